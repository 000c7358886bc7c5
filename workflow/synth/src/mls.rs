//! A mobile laser scanner along the drive: a profile scanner on the vehicle roof whose mirror turns in the
//! plane across the driving direction, as survey-grade mobile-mapping systems carry. Every profile is cast
//! into the world from the TRUE scanner pose and georeferenced with the DG pose of the same time, so the cloud
//! carries the DG error of its time exactly as a delivered cloud does; each point has its GPS time.
//!
//! A profile is taken as instantaneous (all its points carry the profile's time and pose). Profiles are made
//! only while the vehicle moves (a standing vehicle would pile up profiles of one line), and a point is kept
//! only when its ray hits something within the scanner's range (the sky returns nothing).

use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::trajectory::{PositionInterpolation, Trajectory};
use plumbline_geo::{Camera, Vec3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::motion::Drive;
use crate::observations::normal;
use crate::sensors::{self, Mount, SensorError};
use crate::world::{Epoch, Surface, World};

/// A profile scanner and how it is mounted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProfileScanner {
    /// Scanner centre and orientation on the vehicle. The profile is the scanner frame's x–y plane (camera
    /// conventions: with a zero boresight, z is the body's forward axis, so profiles stand across the drive).
    pub mount: Mount,
    /// Profiles per second.
    pub profile_rate_hz: f64,
    /// Angle between the shots of a profile, degrees.
    pub angular_step_deg: f64,
    /// Farthest range measured, metres.
    pub max_range_m: f64,
    /// One-sigma range noise, metres.
    pub range_sigma_m: f64,
}

impl ProfileScanner {
    /// A survey-grade roof scanner: 2.2 m above the IMU at the vehicle's rear, 200 profiles/s (5 cm apart at
    /// 36 km/h), 0.4° between shots, 1 cm range noise, 60 m range: about 160 000 measured points per second in
    /// a street (a Riegl VUX-1HA runs 250 profiles/s with up to 1 M shots/s; the simulation uses fewer shots
    /// so that a district's cloud stays a few hundred MB).
    pub const ROOF: ProfileScanner = ProfileScanner {
        mount: Mount { lever_arm_m: [-0.9, 0.0, -1.2], boresight_deg: [0.0, 0.0, 0.0] },
        profile_rate_hz: 200.0,
        angular_step_deg: 0.4,
        max_range_m: 60.0,
        range_sigma_m: 0.01,
    };

    /// The mount as the geometric core uses it.
    pub fn camera_mount(&self) -> CameraMount {
        let [r, p, y] = self.mount.boresight_deg;
        CameraMount::new(self.mount.lever_arm_m, &Boresight::from_degrees(r, p, y))
    }

    /// Shots per profile.
    pub fn shots(&self) -> usize {
        (360.0 / self.angular_step_deg).round().max(1.0) as usize
    }
}

/// One georeferenced point of the cloud, with its truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MlsPoint {
    /// Easting, northing, height through the DG pose, metres.
    pub position: [f64; 3],
    /// GPS time (the trajectory's time scale), seconds.
    pub gps_time: f64,
    /// Where the shot truly hit (no noise), metres.
    pub truth: [f64; 3],
    /// What it hit.
    pub surface: Surface,
}

/// The profile times of the drive: `profile_rate_hz` while the vehicle moves.
pub fn profile_times(drive: &Drive, scanner: &ProfileScanner) -> Result<Vec<f64>, SensorError> {
    sensors::moving_times(drive, scanner.profile_rate_hz)
}

/// The points of the profiles at `times` (in time order): each shot traced from the true scanner pose, its
/// range perturbed by the noise and georeferenced through the DG pose. The noise of a profile depends on
/// `seed` and the profile's time only, so any cut of the drive into strips gives the same points.
pub fn scan_profiles(
    world: &World,
    truth: &Trajectory,
    dg: &Trajectory,
    scanner: &ProfileScanner,
    times: &[f64],
    seed: u64,
) -> Result<Vec<MlsPoint>, SensorError> {
    let mount = scanner.camera_mount();
    let n = scanner.shots();
    let step = scanner.angular_step_deg.to_radians();
    let profiles: Result<Vec<Vec<MlsPoint>>, SensorError> = times
        .par_iter()
        .map(|&time| {
            let at = |which: &'static str, t: &Trajectory| {
                t.interpolate(time, PositionInterpolation::Cubic).map_err(|e| SensorError::Interpolation {
                    trajectory: which,
                    id: format!("profile at {time:.3} s"),
                    time,
                    reason: e.to_string(),
                })
            };
            let (true_body, dg_body) = (at("true", truth)?.pose(), at("DG", dg)?.pose());
            let pose = mount.camera_pose(&true_body);
            let origin = pose.translation.p;
            let mut rng = ChaCha8Rng::seed_from_u64(seed ^ (time * 1e4).round() as u64);
            let mut out = Vec::new();
            for k in 0..n {
                let angle = k as f64 * step;
                let r_c = Vec3::<Camera>::new(angle.cos(), angle.sin(), 0.0);
                let d = pose.rotation.apply(&r_c).v;
                let noise = scanner.range_sigma_m * normal(&mut rng);
                let Some(hit) = world.trace(&origin, &d, scanner.max_range_m, Epoch::Mobile) else { continue };
                let p = mount.georeference(&dg_body, &r_c, hit.t + noise).p;
                let truth = [hit.point.x, hit.point.y, hit.point.z];
                out.push(MlsPoint { position: [p.x, p.y, p.z], gps_time: time, truth, surface: hit.surface });
            }
            Ok(out)
        })
        .collect();
    Ok(profiles?.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;

    #[test]
    fn a_profile_has_its_shots_and_the_roof_scanner_looks_across_the_drive() {
        assert_eq!(ProfileScanner::ROOF.shots(), 900);
        let mount = ProfileScanner::ROOF.camera_mount();
        // The profile plane's normal (camera z) is the body's forward axis.
        let z = mount.body_from_camera().rotation.apply(&Vec3::<Camera>::new(0.0, 0.0, 1.0)).v;
        assert!((z - Vector3::x()).norm() < 1e-9, "{z}");
    }
}
