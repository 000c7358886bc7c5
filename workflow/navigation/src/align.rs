//! Coarse alignment from the data themselves, for campaigns that deliver only raw GNSS and IMU: the drive
//! must start at a standstill (static initialisation, as survey practice demands).
//!
//! - Roll and pitch by levelling: the mean specific force over the first `levelling` seconds is gravity's
//!   reaction, f_b = R_Bᴺᴱᴰᵀ (0, 0, −g), so roll = atan2(−f_y, −f_z), pitch = atan2(f_x, √(f_y² + f_z²)).
//! - Heading from the GNSS course once the vehicle has moved: the direction between two fixes `baseline`
//!   metres apart (no side-slip), carried back to the start by integrating the heading rate
//!   ψ̇ = (ω_y sin φ + ω_z cos φ) / cos θ.
//! - Position: the first fix minus the rotated lever arm; velocity zero.

use nalgebra::Vector3;
use plumbline_geo::{Attitude, Body, Point3, Vec3};
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::config::{GnssFix, ImuSample, InitialState};

/// Parameters of the coarse alignment.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AlignmentConfig {
    /// Seconds of IMU data averaged for levelling.
    pub levelling: f64,
    /// Largest GNSS displacement during levelling for the vehicle to count as standing, m.
    pub standstill: f64,
    /// Distance the vehicle must move before the start of the course baseline, m.
    pub moved: f64,
    /// Length of the course baseline between two fixes, m.
    pub baseline: f64,
}

impl Default for AlignmentConfig {
    fn default() -> Self {
        Self { levelling: 1.0, standstill: 0.1, moved: 2.0, baseline: 4.0 }
    }
}

fn failed(reason: &'static str) -> NavError {
    NavError::Alignment { reason }
}

/// The initial state at the start of the first IMU interval, with σ that cover the alignment's errors.
pub fn align(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    lever_arm: &Vec3<Body>,
    config: &AlignmentConfig,
) -> Result<InitialState, NavError> {
    let first = imu.first().ok_or(NavError::Empty)?;
    let t0 = first.time - first.dt;
    let fix0 = gnss.iter().find(|f| f.position.is_finite()).ok_or(failed("no finite GNSS fix"))?;
    if (fix0.time - t0).abs() > config.levelling {
        return Err(failed("the first GNSS fix is not within the levelling time of the first IMU sample"));
    }
    let (roll, pitch) = level(imu, t0 + config.levelling)?;
    let standing = gnss
        .iter()
        .take_while(|f| f.time <= t0 + config.levelling)
        .all(|f| (f.position.p - fix0.position.p).xy().norm() <= config.standstill);
    if !standing {
        return Err(failed("the vehicle moves during levelling; the drive must start at a standstill"));
    }
    let (course, at) = course(gnss, fix0, config)?;
    let heading = course - turned(imu, t0, at, roll, pitch);
    let attitude = Attitude::new(roll, pitch, heading.rem_euclid(std::f64::consts::TAU));
    let arm = attitude.to_rotation().matrix() * lever_arm.v;
    let std = fix0.std.iter().fold(0.0f64, |m, s| m.max(*s));
    Ok(InitialState {
        time: t0,
        position: Point3::from_vector(fix0.position.p - arm),
        velocity: Vec3::zeros(),
        attitude,
        position_std: std.max(0.01),
        velocity_std: 0.02,
        attitude_std: [2e-3, 2e-3, 0.02],
    })
}

/// Roll and pitch from the mean specific force until `until`.
fn level(imu: &[ImuSample], until: f64) -> Result<(f64, f64), NavError> {
    let (mut dv, mut dt) = (Vector3::zeros(), 0.0);
    for s in imu.iter().take_while(|s| s.time <= until) {
        dv += s.delta_v.v;
        dt += s.dt;
    }
    if dt <= 0.0 || !dv.iter().all(|v| v.is_finite()) {
        return Err(failed("no usable IMU samples to level with"));
    }
    let f = dv / dt;
    Ok(((-f.y).atan2(-f.z), f.x.atan2(f.y.hypot(f.z))))
}

/// The GNSS course (clockwise from north) over the first baseline after the vehicle moved, and its time.
fn course(gnss: &[GnssFix], fix0: &GnssFix, config: &AlignmentConfig) -> Result<(f64, f64), NavError> {
    let away = |a: &GnssFix, b: &GnssFix| (b.position.p - a.position.p).xy().norm();
    let start = gnss.iter().find(|f| away(fix0, f) >= config.moved).ok_or(failed("the vehicle never moves"))?;
    let end = gnss
        .iter()
        .find(|f| f.time > start.time && away(start, f) >= config.baseline)
        .ok_or(failed("the vehicle never drives a full course baseline"))?;
    let d = end.position.p - start.position.p;
    Ok((d.x.atan2(d.y), 0.5 * (start.time + end.time)))
}

/// Heading change from `from` to `to` by integrating the gyros (levelled with the initial roll and pitch).
fn turned(imu: &[ImuSample], from: f64, to: f64, roll: f64, pitch: f64) -> f64 {
    let (sr, cr) = roll.sin_cos();
    imu.iter()
        .filter(|s| s.time > from && s.time - s.dt < to)
        .map(|s| {
            let share = ((to.min(s.time) - (s.time - s.dt).max(from)) / s.dt).clamp(0.0, 1.0);
            share * (s.delta_theta.y() * sr + s.delta_theta.z() * cr) / pitch.cos()
        })
        .sum()
}
