//! Aerial block planning: parallel east–west strips of nadir frames over the world at a chosen GSD, with the
//! forward and side overlaps photogrammetric blocks are flown with (60 % / 30 %).

use plumbline_geo::camera::Pinhole;
use std::f64::consts::PI;

use nalgebra::{UnitQuaternion, Vector3};
use plumbline_geo::{Camera, Map, MapFromCamera, OmegaPhiKappa, Point3, Rotation};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::world::World;

/// How to fly a block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockSpec {
    /// Ground sample distance at the principal point, metres.
    pub gsd: f64,
    /// Share of an image overlapping the next one in its strip.
    pub forward_overlap: f64,
    /// Share of an image overlapping the neighbouring strip.
    pub side_overlap: f64,
}

impl BlockSpec {
    /// 12 cm GSD, 60 % forward and 30 % side overlap.
    pub fn standard() -> Self {
        Self { gsd: 0.12, forward_overlap: 0.6, side_overlap: 0.3 }
    }
}

/// The exterior orientations of a block covering the world (plus one image of margin all round).
/// Strips run east–west (image x along track); every other strip is flown westward (κ = 180°).
pub fn plan_block(world: &World, cam: &Pinhole, spec: &BlockSpec) -> Vec<MapFromCamera> {
    let height = world.config.ground_height + spec.gsd * cam.fx;
    let along = f64::from(cam.width) * spec.gsd;
    let across = f64::from(cam.height) * spec.gsd;
    let base = (1.0 - spec.forward_overlap).max(0.05) * along;
    let spacing = (1.0 - spec.side_overlap).max(0.05) * across;
    let (lo, hi) = world.bounds();
    let count = |extent: f64, step: f64| ((extent / step).ceil() as usize).max(1) + 1;
    let (n_along, n_strips) = (count(hi[0] - lo[0] + along, base), count(hi[1] - lo[1] + across, spacing));
    let (e0, n0) = (lo[0] - along / 2.0, lo[1] - across / 2.0);
    let mut poses = Vec::with_capacity(n_along * n_strips);
    for s in 0..n_strips {
        let north = n0 + s as f64 * spacing;
        let westward = s % 2 == 1;
        let rotation = strip_rotation(westward);
        for k in 0..n_along {
            let k = if westward { n_along - 1 - k } else { k };
            poses.push(MapFromCamera::new(rotation, Point3::new(e0 + k as f64 * base, north, height)));
        }
    }
    poses
}

/// The nadir attitude of a strip: κ = 0 flying east, κ = 180° flying west.
pub fn strip_rotation(westward: bool) -> Rotation<Map, Camera> {
    let level = OmegaPhiKappa::from_degrees(0.0, 0.0, 0.0).to_rotation();
    // κ = 180° as a turn about the camera axis: `OmegaPhiKappa::to_rotation` goes through nalgebra's
    // iterative `UnitQuaternion::from_matrix`, which does not converge for half turns.
    let half_turn =
        Rotation::<Camera, Camera>::from_quaternion(UnitQuaternion::from_axis_angle(&Vector3::z_axis(), PI));
    if westward { level.then_from(&half_turn) } else { level }
}

/// Errors of an aerial triangulation: the orientations a real block would be delivered with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtErrors {
    /// Standard deviation of each projection-centre coordinate, metres.
    pub position_m: f64,
    /// Standard deviation of each rotation angle (about the camera x, y, z axes), radians.
    pub angle_rad: f64,
}

impl AtErrors {
    /// A good AT: 3 cm and 3 arcseconds.
    pub fn typical() -> Self {
        Self { position_m: 0.03, angle_rad: (3.0f64 / 3600.0).to_radians() }
    }
}

/// The true orientations with independent Gaussian AT errors (seeded): what the campaign reports.
pub fn perturb_block(poses: &[MapFromCamera], errors: &AtErrors, seed: u64) -> Vec<MapFromCamera> {
    let mut normal = normal_source(seed);
    poses.iter().map(|p| perturb_with(p, errors, &mut normal)).collect()
}

/// One true orientation with Gaussian AT errors drawn from their own stream of `seed` (frames of a block
/// made piece by piece, e.g. the `city` preset's, each with a seed of its own).
pub fn perturb_pose(pose: &MapFromCamera, errors: &AtErrors, seed: u64) -> MapFromCamera {
    perturb_with(pose, errors, &mut normal_source(seed))
}

/// Standard normal draws (Box–Muller) from a seeded stream.
fn normal_source(seed: u64) -> impl FnMut() -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xAE71_A100);
    move || {
        let (u1, u2): (f64, f64) = (rng.random_range(f64::MIN_POSITIVE..1.0), rng.random_range(0.0..1.0));
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// The pose moved by three position and three angle errors, in that order of draws.
fn perturb_with(p: &MapFromCamera, errors: &AtErrors, normal: &mut impl FnMut() -> f64) -> MapFromCamera {
    let dp = Vector3::new(normal(), normal(), normal()) * errors.position_m;
    let da = Vector3::new(normal(), normal(), normal()) * errors.angle_rad;
    let turn = Rotation::<Camera, Camera>::from_quaternion(UnitQuaternion::from_scaled_axis(da));
    MapFromCamera::new(p.rotation.then_from(&turn), Point3::from_vector(p.translation.p + dp))
}
