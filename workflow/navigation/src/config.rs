//! Settings of the filter and the state it starts from: the IMU error model, the filter configuration with
//! the vehicle constraint, the IMU's mounting in the vehicle and the model of the IMU record's gaps, and the
//! initial state. Imports no module of the crate but `earth`; the inputs themselves are in `crate::inputs`.

use nalgebra::{Matrix3, Vector3};
use plumbline_geo::{Attitude, Body, Map, Point3, Vec3};
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::earth::Earth;

/// Standard gravity, m/s² (the simulator's flat Earth; [`Earth::Wgs84`] uses normal gravity).
pub const STANDARD_GRAVITY: f64 = 9.806_65;

/// Error model of the IMU, per axis (1σ), SI units; the process noise of the filter is built from it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImuModel {
    /// Turn-on gyro bias, rad/s (initial σ of the gyro-bias states).
    pub gyro_bias: f64,
    /// Gyro bias instability (Gauss–Markov σ), rad/s.
    pub gyro_bias_instability: f64,
    /// Angle random walk, rad/√s.
    pub gyro_random_walk: f64,
    /// Turn-on accelerometer bias, m/s² (initial σ of the accelerometer-bias states).
    pub accel_bias: f64,
    /// Accelerometer bias instability (Gauss–Markov σ), m/s².
    pub accel_bias_instability: f64,
    /// Velocity random walk, m/s/√s.
    pub accel_random_walk: f64,
    /// Correlation time of both bias instabilities, s.
    pub bias_correlation_time: f64,
}

/// Filter configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavConfig {
    /// The IMU's error model.
    pub imu: ImuModel,
    /// GNSS antenna position in the body frame (x forward, y right, z down), m.
    pub lever_arm: Vec3<Body>,
    /// The Earth of the mechanisation: flat with constant gravity (the simulator's), or WGS 84.
    pub earth: Earth,
    /// The land vehicle's motion constraint (no sideways or vertical sliding), or `None` for a platform
    /// that may move in any direction (a backpack, a trolley pushed sideways).
    pub vehicle: Option<VehicleConstraint>,
    /// Find the IMU recording's unrecorded stretches (filled or lost samples) and add process noise for
    /// the motion they hide ([`crate::find_imu_gaps`]), or `None` to take every sample as measured.
    pub gaps: Option<ImuGapModel>,
    /// The lasting part of the GNSS positions' error, estimated as a state, or `None` to take the fixes'
    /// errors as white (`navigate` measures it: [`crate::measure_gnss_correlation`]).
    pub gnss_error: Option<CorrelatedGnssError>,
}

/// The part of the GNSS positions' error that lasts from one fix to the next: a first-order Gauss–Markov
/// process per axis, added to the antenna position the fixes observe. A receiver's own filter, multipath
/// that changes slowly and an unmodelled atmosphere leave such errors (decimetres for seconds); white noise
/// cannot describe them, and a filter that assumes it flags every run of them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CorrelatedGnssError {
    /// Steady σ east, north, up, m.
    pub std: [f64; 3],
    /// Correlation time, s.
    pub correlation_time: f64,
}

impl CorrelatedGnssError {
    /// No lasting error: the state held at a σ far below any receiver's (it keeps the smoother's
    /// covariances invertible).
    pub const NONE: Self = Self { std: [1e-6; 3], correlation_time: 1.0 };

    /// Check every parameter; the error names the first bad one.
    pub fn check(&self) -> Result<(), NavError> {
        let fields = [
            ("gnss_error.std[0]", self.std[0]),
            ("gnss_error.std[1]", self.std[1]),
            ("gnss_error.std[2]", self.std[2]),
            ("gnss_error.correlation_time", self.correlation_time),
        ];
        for (field, value) in fields {
            if !(value.is_finite() && value > 0.0) {
                return Err(NavError::Config { field, value, expected: "a finite number > 0" });
            }
        }
        Ok(())
    }
}

/// A wheeled vehicle does not slide sideways or lift off: the body's lateral and vertical velocity stay
/// near zero (the non-holonomic constraint of land-vehicle navigation). Applied as a zero-velocity
/// pseudo-measurement of those two components every `interval` seconds, it holds the velocity's direction to
/// the attitude, so accelerometer errors cannot build up across the track or in height while GNSS is out.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VehicleConstraint {
    /// Time between two constraint updates, s.
    pub interval: f64,
    /// σ of the body's lateral and vertical velocity on a straight, even road (suspension, tyre slip), m/s.
    pub velocity_std: f64,
    /// Distance from the IMU to the point the vehicle turns about (the rear axle), m: turning at ω moves the
    /// IMU sideways at up to ω·arm, so the lateral σ grows by |ω_z|·arm and the vertical by |ω_y|·arm.
    pub arm: f64,
    /// How the IMU sits against the vehicle's axes (the constraint holds the vehicle's lateral and vertical
    /// velocity, not the IMU's); `navigate` measures it ([`crate::measure_mounting`]).
    #[serde(default)]
    pub mounting: Mounting,
}

