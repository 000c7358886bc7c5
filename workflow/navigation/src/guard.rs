//! The divergence guard: spans where the forward state left what a road vehicle and its IMU can be.
//!
//! A filter whose model does not fit its data can run away — its prediction drifts, the tests exclude the
//! fixes that would pull it back, the covariance re-openings grow, and the state ends hundreds of metres
//! off while every step looked valid to the filter. The guard checks the state itself against physics, not
//! against the filter's own covariance: a speed above the vehicle's limit, a vertical speed no road allows,
//! or bias estimates larger than any unit of the configured class could carry, for ten seconds or more. `navigate` reports each span
//! and stops with a non-zero exit instead of writing a trajectory through it.

use serde::{Deserialize, Serialize};

use crate::filter::ForwardPass;

/// Physical limits of the forward state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Physics {
    /// Highest speed of the vehicle, m/s.
    pub max_speed: f64,
    /// Highest vertical speed, m/s (a 20 % grade at 100 km/h climbs 5.6 m/s).
    pub max_vertical_speed: f64,
    /// Largest plausible accelerometer bias, m/s², per axis.
    pub max_accel_bias: f64,
    /// Largest plausible gyro bias, rad/s, per axis.
    pub max_gyro_bias: f64,
    /// Shortest span that counts, s: a re-opening may swing an estimate past a limit for a moment and the
    /// next fixes pull it back; a runaway stays.
    pub min_duration: f64,
}

impl Physics {
    /// Limits for a unit whose turn-on biases (1σ) are `accel_bias` m/s² and `gyro_bias` rad/s: speeds of a
    /// road vehicle (the trajectory validation's limit), biases ten times the turn-on σ or 0.5 m/s² and
    /// 1 °/s, whichever is larger (the adaptive filter's re-openings may legitimately take in a unit worse
    /// than its class by that much; beyond it the estimate is the filter's runaway, not the sensor).
    pub fn for_unit(accel_bias: f64, gyro_bias: f64) -> Self {
        Self {
            max_speed: plumbline_geo::ValidationLimits::default().max_speed,
            max_vertical_speed: 10.0,
            max_accel_bias: (10.0 * accel_bias).max(0.5),
            max_gyro_bias: (10.0 * gyro_bias).max(1f64.to_radians()),
            min_duration: 10.0,
        }
    }
}

/// What was implausible in a span.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Runaway {
    /// The speed exceeded `max_speed`.
    Speed,
    /// The vertical speed exceeded `max_vertical_speed`.
    VerticalSpeed,
    /// An accelerometer bias estimate exceeded `max_accel_bias`.
    AccelBias,
    /// A gyro bias estimate exceeded `max_gyro_bias`.
    GyroBias,
}

/// A span of epochs whose state left the limits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Divergence {
    /// First implausible epoch, s.
    pub start: f64,
    /// Last implausible epoch, s.
    pub end: f64,
    /// What first left the limits.
    pub first: Runaway,
    /// The largest speed in the span, m/s.
    pub max_speed: f64,
}

/// Implausible spans closer than this merge into one, s.
const MERGE: f64 = 5.0;

/// Every span of the forward pass where the state left `physics` (gaps under 5 s joined) for at least
/// `min_duration`, in time order.
pub fn divergences(forward: &ForwardPass, physics: &Physics) -> Vec<Divergence> {
    let mut spans: Vec<Divergence> = Vec::new();
    for n in &forward.nominal {
        let speed = n.velocity.norm();
        let why = if speed > physics.max_speed {
            Some(Runaway::Speed)
        } else if n.velocity.z.abs() > physics.max_vertical_speed {
            Some(Runaway::VerticalSpeed)
        } else if n.accel_bias.amax() > physics.max_accel_bias {
            Some(Runaway::AccelBias)
        } else if n.gyro_bias.amax() > physics.max_gyro_bias {
            Some(Runaway::GyroBias)
        } else {
            None
        };
        let Some(first) = why else { continue };
        match spans.last_mut() {
            Some(last) if n.time - last.end <= MERGE => {
                last.end = n.time;
                last.max_speed = last.max_speed.max(speed);
            }
            _ => spans.push(Divergence { start: n.time, end: n.time, first, max_speed: speed }),
        }
    }
    spans.retain(|s| s.end - s.start >= physics.min_duration);
    spans
}
