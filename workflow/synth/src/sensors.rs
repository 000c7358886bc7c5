//! What the vehicle's cameras record along a drive: the sensor rig (panoramic and depth camera mounts),
//! the image epochs (panoramas every few metres driven, depth images at a frame rate while moving), the
//! true and DG poses at those epochs, and the index / truth CSV files that name them.

use std::fmt::Write as _;

use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::{Attitude, PositionInterpolation, Trajectory, TrajectoryRecord};

use crate::motion::{Drive, STANDSTILL_SPEED};

/// Lever arm and boresight of a camera as a campaign states them (metres, body frame; degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mount {
    /// Camera centre in the body frame (x forward, y right, z down), metres.
    pub lever_arm_m: [f64; 3],
    /// Boresight roll, pitch, yaw about the body axes, degrees (ARCHITECTURE.md § Angles).
    pub boresight_deg: [f64; 3],
}

impl Mount {
    /// The panoramic camera: 1.85 m above the IMU (≈ 2.85 m above the road), slightly misaligned.
    pub const PANORAMA: Mount = Mount { lever_arm_m: [0.4, 0.02, -1.85], boresight_deg: [0.12, -0.35, 0.8] };
    /// The side-looking depth camera (Meyer et al. 2023 §3.1: right side, looking at the kerb), outside the van body.
    pub const DEPTH: Mount = Mount { lever_arm_m: [1.2, 1.0, -0.4], boresight_deg: [0.0, -5.0, 90.0] };

    /// The mount as the geometric core uses it.
    pub fn camera_mount(&self) -> CameraMount {
        let [r, p, y] = self.boresight_deg;
        CameraMount::new(self.lever_arm_m, &Boresight::from_degrees(r, p, y))
    }
}

/// Errors of the sensor planning.
#[derive(Debug, thiserror::Error)]
pub enum SensorError {
    /// A parameter is out of range.
    #[error("sensor plan: {field} = {value} {expected}")]
    Config {
        /// The parameter.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What is expected.
        expected: &'static str,
    },
    /// A trajectory could not be interpolated at an image time.
    #[error("{trajectory} trajectory at image {id} (t = {time} s): {reason}")]
    Interpolation {
        /// Which trajectory.
        trajectory: &'static str,
        /// The image.
        id: String,
        /// Its time.
        time: f64,
        /// Why.
        reason: String,
    },
}

/// The vehicle's velocity (map frame, m/s) at `time` on `truth`: [`Trajectory::velocity`] over ±50 ms, the
/// difference the worker takes of the DG trajectory; zero where the trajectory does not cover `time`.
pub fn velocity(truth: &Trajectory, time: f64) -> nalgebra::Vector3<f64> {
    truth.velocity(time, 0.05).map_or_else(nalgebra::Vector3::zeros, |v| v.v)
}

/// Times at which the vehicle has driven another `spacing` metres (the first one at the start).
pub fn spaced_times(drive: &Drive, spacing: f64) -> Result<Vec<f64>, SensorError> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(SensorError::Config { field: "spacing", value: spacing, expected: "must be positive (m)" });
    }
    let mut times = Vec::new();
    let mut next = 0.0;
    for w in drive.kinematics.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        while b.distance >= next && b.distance > a.distance {
            let f = ((next - a.distance) / (b.distance - a.distance)).clamp(0.0, 1.0);
            times.push(a.time + f * (b.time - a.time));
            next += spacing;
        }
    }
    Ok(times)
}

/// Times at `rate` Hz while the vehicle moves faster than the standstill speed.
pub fn moving_times(drive: &Drive, rate: f64) -> Result<Vec<f64>, SensorError> {
    if !(rate.is_finite() && rate > 0.0) {
        return Err(SensorError::Config { field: "rate", value: rate, expected: "must be positive (Hz)" });
    }
    let (t0, t1) = drive.trajectory.span();
    let n = ((t1 - t0) * rate).floor() as usize;
    let mut k = 0;
    let mut times = Vec::new();
    for i in 0..n {
        let t = t0 + i as f64 / rate;
        while k + 1 < drive.kinematics.len() && drive.kinematics[k + 1].time <= t {
            k += 1;
        }
        if drive.kinematics.get(k).is_some_and(|e| e.speed > STANDSTILL_SPEED) {
            times.push(t);
        }
    }
    Ok(times)
}