impl Default for VehicleConstraint {
    fn default() -> Self {
        Self { interval: 0.1, velocity_std: 0.1, arm: 2.0, mounting: Mounting::default() }
    }
}

impl VehicleConstraint {
    /// Check every parameter; the error names the first bad one.
    pub fn check(&self) -> Result<(), NavError> {
        let positive = [("vehicle.interval", self.interval), ("vehicle.velocity_std", self.velocity_std)];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(NavError::Config { field, value, expected: "a finite number > 0" });
            }
        }
        if !(self.arm.is_finite() && self.arm >= 0.0) {
            return Err(NavError::Config {
                field: "vehicle.arm",
                value: self.arm,
                expected: "a finite distance >= 0 m",
            });
        }
        self.mounting.check()
    }
}

/// The state the filter starts from, with its uncertainty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InitialState {
    /// Time of the state, s: the start of the first IMU interval.
    pub time: f64,
    /// Body (IMU) origin, m.
    pub position: Point3<Map>,
    /// Velocity of the body origin, m/s.
    pub velocity: Vec3<Map>,
    /// Attitude (Applanix convention).
    pub attitude: Attitude,
    /// σ of the position per axis, m.
    pub position_std: f64,
    /// σ of the velocity per axis, m/s.
    pub velocity_std: f64,
    /// σ of the attitude about east, north and up (map-frame rotation vector), rad.
    pub attitude_std: [f64; 3],
}

impl NavConfig {
    /// The GNSS error model the filter runs with ([`CorrelatedGnssError::NONE`] when none is set).
    pub fn gnss_error_model(&self) -> CorrelatedGnssError {
        self.gnss_error.unwrap_or(CorrelatedGnssError::NONE)
    }

    /// Check every parameter; the error names the first bad one.
    pub fn check(&self) -> Result<(), NavError> {
        let m = &self.imu;
        let fields = [
            ("imu.gyro_bias", m.gyro_bias),
            ("imu.gyro_bias_instability", m.gyro_bias_instability),
            ("imu.gyro_random_walk", m.gyro_random_walk),
            ("imu.accel_bias", m.accel_bias),
            ("imu.accel_bias_instability", m.accel_bias_instability),
            ("imu.accel_random_walk", m.accel_random_walk),
        ];
        for (field, value) in fields {
            if !(value.is_finite() && value >= 0.0) {
                return Err(NavError::Config { field, value, expected: "a finite σ >= 0" });
            }
        }
        self.earth.check()?;
        if let Some(v) = &self.vehicle {
            v.check()?;
        }
        if let Some(g) = &self.gaps {
            g.check()?;
        }
        if let Some(g) = &self.gnss_error {
            g.check()?;
        }
        let positive = [("imu.bias_correlation_time", m.bias_correlation_time)];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(NavError::Config { field, value, expected: "a finite number > 0" });
            }
        }
        if !self.lever_arm.is_finite() {
            let value = self.lever_arm.norm();
            return Err(NavError::Config { field: "lever_arm", value, expected: "finite components" });
        }
        Ok(())
    }
}

impl InitialState {
    /// Check every field; the error names the first bad one.
    pub fn check(&self) -> Result<(), NavError> {
        let finite = [
            ("initial.time", self.time),
            ("initial.position", self.position.p.norm()),
            ("initial.velocity", self.velocity.norm()),
        ];
        for (field, value) in finite {
            if !value.is_finite() {
                return Err(NavError::Config { field, value, expected: "finite" });
            }
        }
        if !self.attitude.is_finite() {
            return Err(NavError::Config { field: "initial.attitude", value: f64::NAN, expected: "finite angles" });
        }
        let sigmas = [
            ("initial.position_std", self.position_std),
            ("initial.velocity_std", self.velocity_std),
            ("initial.attitude_std[east]", self.attitude_std[0]),
            ("initial.attitude_std[north]", self.attitude_std[1]),
            ("initial.attitude_std[up]", self.attitude_std[2]),
        ];
        for (field, value) in sigmas {
            if !(value.is_finite() && value > 0.0) {
                return Err(NavError::Config { field, value, expected: "a finite σ > 0" });
            }
        }
        Ok(())
    }
}

