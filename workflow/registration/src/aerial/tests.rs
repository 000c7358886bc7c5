//! Tests of the MM ↔ aerial registration on a synthetic street scene with known answers: a 3 cm north-up
//! ortho-image of the MM epoch whose georeferencing is shifted by a known DG offset, registered against
//! aerial frames (rendered with the true orientations, registered with the AT-perturbed ones) and against a
//! true orthophoto.

use std::sync::OnceLock;

use plumbline_imaging::corners::Foerstner;
use plumbline_imaging::ortho::GroundGrid;
use plumbline_imaging::{GrayImage, Mask};
use plumbline_synth::aerial::{block, small_format};
use plumbline_synth::ortho::{OrthoGrid, render_orthophoto};
use plumbline_synth::render::{AerialOptics, AtErrors, BlockSpec, Scene, render_aerial};
use plumbline_synth::world::{Preset, StreetClass, World, WorldConfig};

use nalgebra::{UnitQuaternion, Vector3};
use plumbline_geo::camera::{CameraModel, Pinhole};
use plumbline_geo::{Camera, MapFromCamera, Point3, Rotation};

use super::*;

/// The DG error of the MM patch: its georeferencing is this far off the truth, metres (E, N).
const DG_OFFSET: [f64; 2] = [0.62, -0.5];
/// MM patch size, 3 cm pixels (21 m).
const PATCH_PX: usize = 700;
/// How far the recovered offset may be off with AT-perturbed orientations: AtErrors::typical gives each frame
/// σ = 3 cm per centre coordinate and 3″ (2.2 cm on the ground from 1500 m), so a point from two frames is
/// off by about 2.6 cm per coordinate (1σ) in the mean; this is ≈ 3σ of the 2-D miss.
const AT_TOLERANCE: f64 = 0.1;
/// Two aerial pixels at 12 cm: the paper's correctness bound.
const CORRECT_M: f64 = 0.24;

