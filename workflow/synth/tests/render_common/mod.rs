//! Shared fixtures of the rendering tests: a world, a vehicle pose beside a pole, the sensor mounts.
#![allow(clippy::unwrap_used, dead_code)]

use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::{Attitude, MapFromBody, Point3};
use plumbline_synth::world::polyline;
use plumbline_synth::world::{Pole, PoleClass, Preset, World, WorldConfig};

/// The tiny world of a seed.
pub fn world(seed: u64) -> World {
    World::generate(&WorldConfig::new(Preset::Tiny, seed)).unwrap()
}

/// The IMU 1 m above the road at (e, n), heading in radians.
pub fn body_at(w: &World, e: f64, n: f64, heading: f64) -> MapFromBody {
    MapFromBody::new(Attitude::new(0.0, 0.0, heading).to_rotation(), Point3::new(e, n, w.config.ground_height + 1.0))
}

/// Panorama camera on a mast: 1.9 m above the IMU (2.9 m above the road), slightly misaligned.
pub fn pano_mount() -> CameraMount {
    CameraMount::new([0.6, 0.05, -1.9], &Boresight::from_degrees(0.3, -0.2, 0.4))
}

/// Side-looking depth camera, 1 m above the IMU, looking right (Meyer et al. 2023: the right-hand camera).
pub fn depth_mount() -> CameraMount {
    CameraMount::new([0.2, 0.9, -1.0], &Boresight::from_degrees(0.0, 0.5, 90.0))
}

/// Street lights with no other object within 6 m, and the vehicle pose `dist` metres from each, the pole to
/// its right, standing on the carriageway side.
pub fn lonely_lights(w: &World, dist: f64) -> Vec<(Pole, MapFromBody)> {
    w.poles
        .iter()
        .filter(|p| p.class == PoleClass::StreetLight)
        .filter(|p| w.poles.iter().all(|q| q.id == p.id || polyline::dist(q.base, p.base) > 6.0 + q.crown))
        .filter_map(|p| {
            let st = w.streets.iter().min_by(|a, b| {
                let ta = polyline::nearest(&a.points, &a.cum, p.base).t.abs();
                let tb = polyline::nearest(&b.points, &b.cum, p.base).t.abs();
                ta.total_cmp(&tb)
            })?;
            let station = polyline::nearest(&st.points, &st.cum, p.base);
            let left = [-station.tangent[1], station.tangent[0]];
            let side = station.t.signum();
            // Unit vector from the vehicle to the pole: away from the centreline.
            let u = [left[0] * side, left[1] * side];
            let (e, n) = (p.base[0] - u[0] * dist, p.base[1] - u[1] * dist);
            // Heading whose right-hand side is u: forward f = (−u_n, u_e).
            let heading = (-u[1]).atan2(u[0]);
            let clear = w.cars.iter().all(|c| !c.shape.contains([e, n], 2.0));
            clear.then(|| (p.clone(), body_at(w, e, n, heading)))
        })
        .collect()
}