/// The IMU's mounting against the vehicle's axes, rad: yaw (positive: the vehicle's forward axis lies to
/// the IMU's right, x toward y) and pitch (positive: it points below the IMU's x axis, toward its z).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Mounting {
    pub yaw: f64,
    pub pitch: f64,
}

impl Mounting {
    /// The rotation taking IMU-axis vectors to vehicle axes (x forward, y right, z down).
    pub fn to_vehicle(self) -> Matrix3<f64> {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        let forward = Vector3::new(cp * cy, cp * sy, sp);
        let right = Vector3::z().cross(&forward).normalize();
        let down = forward.cross(&right);
        Matrix3::from_rows(&[forward.transpose(), right.transpose(), down.transpose()])
    }

    /// Check both angles; the error names the bad one.
    pub fn check(&self) -> Result<(), NavError> {
        for (field, value) in [("vehicle.mounting.yaw", self.yaw), ("vehicle.mounting.pitch", self.pitch)] {
            if !(value.is_finite() && value.abs() < 0.5) {
                return Err(NavError::Config { field, value, expected: "a finite angle under 0.5 rad" });
            }
        }
        Ok(())
    }
}

/// How unrecorded stretches are found and what motion they may hide.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImuGapModel {
    /// σ of the vehicle's turn rate about the vertical that a gap's samples do not show, rad/s. A car's yaw
    /// rate changes by up to 0.5 rad/s within a second in a city turn; the default 0.15 rad/s (8.6 °/s)
    /// gives a 1.6 s gap a heading σ of 14°.
    pub yaw_rate_std: f64,
    /// σ of the roll and pitch change over a gap, rad, whatever its length (suspension travel bounds it).
    pub tilt_std: f64,
    /// σ of the unrecorded acceleration, m/s², per axis. A car's acceleration along its track changes by
    /// about 1 m/s² per second in normal driving, and a straight line through the gap's ends misses a
    /// fraction of that; across the track it follows the turn rate (held by the vehicle constraint).
    pub accel_std: f64,
    /// Fewest consecutive samples, each exactly on the line through its neighbours in all six channels, that
    /// make a filled run.
    pub min_filled: usize,
    /// An interval longer than this many times the recording's median interval is a gap of lost samples.
    pub missing_factor: f64,
}

impl Default for ImuGapModel {
    fn default() -> Self {
        Self { yaw_rate_std: 0.15, tilt_std: 0.02, accel_std: 0.3, min_filled: 10, missing_factor: 5.0 }
    }
}

impl ImuGapModel {
    /// Check every parameter; the error names the first bad one.
    pub fn check(&self) -> Result<(), NavError> {
        let sigmas = [
            ("gaps.yaw_rate_std", self.yaw_rate_std),
            ("gaps.tilt_std", self.tilt_std),
            ("gaps.accel_std", self.accel_std),
        ];
        for (field, value) in sigmas {
            if !(value.is_finite() && value >= 0.0) {
                return Err(NavError::Config { field, value, expected: "a finite σ >= 0" });
            }
        }
        if self.min_filled < 3 {
            let value = self.min_filled as f64;
            return Err(NavError::Config { field: "gaps.min_filled", value, expected: "at least 3 samples" });
        }
        if !(self.missing_factor.is_finite() && self.missing_factor > 1.0) {
            let value = self.missing_factor;
            return Err(NavError::Config { field: "gaps.missing_factor", value, expected: "a finite factor > 1" });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_vehicle_axes_follow_the_angles() {
        assert!((Mounting::default().to_vehicle() - Matrix3::identity()).norm() < 1e-15);
        let m = Mounting { yaw: 0.02, pitch: -0.01 };
        // The vehicle's forward direction in IMU axes maps to the vehicle's x axis.
        let forward =
            Vector3::new((0.02f64).cos() * (-0.01f64).cos(), (0.02f64).sin() * (-0.01f64).cos(), (-0.01f64).sin());
        assert!((m.to_vehicle() * forward - Vector3::x()).norm() < 1e-12);
        assert!((m.to_vehicle().determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_gap_parameters_are_named() {
        let bad = ImuGapModel { min_filled: 2, ..ImuGapModel::default() };
        assert!(matches!(bad.check(), Err(NavError::Config { field: "gaps.min_filled", .. })));
        let bad = ImuGapModel { yaw_rate_std: f64::NAN, ..ImuGapModel::default() };
        assert!(matches!(bad.check(), Err(NavError::Config { field: "gaps.yaw_rate_std", .. })));
    }
}