/// A deterministic scatter in [−1, 1) for test data (`k`-th draw of stream `salt`).
pub(super) fn scatter(k: usize, salt: u64) -> f64 {
    let x = (k as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15).wrapping_add(salt.wrapping_mul(0xbf58_476d));
    ((x >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

/// The synthetic scene every test shares.
struct Fixture {
    world: World,
    /// True ground position of the patch centre.
    truth_centre: [f64; 2],
    image: GrayImage,
    valid: Mask,
    /// The DG (shifted) grid of the patch.
    grid: GroundGrid,
    /// The true grid of the same pixels.
    truth: GroundGrid,
    points: Vec<PatchPoint>,
    frames: Vec<AerialFrame>,
    /// The true orientations of `frames` (they are rendered with these).
    truth_poses: Vec<MapFromCamera>,
}

fn gray(rgb: &[u8]) -> Vec<f32> {
    rgb.chunks_exact(3).map(|p| 0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2])).collect()
}

/// A location 7 m past the junction area along an arterial: stop line, zebra crossing, lane markings.
fn street_location(world: &World) -> [f64; 2] {
    let st = world.streets.iter().find(|s| s.class == StreetClass::Arterial && s.markings).expect("an arterial");
    let j = &world.junctions[st.from as usize];
    let (a, b) = (st.points[0], st.points[1]);
    let len = (b[0] - a[0]).hypot(b[1] - a[1]);
    let along = j.radius + 7.0;
    [a[0] + (b[0] - a[0]) / len * along, a[1] + (b[1] - a[1]) / len * along]
}

fn mm_patch(world: &World, centre: [f64; 2]) -> (GrayImage, GroundGrid) {
    let truth = GroundGrid::new(centre, 0.03, PATCH_PX, PATCH_PX, 0.0).unwrap();
    let half = PATCH_PX as f64 * 0.03 / 2.0;
    let og = OrthoGrid {
        west: centre[0] - half,
        north: centre[1] + half,
        gsd: 0.03,
        width: PATCH_PX as u32,
        height: PATCH_PX as u32,
    };
    let rgb = render_orthophoto(&Scene::mobile(world), &og);
    (GrayImage::new(PATCH_PX, PATCH_PX, gray(rgb.as_raw())).unwrap(), truth)
}

/// Aerial frames whose image contains the location, rendered with the truth, oriented as the AT reports;
/// with their true orientations.
fn aerial_frames(world: &World, centre: [f64; 2]) -> (Vec<AerialFrame>, Vec<MapFromCamera>) {
    let (cam, frames) = block(world, &small_format(600, 450), &BlockSpec::standard(), &AtErrors::typical(), 5).unwrap();
    let p = Point3::new(centre[0], centre[1], world.config.ground_height);
    frames
        .iter()
        .enumerate()
        .filter(|(_, f)| {
            let c = f.truth.inverse().transform_point(&p) - Point3::origin();
            cam.project(&c).is_some_and(|px| px.u > 60.0 && px.v > 60.0 && px.u < 540.0 && px.v < 390.0)
        })
        .map(|(i, f)| {
            let image = render_frame(world, &cam, &f.truth, 100 + i as u64);
            (AerialFrame { id: f.id.clone(), image, origin: [0, 0], camera: cam, pose: f.reported }, f.truth)
        })
        .unzip()
}

/// One aerial frame of the aerial epoch through `cam` at the true orientation `pose`.
fn render_frame(world: &World, cam: &Pinhole, pose: &MapFromCamera, seed: u64) -> GrayImage {
    let rgb = render_aerial(&Scene::aerial(world), cam, pose, &AerialOptics::typical(seed));
    GrayImage::new(cam.width as usize, cam.height as usize, gray(rgb.as_raw())).unwrap()
}

fn fixture() -> &'static Fixture {
    static FIXTURE: OnceLock<Fixture> = OnceLock::new();
    FIXTURE.get_or_init(|| {
        let world = World::generate(&WorldConfig::new(Preset::Tiny, 11)).unwrap();
        let truth_centre = street_location(&world);
        let (image, truth) = mm_patch(&world, truth_centre);
        let dg_centre = [truth_centre[0] + DG_OFFSET[0], truth_centre[1] + DG_OFFSET[1]];
        let grid = GroundGrid { centre: dg_centre, ..truth };
        let valid = Mask::from_fn(PATCH_PX, PATCH_PX, |_, _| true);
        let corners = Foerstner::default().detect(&image).unwrap();
        let h = world.config.ground_height;
        let points = corners
            .iter()
            .enumerate()
            .map(|(index, c)| {
                let [e, n] = grid.to_map(c.u, c.v);
                PatchPoint { index, pixel: [c.u, c.v], map: [e, n, h], rise: 0.0 }
            })
            .collect();
        let (frames, truth_poses) = aerial_frames(&world, truth_centre);
        Fixture { world, truth_centre, image, valid, grid, truth, points, frames, truth_poses }
    })
}

