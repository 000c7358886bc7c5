//! How the IMU sits in the vehicle. The vehicle constraint holds the *vehicle's* lateral and vertical
//! velocity at zero; an IMU mounted a degree off the vehicle's axes sees the forward motion leak into its own
//! lateral or vertical axis (1° at 10 m/s is 0.17 m/s), and a constraint applied in the IMU's axes pulls
//! the solution by that much every second — on KITTI a mean vertical innovation of 0.1 m that the
//! unconstrained filter does not have. The mounting's yaw and pitch are measured from the data: the
//! direction of the velocity in the IMU's axes while the vehicle drives straight, from a pass without the
//! constraint (GNSS and IMU alone), median over the epochs. Roll about the forward axis does not move the
//! velocity and is left at zero. The mounting itself (`Mounting`, a field of the vehicle constraint) is a
//! setting and lives in `crate::config`; this module measures it, running the filter.

use plumbline_geo::metrics::median;
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::config::{InitialState, Mounting, NavConfig};
use crate::inputs::{GnssFix, ImuSample};
use crate::passes::filter;

/// Fastest turn an epoch may have to count as straight driving, rad/s.
const STRAIGHT: f64 = 0.02;
/// Slowest speed an epoch may have, m/s (below it the velocity's direction is noise).
const MOVING: f64 = 3.0;
/// Fewest straight, moving seconds for a measurement.
const ENOUGH: f64 = 20.0;

/// What [`measure_mounting`] found.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct MountingMeasurement {
    pub mounting: Mounting,
    /// Straight, moving time it was measured over, s.
    pub seconds: f64,
}

/// Measure the mounting from a pass of `config` without the vehicle constraint (and without gap noise);
/// `None` when the drive has under 20 s of straight driving above 3 m/s.
pub fn measure_mounting(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    initial: &InitialState,
    config: &NavConfig,
) -> Result<Option<MountingMeasurement>, NavError> {
    let pass = filter(imu, gnss, initial, &NavConfig { vehicle: None, gaps: None, ..*config })?;
    let (mut yaws, mut pitches, mut seconds) = (Vec::new(), Vec::new(), 0.0);
    for (state, sample) in pass.nominal.iter().zip(&pass.samples) {
        let rate = sample.delta_theta.v / sample.dt - state.gyro_bias;
        let body = state.attitude.inverse() * state.velocity;
        if body.x > MOVING && rate.z.abs() < STRAIGHT {
            yaws.push(body.y.atan2(body.x));
            pitches.push(body.z.atan2(body.x.hypot(body.y)));
            seconds += sample.dt;
        }
    }
    if seconds < ENOUGH {
        return Ok(None);
    }
    let (Some(yaw), Some(pitch)) = (median(&mut yaws), median(&mut pitches)) else { return Ok(None) };
    let mounting = Mounting { yaw, pitch };
    Ok(Some(MountingMeasurement { mounting, seconds }))
}