/// One image epoch: its id, time, and the true and DG vehicle poses then.
#[derive(Clone, Debug, PartialEq)]
pub struct Shot {
    /// Image id (also the file stem).
    pub id: String,
    /// Time, trajectory time scale, seconds.
    pub time: f64,
    /// The true vehicle pose (what the image is rendered with).
    pub truth: TrajectoryRecord,
    /// The DG pose at the same time (what a campaign would deliver).
    pub dg: TrajectoryRecord,
}

/// The shots at `times`, ids `{prefix}{index:05}`.
pub fn shots(prefix: &str, times: &[f64], truth: &Trajectory, dg: &Trajectory) -> Result<Vec<Shot>, SensorError> {
    times
        .iter()
        .enumerate()
        .map(|(i, &time)| {
            let id = format!("{prefix}{i:05}");
            let at = |trajectory: &'static str, t: &Trajectory| {
                t.interpolate(time, PositionInterpolation::Cubic).map_err(|e| SensorError::Interpolation {
                    trajectory,
                    id: id.clone(),
                    time,
                    reason: e.to_string(),
                })
            };
            let (truth, dg) = (at("true", truth)?, at("DG", dg)?);
            Ok(Shot { id, time, truth, dg })
        })
        .collect()
}

/// An image index CSV (`image_id,time,file`) for shots stored as `{id}.{extension}`.
pub fn index_csv(shots: &[Shot], extension: &str) -> Vec<u8> {
    let mut s = String::from("image_id,time,file\n");
    for shot in shots {
        let _ = writeln!(s, "{},{:.6},{}.{extension}", shot.id, shot.time, shot.id);
    }
    s.into_bytes()
}

/// `truth/images.csv`: per shot the true and the DG position (campaign CRS) and attitude (degrees).
pub fn truth_csv(shots: &[Shot]) -> Vec<u8> {
    let mut s = String::from(
        "image_id,time,easting,northing,height,roll_deg,pitch_deg,heading_deg,\
         dg_easting,dg_northing,dg_height,dg_roll_deg,dg_pitch_deg,dg_heading_deg\n",
    );
    for shot in shots {
        let _ = writeln!(s, "{},{:.6},{},{}", shot.id, shot.time, pose_fields(&shot.truth), pose_fields(&shot.dg));
    }
    s.into_bytes()
}

fn pose_fields(r: &TrajectoryRecord) -> String {
    let Attitude { roll, pitch, heading } = r.attitude;
    let p = r.position;
    format!(
        "{:.4},{:.4},{:.4},{:.6},{:.6},{:.6}",
        p.x(),
        p.y(),
        p.z(),
        roll.to_degrees(),
        pitch.to_degrees(),
        heading.to_degrees()
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::DriveConfig;
    use crate::world::{Preset, World, WorldConfig};

    #[test]
    fn shots_are_spaced_by_distance_and_carry_both_poses() {
        let world = World::generate(&WorldConfig::new(Preset::Tiny, 5)).unwrap();
        let drive = Drive::simulate(&world.route(5, 200.0), &DriveConfig::default(), 5).unwrap();
        let length = drive.kinematics.last().unwrap().distance;
        let times = spaced_times(&drive, 10.0).unwrap();
        assert_eq!(times.len(), (length / 10.0).floor() as usize + 1, "{length} m");
        let shots = shots("p", &times, &drive.trajectory, &drive.trajectory).unwrap();
        // Consecutive shots are 10 m apart along the path: chords ≤ 10 m (+1 cm for the path discretisation),
        // near 10 m on straights.
        let gaps: Vec<f64> = shots.windows(2).map(|w| (w[1].truth.position - w[0].truth.position).norm()).collect();
        assert!(
            gaps.iter().all(|g| *g <= 10.01) && gaps.iter().filter(|g| **g > 9.5).count() * 2 > gaps.len(),
            "{gaps:?}"
        );
        assert!(spaced_times(&drive, 0.0).is_err());
        // Depth frames only while moving, at the rate's spacing.
        let moving = moving_times(&drive, 5.0).unwrap();
        assert!(moving.windows(2).all(|w| w[1] - w[0] > 0.199));
        let csv = String::from_utf8(truth_csv(&shots)).unwrap();
        assert_eq!(csv.lines().count(), shots.len() + 1);
        assert!(csv.lines().nth(1).unwrap().starts_with("p00000,"));
    }
}