impl Fixture {
    fn patch(&self) -> MmPatch<'_> {
        MmPatch { image: &self.image, valid: &self.valid, grid: &self.grid, points: &self.points, position_sigma: 0.5 }
    }

    /// Horizontal error of each result against the true ground position of its MM pixel.
    fn errors(&self, outcome: &AerialOutcome) -> Vec<f64> {
        outcome
            .points
            .iter()
            .map(|p| {
                let px = self.points[p.index].pixel;
                let [e, n] = self.truth.to_map(px[0], px[1]);
                (p.position[0] - e).hypot(p.position[1] - n)
            })
            .collect()
    }

    fn patch_with_sigma(&self, position_sigma: f64) -> MmPatch<'_> {
        MmPatch { position_sigma, ..self.patch() }
    }

    /// The mean horizontal difference MM (DG) position − aerial position: the DG offset when both are right.
    fn mean_offset(&self, outcome: &AerialOutcome) -> [f64; 2] {
        let n = outcome.points.len() as f64;
        let sum = outcome.points.iter().fold([0.0, 0.0], |s, p| {
            let m = self.points[p.index].map;
            [s[0] + m[0] - p.position[0], s[1] + m[1] - p.position[1]]
        });
        [sum[0] / n, sum[1] / n]
    }

    /// Checks shared by every successful registration: enough points, all correct, the offset recovered
    /// to within `offset_tolerance` metres.
    fn check_matched(&self, outcome: &AerialOutcome, min_points: usize, offset_tolerance: f64) {
        assert!(outcome.discarded.is_none(), "{:?}", outcome.discarded);
        let errors = self.errors(outcome);
        let correct = errors.iter().filter(|&&e| e < CORRECT_M).count();
        let worst = errors.iter().fold(0.0f64, |a, &b| a.max(b));
        assert!(outcome.points.len() >= min_points, "{} of {} points", outcome.points.len(), self.points.len());
        // Target: ≥ 99 % of the correspondences within two aerial pixels of the truth.
        assert!(
            correct as f64 >= 0.99 * errors.len() as f64,
            "{correct} of {} correct, worst {worst:.3} m",
            errors.len()
        );
        let d = self.mean_offset(outcome);
        let miss = (d[0] - DG_OFFSET[0]).hypot(d[1] - DG_OFFSET[1]);
        assert!(miss < offset_tolerance, "recovered DG offset {d:?}, true {DG_OFFSET:?}");
    }
}

#[test]
fn frames_recover_the_true_positions_and_the_dg_offset() {
    let f = fixture();
    assert!(f.frames.len() >= 2, "{} frames", f.frames.len());
    let outcome = register_patch(&f.patch(), &AerialReference::Frames(f.frames.clone()), &AerialConfig::default());
    // Most corners lie on road paint and kerbs that both epochs show.
    f.check_matched(&outcome, f.points.len() / 2, AT_TOLERANCE);
    for p in &outcome.points {
        assert!(p.observations.len() >= 2 && p.covariance[0][0].sqrt() < 0.05, "{p:?}");
    }
    // Every overlapping frame passed the initial transformation with the DG offset as its translation.
    assert_eq!(outcome.images.len(), f.frames.len());
    for d in &outcome.images {
        let offset = d.offset_m.expect("an initial transformation");
        assert!(d.passed && d.rejection.is_none() && d.correspondences >= 10, "{d:?}");
        assert!((offset - DG_OFFSET[0].hypot(DG_OFFSET[1])).abs() < 0.15, "{d:?}");
    }
}

#[test]
fn one_frame_gives_single_rays_that_hold_the_position_across_the_ray() {
    // Only one frame sees the patch (or only one passes): its points enter as single rays.
    let f = fixture();
    let one = AerialReference::Frames(f.frames[..1].to_vec());
    let outcome = register_patch(&f.patch(), &one, &AerialConfig::default());
    f.check_matched(&outcome, f.points.len() / 3, AT_TOLERANCE);
    for p in &outcome.points {
        assert_eq!(p.observations.len(), 1, "{p:?}");
        let mut sigmas: Vec<f64> =
            nalgebra::Matrix3::from(p.covariance).symmetric_eigen().eigenvalues.iter().map(|v| v.sqrt()).collect();
        sigmas.sort_by(f64::total_cmp);
        assert!(sigmas[1] < 0.05 && (sigmas[2] - 10.0).abs() < 1e-6, "σ across, across, along: {sigmas:?}");
    }
    // The rule of Jende et al. (2017), two frames at least: the patch is discarded.
    let two = AerialConfig { single_ray_sigma_m: None, ..AerialConfig::default() };
    let outcome = register_patch(&f.patch(), &one, &two);
    assert_eq!(outcome.discarded, Some(AerialDiscard::TooFewPlausible { passed: 1, needed: 2 }));
}

