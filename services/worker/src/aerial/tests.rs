//! The frame orientation reader against the simulator: interior and exterior orientation as
//! `plumbline simulate` writes them come back as the camera and pose the frames were rendered with.

use plumbline_campaign::tables::read_exterior;
use plumbline_synth::aerial::{Frame, block, exterior_orientation_csv, small_format_distorted};
use plumbline_synth::render::{AtErrors, BlockSpec};
use plumbline_synth::world::{Preset, World, WorldConfig};

use super::*;

/// The simulator's block over the tiny world: its camera and frames, and the world's ground height.
fn simulated_block() -> (Pinhole, Vec<Frame>, f64) {
    let world = World::generate(&WorldConfig::new(Preset::Tiny, 4)).unwrap();
    let interior = small_format_distorted(1000, 750);
    let (cam, frames) = block(&world, &interior, &BlockSpec::standard(), &AtErrors::typical(), 9).unwrap();
    (cam, frames, world.config.ground_height)
}

/// `[aerial.frames.interior]` as `services/cli/src/simulate/aerial.rs` writes it.
fn manifest_interior(m: &MetricInterior) -> InteriorOrientation {
    InteriorOrientation {
        focal_length_mm: m.focal_mm,
        principal_point_mm: [m.xp_mm, m.yp_mm],
        pixel_size_mm: m.pixel_mm,
        k1: m.k1,
        k2: m.k2,
        width_px: m.width,
        height_px: m.height,
    }
}

#[test]
fn the_manifest_interior_gives_the_simulators_camera() {
    let (cam, _, _) = simulated_block();
    assert_eq!(frame_camera(&manifest_interior(&small_format_distorted(1000, 750))).unwrap(), cam);
    // An off-centre principal point (x right, y up in millimetres) moves cx right and cy up.
    let shifted = MetricInterior { xp_mm: 0.08, yp_mm: -0.04, ..small_format_distorted(1000, 750) };
    let c = frame_camera(&manifest_interior(&shifted)).unwrap();
    assert!((c.cx - (500.0 + 20.0)).abs() < 1e-9 && (c.cy - (375.0 + 10.0)).abs() < 1e-9, "{c:?}");
    assert_eq!(c, Pinhole::from_metric(&shifted).unwrap());
}

#[test]
fn the_simulators_exterior_table_reads_back_as_the_reported_poses() {
    let (_, frames, _) = simulated_block();
    let csv = exterior_orientation_csv(&frames, true);
    let table = read_exterior("exterior_orientation.csv", &csv).unwrap();
    assert!(table.skipped.is_empty());
    assert_eq!(table.rows.len(), frames.len());
    for (row, f) in table.rows.iter().zip(&frames) {
        let pose = frame_pose(row);
        // The table rounds angles to 1e-7° (≤ 1.5e-9 rad together) and coordinates to 0.1 mm.
        assert!(pose.rotation.angle_to(&f.reported.rotation) < 2e-9, "{}", row.image_id);
        assert!((pose.translation - f.reported.translation).norm() < 1e-4, "{}", row.image_id);
        // Unrounded angles and centre give the same pose to 1e-9.
        let opk = OmegaPhiKappa::from_rotation(&f.reported.rotation);
        let t = f.reported.translation;
        let exact = ExteriorRow {
            opk_deg: [opk.omega.to_degrees(), opk.phi.to_degrees(), opk.kappa.to_degrees()],
            centre: [t.x(), t.y(), t.z()],
            ..row.clone()
        };
        let pose = frame_pose(&exact);
        assert!(pose.rotation.angle_to(&f.reported.rotation) < 1e-9);
        assert!((pose.translation - t).norm() < 1e-9);
    }
}

#[test]
fn a_frame_sees_the_ground_under_its_centre_and_not_far_away() {
    let (cam, frames, ground) = simulated_block();
    let f = &frames[frames.len() / 2];
    let c = f.truth.translation;
    let below = Point3::new(c.x(), c.y(), ground);
    assert!(sees(&cam, &f.truth, &[below]));
    // The principal point images the nadir point (a nadir frame).
    let d = f.truth.inverse().transform_point(&below);
    let px = cam.project(&(d - Point3::origin())).unwrap();
    assert!((px.u - cam.cx).hypot(px.v - cam.cy) < 0.05 * f64::from(cam.height), "{px:?}");
    // 1000 × 750 px at 12 cm: ±60 m along x; 200 m off is outside, and a point above the camera is not seen.
    let off = Point3::new(c.x() + 200.0, c.y(), ground);
    assert!(!sees(&cam, &f.truth, &[off]));
    assert!(!sees(&cam, &f.truth, &[Point3::new(c.x(), c.y(), c.z() + 100.0)]));
    assert!(sees(&cam, &f.truth, &[off, below]));
}

#[test]
fn a_frame_over_the_budget_or_of_another_size_than_the_interior_orientation_is_skipped() {
    let camera = frame_camera(&manifest_interior(&small_format_distorted(1000, 750))).unwrap();
    let pose = || Pose::new(plumbline_geo::Rotation::identity(), Point3::new(0.0, 0.0, 500.0));
    let png = |w, h| {
        let img = image::GrayImage::from_fn(w, h, |x, y| image::Luma([((x + y) % 256) as u8]));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        bytes::Bytes::from(out.into_inner())
    };
    let want = |id: &str, window| frames::Wanted {
        id: id.into(),
        pose: pose(),
        url: format!("frames/{id}.png"),
        camera,
        window,
    };
    let frame = frames::decode_frame(&want("f1", None), &png(1000, 750)).unwrap();
    assert_eq!((frame.id.as_str(), frame.image.width(), frame.image.height()), ("f1", 1000, 750));
    // A window of it: the same pixels, placed by its origin.
    let window = frames::decode_frame(&want("f1", Some((100, 50, 30, 20))), &png(1000, 750)).unwrap();
    assert_eq!((window.origin, window.image.width(), window.image.height()), ([100, 50], 30, 20));
    assert_eq!(window.image.get(5, 7), frame.image.get(105, 57));
    let small = frames::decode_frame(&want("f2", None), &png(500, 375)).unwrap_err();
    assert_eq!((small.item.as_str(), &small.reason), ("frames/f2.png", &SkipReason::Size));
    assert_eq!(small.detail, "frames/f2.png: 500 × 375 px, expected 1000 × 750 px (the interior orientation's size)");
    // A header claiming more than any aerial camera delivers (600 M px) is refused on the budget.
    let forged = bytes::Bytes::from(plumbline_testkit::images::png_claiming(30_000, 20_000));
    let bomb = frames::decode_frame(&want("f3", None), &forged).unwrap_err();
    assert_eq!(bomb.reason, SkipReason::Size);
    assert!(bomb.detail.starts_with("frames/f3.png: 30000 × 20000 px (600.0 M px) exceeds"), "{}", bomb.detail);
    assert!(bomb.detail.contains("budget of 450.0 M px"), "{}", bomb.detail);
    let garbage = frames::decode_frame(&want("f4", None), &bytes::Bytes::from_static(b"no"));
    assert_eq!(garbage.unwrap_err().reason, SkipReason::Decode);
}
