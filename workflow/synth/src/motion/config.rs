//! Parameters of the true motion, with the defaults of a mapping van in city traffic.

use serde::{Deserialize, Serialize};

use super::MotionError;

/// How the vehicle drives. Units: SI (m, s, rad) unless the field says otherwise.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct DriveConfig {
    /// Output rate, Hz (100–200 Hz like a POS, Cazzaniga et al. 2007 §1.1). Default 200.
    pub rate_hz: f64,
    /// Time of the first epoch, seconds (GPS seconds of week). Default 345 600 (Monday 00:00).
    pub start_time: f64,
    /// Largest forward acceleration, m/s². Default 1.2.
    pub max_accel: f64,
    /// Largest braking deceleration, m/s². Default 1.8.
    pub max_decel: f64,
    /// Largest centripetal acceleration in curves, m/s². Default 1.5.
    pub max_lateral_accel: f64,
    /// Slowest speed the curve limit imposes (degenerate, near U-turn corners), m/s. Default 0.5.
    pub min_curve_speed: f64,
    /// Share of the speed limit the driver keeps. Default 0.9.
    pub cruise_factor: f64,
    /// Radius of the arcs that round the route's corners, metres (smaller where segments are short). Default 8.
    pub turn_radius: f64,
    /// Probability that the vehicle stops at a junction waypoint. Default 0.5.
    pub stop_probability: f64,
    /// Shortest standstill at a junction, s. Default 5.
    pub standstill_min: f64,
    /// Longest standstill at a junction, s (Meyer et al. 2023, Fig. 7: ~38 s at a traffic light). Default 40.
    pub standstill_max: f64,
    /// Where the vehicle stops before the junction's centre (the stop line), metres. Default 6.
    pub stop_before_junction: f64,
    /// Standstill at the start (initialisation), s. Default 10.
    pub start_dwell: f64,
    /// Standstill at the end, s. Default 10.
    pub end_dwell: f64,
    /// Height of the body (IMU) origin above the road, metres. Default 1.9 (roof rack).
    pub imu_height: f64,
    /// Crossfall of the lane, down to the right (dimensionless). Default 0.025.
    pub camber: f64,
    /// Body roll per centripetal acceleration, rad per m/s². Default 0.4°/(m/s²).
    pub roll_per_accel: f64,
    /// Body pitch per longitudinal acceleration, rad per m/s². Default 0.25°/(m/s²).
    pub pitch_per_accel: f64,
    /// Time constant of the body's roll/pitch response, s. Default 0.3.
    pub attitude_lag: f64,
    /// Window of the moving average that smooths the speed profile, s: acceleration ramps instead of
    /// stepping, jerk ≤ (max_accel + max_decel) / jerk_window. Default 1; 0 keeps the steps.
    pub jerk_window: f64,
}

impl Default for DriveConfig {
    fn default() -> Self {
        Self {
            rate_hz: 200.0,
            start_time: 345_600.0,
            max_accel: 1.2,
            max_decel: 1.8,
            max_lateral_accel: 1.5,
            min_curve_speed: 0.5,
            cruise_factor: 0.9,
            turn_radius: 8.0,
            stop_probability: 0.5,
            standstill_min: 5.0,
            standstill_max: 40.0,
            stop_before_junction: 6.0,
            start_dwell: 10.0,
            end_dwell: 10.0,
            imu_height: 1.9,
            camber: 0.025,
            roll_per_accel: 0.4f64.to_radians(),
            pitch_per_accel: 0.25f64.to_radians(),
            attitude_lag: 0.3,
            jerk_window: 1.0,
        }
    }
}

impl DriveConfig {
    /// Check every parameter's range; the error names the first bad one.
    pub fn check(&self) -> Result<(), MotionError> {
        let positive = [
            ("rate_hz", self.rate_hz),
            ("max_accel", self.max_accel),
            ("max_decel", self.max_decel),
            ("max_lateral_accel", self.max_lateral_accel),
            ("min_curve_speed", self.min_curve_speed),
            ("cruise_factor", self.cruise_factor),
            ("turn_radius", self.turn_radius),
        ];
        let non_negative = [
            ("standstill_min", self.standstill_min),
            ("stop_before_junction", self.stop_before_junction),
            ("start_dwell", self.start_dwell),
            ("end_dwell", self.end_dwell),
            ("attitude_lag", self.attitude_lag),
            ("jerk_window", self.jerk_window),
        ];
        let bad = |field, value, expected| Err(MotionError::Config { config: "drive", field, value, expected });
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return bad(field, value, "a finite number > 0");
            }
        }
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return bad(field, value, "a finite number >= 0");
            }
        }
        if !(0.0..=1.0).contains(&self.stop_probability) {
            return bad("stop_probability", self.stop_probability, "a probability in [0, 1]");
        }
        if !(self.standstill_max >= self.standstill_min && self.standstill_max.is_finite()) {
            return bad("standstill_max", self.standstill_max, "a finite number >= standstill_min");
        }
        let finite = [("start_time", self.start_time), ("imu_height", self.imu_height), ("camber", self.camber)];
        for (field, value) in finite
            .into_iter()
            .chain([("roll_per_accel", self.roll_per_accel), ("pitch_per_accel", self.pitch_per_accel)])
        {
            if !value.is_finite() {
                return bad(field, value, "a finite number");
            }
        }
        Ok(())
    }
}