#[test]
fn frames_with_their_true_orientations_recover_the_offset_to_a_centimetre() {
    // Without AT errors nothing but matching noise remains: the pipeline itself adds no bias.
    let f = fixture();
    let mut frames = f.frames.clone();
    for (frame, truth) in frames.iter_mut().zip(&f.truth_poses) {
        frame.pose = *truth;
    }
    let outcome = register_patch(&f.patch(), &AerialReference::Frames(frames), &AerialConfig::default());
    f.check_matched(&outcome, f.points.len() / 2, 0.01);
    // The height from two nadir frames is weak, and its σ says how weak: a parallax error of σ_px·√2
    // pixels moves the point by that many GSDs times height / base (Jende et al. 2017 §3.9: covariance from the
    // normal matrix).
    assert_eq!(f.frames.len(), 2, "the expected σ below is for two frames");
    let (a, b) = (f.truth_poses[0].translation, f.truth_poses[1].translation);
    let above = a.z() - f.world.config.ground_height;
    let gsd = above / f.frames[0].camera.fx;
    let expected = AerialConfig::default().pixel_sigma * 2f64.sqrt() * gsd * above / (a - b).norm();
    let mut sz: Vec<f64> = outcome.points.iter().map(|p| p.covariance[2][2].sqrt()).collect();
    sz.sort_by(f64::total_cmp);
    assert!((sz[sz.len() / 2] / expected - 1.0).abs() < 0.1, "median σH {} vs {expected}", sz[sz.len() / 2]);
    for p in &outcome.points {
        let (dz, sigma) = (p.position[2] - f.world.config.ground_height, p.covariance[2][2].sqrt());
        assert!(dz.abs() < 3.0 * sigma, "height error {dz} m, σ {sigma} m");
    }
}

#[test]
fn a_frame_turned_about_its_axis_is_rotated_into_and_still_registered() {
    // The second frame flown the other way round (κ + 150°): the MM patch must be rotated to match it.
    let f = fixture();
    let turn = Rotation::<Camera, Camera>::from_quaternion(UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 2.6));
    let mut frames = f.frames.clone();
    let truth = MapFromCamera::new(f.truth_poses[1].rotation.then_from(&turn), f.truth_poses[1].translation);
    frames[1].image = render_frame(&f.world, &frames[1].camera, &truth, 77);
    frames[1].pose = MapFromCamera::new(frames[1].pose.rotation.then_from(&turn), frames[1].pose.translation);
    let outcome = register_patch(&f.patch(), &AerialReference::Frames(frames), &AerialConfig::default());
    f.check_matched(&outcome, f.points.len() / 3, AT_TOLERANCE);
    assert!(outcome.images.iter().all(|d| d.passed), "{:?}", outcome.images);
}

#[test]
fn a_dg_offset_beyond_the_plausibility_bound_discards_the_patch() {
    // The patch claims 5 cm DG precision and the σ floor is off: the 0.8 m offset exceeds 3 · 0.05 + 0.5 m
    // in every frame.
    let f = fixture();
    let trusting = Plausibility { min_position_sigma: 0.0, ..Plausibility::default() };
    let config = AerialConfig { plausibility: trusting, ..AerialConfig::default() };
    let outcome = register_patch(&f.patch_with_sigma(0.05), &AerialReference::Frames(f.frames.clone()), &config);
    assert_eq!(outcome.discarded, Some(AerialDiscard::TooFewPlausible { passed: 0, needed: 1 }));
    assert!(outcome.points.is_empty());
    for d in &outcome.images {
        let Some(ImageRejection::Implausible { offset_m, bound_m, .. }) = d.rejection else { panic!("{d:?}") };
        assert!((offset_m - 0.8).abs() < 0.15 && (bound_m - 0.65).abs() < 1e-12, "{d:?}");
    }
    // With the default floor (σ ≥ 0.5 m: a reported σ is blind to multipath jumps) the same patch registers.
    let floored =
        register_patch(&f.patch_with_sigma(0.05), &AerialReference::Frames(f.frames.clone()), &AerialConfig::default());
    f.check_matched(&floored, f.points.len() / 3, AT_TOLERANCE);
    assert!(floored.images.iter().all(|d| d.passed && d.offset_m.is_some_and(|o| (o - 0.8).abs() < 0.15)));
}

