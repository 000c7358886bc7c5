//! The aerial block of a campaign as values: the metric camera, the frames' ids, their true and reported
//! (AT-perturbed) orientations, and the exterior-orientation CSV (`image_id,file,x,y,z,omega_deg,phi_deg,
//! kappa_deg`; campaign CRS, ARCHITECTURE.md § Angles).

use std::fmt::Write as _;

use plumbline_geo::camera::{CameraError, MetricInterior, Pinhole};
use plumbline_geo::{MapFromCamera, OmegaPhiKappa};

use crate::render::{AtErrors, BlockSpec, perturb_block, plan_block};
use crate::world::World;

/// A small-format metric camera: 50 mm, 4 µm pixels (12 500 px focal length), no distortion.
pub fn small_format(width: u32, height: u32) -> MetricInterior {
    MetricInterior { focal_mm: 50.0, xp_mm: 0.0, yp_mm: 0.0, k1: 0.0, k2: 0.0, pixel_mm: 0.004, width, height }
}

/// Radial distortion of [`small_format_distorted`]: K1 in mm⁻², K2 in mm⁻⁴ (together about −1.1 px at the
/// corners of a 1000 × 750 frame: small, as after a good calibration, but large enough that ignoring it
/// costs a pixel, 12 cm on the ground).
pub const SMALL_FORMAT_DISTORTION: (f64, f64) = (-4.0e-4, 2.0e-5);

/// [`small_format`] with the radial distortion [`SMALL_FORMAT_DISTORTION`] (what `plumbline simulate` flies).
pub fn small_format_distorted(width: u32, height: u32) -> MetricInterior {
    let (k1, k2) = SMALL_FORMAT_DISTORTION;
    MetricInterior { k1, k2, ..small_format(width, height) }
}

/// One frame of the block.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Image id (also the file stem).
    pub id: String,
    /// The true orientation (what the image is rendered with).
    pub truth: MapFromCamera,
    /// The orientation the AT reports (truth plus AT errors).
    pub reported: MapFromCamera,
}

/// The block over `world` flown with `spec`, with seeded AT errors.
pub fn block(
    world: &World,
    interior: &MetricInterior,
    spec: &BlockSpec,
    errors: &AtErrors,
    seed: u64,
) -> Result<(Pinhole, Vec<Frame>), CameraError> {
    let cam = Pinhole::from_metric(interior)?;
    let truth = plan_block(world, &cam, spec);
    let reported = perturb_block(&truth, errors, seed);
    let frames = truth
        .into_iter()
        .zip(reported)
        .enumerate()
        .map(|(i, (truth, reported))| Frame { id: format!("aerial{i:04}"), truth, reported })
        .collect();
    Ok((cam, frames))
}

/// The exterior-orientation CSV of `frames` (`reported` or true orientations), files `{id}.jpg`.
pub fn exterior_orientation_csv(frames: &[Frame], reported: bool) -> Vec<u8> {
    exterior_orientation_csv_as(frames, reported, "jpg")
}

/// [`exterior_orientation_csv`] with files `{id}.{extension}`.
pub fn exterior_orientation_csv_as(frames: &[Frame], reported: bool, extension: &str) -> Vec<u8> {
    let mut s = String::from("image_id,file,x,y,z,omega_deg,phi_deg,kappa_deg\n");
    for f in frames {
        let pose = if reported { &f.reported } else { &f.truth };
        let opk = OmegaPhiKappa::from_rotation(&pose.rotation);
        let p = pose.translation;
        let _ = writeln!(
            s,
            "{},{}.{extension},{:.4},{:.4},{:.4},{:.7},{:.7},{:.7}",
            f.id,
            f.id,
            p.x(),
            p.y(),
            p.z(),
            opk.omega.to_degrees(),
            opk.phi.to_degrees(),
            opk.kappa.to_degrees()
        );
    }
    s.into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{Preset, WorldConfig};

    #[test]
    fn csv_angles_rebuild_the_reported_rotation() {
        let world = World::generate(&WorldConfig::new(Preset::Tiny, 4)).unwrap();
        let (cam, frames) =
            block(&world, &small_format(400, 300), &BlockSpec::standard(), &AtErrors::typical(), 9).unwrap();
        // 12 cm GSD: flying height = gsd · focal length in pixels above the ground.
        let h = frames[0].truth.translation.z() - world.config.ground_height;
        assert!((h - 0.12 * cam.fx).abs() < 1e-9, "{h}");
        let text = String::from_utf8(exterior_orientation_csv(&frames, true)).unwrap();
        for (line, f) in text.lines().skip(1).zip(&frames) {
            let v: Vec<f64> = line.split(',').skip(2).map(|x| x.parse().unwrap()).collect();
            let r = OmegaPhiKappa::from_degrees(v[3], v[4], v[5]).to_rotation();
            assert!(r.angle_to(&f.reported.rotation) < 1e-8, "{line}");
            assert!((v[0] - f.reported.translation.x()).abs() < 1e-4);
            // The reported orientation differs from the truth by the AT error (a few cm).
            let d = (f.reported.translation - f.truth.translation).norm();
            assert!(d > 1e-4 && d < 0.3, "{d}");
        }
        assert_eq!(text.lines().count(), frames.len() + 1);
    }

    #[test]
    fn the_flown_camera_is_distorted_by_about_a_pixel_at_the_corners() {
        use plumbline_geo::camera::{CameraModel, Pixel};
        let plain = Pinhole::from_metric(&small_format(1000, 750)).unwrap();
        let flown = Pinhole::from_metric(&small_format_distorted(1000, 750)).unwrap();
        let shift = |u: f64, v: f64| {
            let ray = plain.unproject(Pixel { u, v }).unwrap();
            let p = flown.project(&ray).unwrap();
            (p.u - u).hypot(p.v - v)
        };
        let corner = shift(0.5, 0.5);
        assert!((0.8..1.4).contains(&corner), "corner shift {corner} px");
        assert!(shift(500.0, 375.0) < 1e-9, "the principal point does not move");
        assert!(shift(500.0, 200.0) < 0.1 * corner);
    }
}
