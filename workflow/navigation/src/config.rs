//! Inputs of the filter: IMU increments, GNSS fixes, the IMU error model and the initial state.

use plumbline_geo::{Attitude, Body, Map, Point3, Vec3};
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::earth::Earth;
use crate::gaps::ImuGapModel;
use crate::mount::Mounting;

/// Standard gravity, m/s² (the simulator's flat Earth; [`Earth::Wgs84`] uses normal gravity).
pub const STANDARD_GRAVITY: f64 = 9.806_65;

/// One IMU record: angle and velocity increments over the interval `[time − dt, time]`, body frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// End of the interval, s.
    pub time: f64,
    /// Length of the interval, s.
    pub dt: f64,
    /// Angle increment Δθ, rad.
    pub delta_theta: Vec3<Body>,
    /// Velocity increment Δv (specific force × dt), m/s.
    pub delta_v: Vec3<Body>,
}

/// One GNSS position fix of the antenna.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFix {
    /// Time, s (same scale as the IMU).
    pub time: f64,
    /// Antenna position in the mapping frame, m.
    pub position: Point3<Map>,
    /// Standard deviations east, north, up, m.
    pub std: [f64; 3],
}

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