#[test]
fn a_patch_with_too_few_correspondences_in_all_images_together_is_discarded() {
    let f = fixture();
    let needed = f.frames.len() * f.points.len() + 1;
    let config = AerialConfig { min_correspondences: needed, ..AerialConfig::default() };
    let outcome = register_patch(&f.patch(), &AerialReference::Frames(f.frames.clone()), &config);
    let Some(AerialDiscard::TooFewCorrespondences { images: 0, needed: 1, correspondences, needed_correspondences }) =
        outcome.discarded
    else {
        panic!("{:?}", outcome.discarded)
    };
    assert!(correspondences < needed && needed_correspondences == needed, "{correspondences} of {needed}");
    for d in &outcome.images {
        assert!(d.passed, "the initial transformation still passes: {d:?}");
        assert!(matches!(d.rejection, Some(ImageRejection::TooFewCorrespondences { .. })), "{d:?}");
    }
}

#[test]
fn ten_correspondences_in_all_images_together_suffice_where_no_single_image_has_ten() {
    // Jende et al. 2017 §3.8's ten correspondences stabilise the one transformation all images share (the patch's
    // DG error): asking for one more than the best image has, the images together still register.
    let f = fixture();
    let reference = AerialReference::Frames(f.frames.clone());
    let plain = register_patch(&f.patch(), &reference, &AerialConfig::default());
    let per_image: Vec<usize> = plain.images.iter().map(|d| d.correspondences).collect();
    let needed = per_image.iter().max().copied().unwrap_or(0) + 1;
    assert!(per_image.len() >= 2 && needed <= per_image.iter().sum::<usize>(), "{per_image:?}");
    let config = AerialConfig { min_correspondences: needed, ..AerialConfig::default() };
    let outcome = register_patch(&f.patch(), &reference, &config);
    f.check_matched(&outcome, f.points.len() / 2, AT_TOLERANCE);
    assert_eq!(outcome.points, plain.points, "the same correspondences as with the default");
}

#[test]
fn orthophoto_windows_give_positions_from_the_geotransform_and_terrain() {
    let f = fixture();
    let c = f.truth_centre;
    // A 48 m window of a 12 cm true orthophoto of the aerial epoch, and a 1 m terrain grid 0.3 m above the
    // ground (so the height provably comes from the terrain, not from the patch).
    let grid = OrthoGrid { west: c[0] - 24.3, north: c[1] + 23.8, gsd: 0.12, width: 400, height: 400 };
    let rgb = render_orthophoto(&Scene::aerial(&f.world), &grid);
    let terrain_height = f.world.config.ground_height + 0.3;
    let terrain = Terrain {
        heights: vec![terrain_height as f32; 100 * 100],
        width: 100,
        height: 100,
        geotransform: [c[0] - 50.0, 1.0, 0.0, c[1] + 50.0, 0.0, -1.0],
    };
    let ortho = Orthophoto {
        id: "ortho".into(),
        image: GrayImage::new(400, 400, gray(rgb.as_raw())).unwrap(),
        geotransform: grid.geotransform(),
        terrain: Some(terrain),
    };
    let outcome = register_patch(&f.patch(), &AerialReference::Orthophoto(ortho.clone()), &AerialConfig::default());
    // A true orthophoto has no orientation error: the offset comes back to a centimetre.
    f.check_matched(&outcome, f.points.len() / 2, 0.01);
    assert_eq!(outcome.images.len(), 1);
    for p in &outcome.points {
        assert!((p.position[2] - terrain_height).abs() < 1e-4, "{p:?}");
        // σ from the GSD: 0.5 px · 0.12 m.
        assert!((p.covariance[0][0].sqrt() - 0.06).abs() < 1e-9 && p.observations[0].frame == "ortho");
    } // Without a terrain model the patch's own height stands in, with a σ that says it is the DG height.
    let bare = Orthophoto { terrain: None, ..ortho };
    let outcome = register_patch(&f.patch(), &AerialReference::Orthophoto(bare), &AerialConfig::default());
    assert!(!outcome.points.is_empty());
    for p in &outcome.points {
        let sz = p.covariance[2][2].sqrt();
        assert!((p.position[2] - f.world.config.ground_height).abs() < 1e-9 && sz > 1.5, "{p:?}");
    }
}

#[test]
fn bad_patches_and_missing_overlap_are_reported_not_panicked() {
    let f = fixture();
    let frames = AerialReference::Frames(f.frames.clone());
    let none = register_patch(&MmPatch { points: &[], ..f.patch() }, &frames, &AerialConfig::default());
    assert!(matches!(none.discarded, Some(AerialDiscard::InvalidPatch { ref reason }) if reason == "no points"));
    let small = Mask::from_fn(10, 10, |_, _| true);
    let wrong = register_patch(&MmPatch { valid: &small, ..f.patch() }, &frames, &AerialConfig::default());
    assert!(
        matches!(wrong.discarded, Some(AerialDiscard::InvalidPatch { ref reason }) if reason.contains("valid mask"))
    );
    // The same patch 5 km away: no frame sees it.
    let far = GroundGrid { centre: [f.grid.centre[0] + 5000.0, f.grid.centre[1]], ..f.grid };
    let moved: Vec<PatchPoint> =
        f.points.iter().map(|p| PatchPoint { map: [p.map[0] + 5000.0, p.map[1], p.map[2]], ..*p }).collect();
    let away = register_patch(&MmPatch { grid: &far, points: &moved, ..f.patch() }, &frames, &AerialConfig::default());
    assert_eq!(away.discarded, Some(AerialDiscard::NoOverlap));
    assert!(away.images.is_empty());
}

#[test]
fn masked_cells_give_no_points_and_a_broken_frame_does_not_sink_the_others() {
    // The mask flags the western 200 columns (6 m) as vehicle while their pixels still show the street: any
    // point found there would prove the mask ignored.
    let f = fixture();
    let valid = Mask::from_fn(PATCH_PX, PATCH_PX, |c, _| c >= 200);
    let mut frames = f.frames.clone();
    let mut broken = frames[0].clone();
    broken.id = "broken".into();
    broken.image = GrayImage::filled(601, 450, 100.0);
    frames.push(broken);
    let patch = MmPatch { valid: &valid, ..f.patch() };
    let outcome = register_patch(&patch, &AerialReference::Frames(frames), &AerialConfig::default());
    let inside = f.points.iter().filter(|p| p.pixel[0] >= 200.0).count();
    f.check_matched(&outcome, inside / 2, AT_TOLERANCE);
    // The template (6 px at 12 cm = 24 MM px) and the blur must stay clear of the masked cells too.
    assert!(outcome.points.iter().all(|p| f.points[p.index].pixel[0] > 220.0));
    let broken = outcome.images.iter().find(|d| d.frame == "broken").expect("a diagnostic for the broken frame");
    assert!(matches!(broken.rejection, Some(ImageRejection::InvalidImage { ref reason }) if reason.contains("601")));
}

#[test]
fn without_kaze_features_the_whole_patch_correlation_finds_the_translation() {
    // A KAZE threshold nothing reaches: no features, so the correlation fallback must carry step 6.
    let f = fixture();
    let kaze = plumbline_imaging::kaze::KazeConfig { threshold: 1e3, ..AerialConfig::default().kaze };
    let config = AerialConfig { kaze, ..AerialConfig::default() };
    let frames = AerialReference::Frames(f.frames.clone());
    let outcome = register_patch(&f.patch(), &frames, &config);
    f.check_matched(&outcome, f.points.len() / 2, AT_TOLERANCE);
    for d in &outcome.images {
        let ncc = d.fallback_ncc.expect("the fallback was used");
        assert!(d.passed && d.initial_inliers == 0 && ncc >= config.min_correlation, "{d:?}");
        assert!((d.offset_m.unwrap() - DG_OFFSET[0].hypot(DG_OFFSET[1])).abs() < 0.15, "{d:?}");
    }
    // Without the fallback (and without the DG-bounded search) the same images fail for want of features.
    let off =
        register_patch(&f.patch(), &frames, &AerialConfig { correlation_fallback: false, dg_search: false, ..config });
    assert_eq!(off.discarded, Some(AerialDiscard::TooFewPlausible { passed: 0, needed: 1 }));
    assert!(off.images.iter().all(|d| matches!(d.rejection, Some(ImageRejection::FewFeatures { mm: 0, aerial: 0 }))));
}

#[test]
fn without_an_initial_transformation_the_dg_bounded_search_finds_the_offset_and_no_more() {
    // No KAZE features and no whole-patch correlation: every corner is searched over the whole DG bound
    // (σ floor 0.5 m → 2.0 m) and the per-image RANSAC finds the common translation, the 0.8 m DG offset.
    let f = fixture();
    let kaze = plumbline_imaging::kaze::KazeConfig { threshold: 1e3, ..AerialConfig::default().kaze };
    let config = AerialConfig { kaze, correlation_fallback: false, ..AerialConfig::default() };
    let frames = AerialReference::Frames(f.frames.clone());
    let outcome = register_patch(&f.patch(), &frames, &config);
    // Fewer corners than with a transformation (a wide search finds look-alikes), all of them correct.
    f.check_matched(&outcome, f.points.len() / 3, AT_TOLERANCE);
    for d in &outcome.images {
        assert!(d.passed && d.initial_inliers == 0 && d.fallback_ncc.is_none(), "{d:?}");
        assert!((d.offset_m.unwrap() - DG_OFFSET[0].hypot(DG_OFFSET[1])).abs() < 0.15, "{d:?}");
    }
    // A bound smaller than the offset (σ 5 cm trusted: 0.65 m < 0.8 m): the square search window still
    // reaches the true matches, but their transformation fails the plausibility check like a KAZE one would.
    let trusting = Plausibility { min_position_sigma: 0.0, ..Plausibility::default() };
    let short = register_patch(&f.patch_with_sigma(0.05), &frames, &AerialConfig { plausibility: trusting, ..config });
    assert_eq!(short.discarded, Some(AerialDiscard::TooFewPlausible { passed: 0, needed: 1 }), "{:?}", short.images);
    for d in &short.images {
        let Some(ImageRejection::Implausible { offset_m, bound_m, .. }) = d.rejection else { panic!("{d:?}") };
        assert!((offset_m - 0.8).abs() < 0.15 && (bound_m - 0.65).abs() < 1e-12, "{d:?}");
    }
}

/// A frame held as the window around the patch (as the worker reads large frames) registers exactly
/// as the whole frame does: positions, observations and diagnostics in full-frame pixels.
#[test]
fn frame_windows_register_exactly_as_whole_frames() {
    let f = fixture();
    let whole = register_patch(&f.patch(), &AerialReference::Frames(f.frames.clone()), &AerialConfig::default());
    let windows: Vec<AerialFrame> = f
        .frames
        .iter()
        .map(|frame| {
            let p = Point3::new(f.grid.centre[0], f.grid.centre[1], f.world.config.ground_height);
            let c = frame.pose.inverse().transform_point(&p) - Point3::origin();
            let px = frame.camera.project(&c).expect("the patch projects into the frame");
            // 220 px around the patch centre: the 21 m patch (~175 aerial px) plus the search margins.
            let (c0, r0) = ((px.u - 220.0).max(0.0) as usize, (px.v - 220.0).max(0.0) as usize);
            let (c1, r1) = (((px.u + 220.0) as usize).min(600), ((px.v + 220.0) as usize).min(450));
            let image = GrayImage::from_fn(c1 - c0, r1 - r0, |c, r| frame.image.get(c0 + c, r0 + r));
            AerialFrame { image, origin: [c0, r0], ..frame.clone() }
        })
        .collect();
    assert!(windows.iter().any(|w| w.origin != [0, 0] && w.image.width() < 600));
    let windowed = register_patch(&f.patch(), &AerialReference::Frames(windows), &AerialConfig::default());
    assert!(!whole.points.is_empty());
    assert_eq!(format!("{windowed:?}"), format!("{whole:?}"));
}
