//! Coarse alignment from the data themselves, for campaigns that deliver only raw GNSS and IMU. The drive
//! may start standing or moving.
//!
//! - Motion over the first `levelling` seconds from the GNSS fixes (`fit`), widened to the fourth fix when
//!   the receiver logs slower (1 Hz), up to ten times `levelling`: a weighted quadratic per axis
//!   and a χ² test of the standstill hypothesis; standing gives zero velocity and acceleration, moving the
//!   fitted velocity at the start and the mean acceleration.
//! - Roll and pitch by levelling (`level`): the gyro-compensated mean specific force over the window is the
//!   reaction to gravity plus the GNSS acceleration.
//! - Heading from the GNSS course once the vehicle has moved: the direction between two fixes `baseline`
//!   metres apart (no side-slip), carried back to the start by integrating the heading rate
//!   ψ̇ = (ω_y sin φ + ω_z cos φ) / cos θ.
//! - Position: the fitted antenna position minus the rotated lever arm. The antenna's velocity stands for
//!   the body origin's (the lever-arm term ω × R·l is neglected).
//!
//! The σ it states cover the fit (scaled by the fixes' own scatter) and the levelling error the GNSS
//! acceleration brings; alignment fails, naming why, only without fixes near the start or when the vehicle
//! never drives a course baseline.

mod fit;
mod level;

use nalgebra::Vector3;
use plumbline_geo::{Attitude, Body, Point3, Vec3};
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::config::{InitialState, STANDARD_GRAVITY};
use crate::inputs::{GnssFix, ImuSample};

/// Fewest GNSS fixes in the levelling window: a quadratic per axis and one degree of freedom.
const MIN_FIXES: usize = 4;
/// Levelling error of a perfect accelerometer triad: the turn-on bias of a tactical IMU over g, rad.
const TILT_FLOOR: f64 = 2e-3;
/// How far the levelling window may widen to hold [`MIN_FIXES`] fixes, in multiples of `levelling`.
const MAX_LEVELLING_WINDOWS: f64 = 10.0;
/// σ of the heading from the GNSS course, rad.
const HEADING_STD: f64 = 0.02;
/// Smallest stated velocity σ, m/s.
const VELOCITY_FLOOR: f64 = 0.02;

/// Parameters of the coarse alignment.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AlignmentConfig {
    /// Seconds of GNSS and IMU data from the start used for the motion fit and levelling.
    pub levelling: f64,
    /// Significance level of the standstill test on the GNSS fixes of the levelling window.
    #[serde(default = "default_alpha")]
    pub alpha: f64,
    /// Distance the vehicle must move before the start of the course baseline, m.
    pub moved: f64,
    /// Length of the course baseline between two fixes, m.
    pub baseline: f64,
}

fn default_alpha() -> f64 {
    0.001
}

impl Default for AlignmentConfig {
    fn default() -> Self {
        Self { levelling: 2.0, alpha: default_alpha(), moved: 2.0, baseline: 4.0 }
    }
}

impl AlignmentConfig {
    /// Check every parameter; the error names the first bad one.
    pub fn check(&self) -> Result<(), NavError> {
        let positive = [("alignment.levelling", self.levelling), ("alignment.baseline", self.baseline)];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(NavError::Config { field, value, expected: "a finite number > 0" });
            }
        }
        if !(self.moved.is_finite() && self.moved >= 0.0) {
            return Err(NavError::Config { field: "alignment.moved", value: self.moved, expected: ">= 0 m" });
        }
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return Err(NavError::Config { field: "alignment.alpha", value: self.alpha, expected: "in (0, 1)" });
        }
        Ok(())
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
    config.check()?;
    let first = imu.first().ok_or(NavError::Empty)?;
    let t0 = first.time - first.dt;
    let window = levelling_window(gnss, t0, config)?;
    let until = window[window.len() - 1].time.max(t0 + config.levelling);
    let motion = fit::fit(&window, t0, config.alpha)
        .ok_or(failed("the GNSS fixes of the levelling window do not determine the motion"))?;
    let (u, _) = level::mean_specific_force(imu, t0, until).ok_or(failed("no usable IMU samples to level with"))?;
    let w = motion.acceleration + Vector3::new(0.0, 0.0, STANDARD_GRAVITY);
    let (mut roll, mut pitch) = level::static_level(&u);
    let (course, at) = course(gnss, window[0], config)?;
    let mut heading = course;
    // Heading and levelling depend on each other only through the horizontal acceleration: two rounds.
    for _ in 0..2 {
        heading = course - turned(imu, t0, at, roll, pitch);
        (roll, pitch) = level::level(&u, &w, heading);
    }
    let attitude = Attitude::new(roll, pitch, heading.rem_euclid(std::f64::consts::TAU));
    let arm = attitude.to_rotation().matrix() * lever_arm.v;
    let [p_std, v_std, a_std] = motion.std;
    let tilt = TILT_FLOOR.hypot(a_std / STANDARD_GRAVITY);
    Ok(InitialState {
        time: t0,
        position: Point3::from_vector(motion.position - arm),
        velocity: Vec3::from_vector(motion.velocity),
        attitude,
        position_std: p_std.max(0.01),
        velocity_std: v_std.max(VELOCITY_FLOOR),
        attitude_std: [tilt, tilt, HEADING_STD],
    })
}

/// The usable GNSS fixes the motion fit and levelling use: those of the first `levelling` seconds, or, when
/// the receiver logs too slowly for [`MIN_FIXES`] of them (1 Hz GNSS in a 2 s window), the window widened to
/// the [`MIN_FIXES`]-th fix — but never beyond [`MAX_LEVELLING_WINDOWS`] times `levelling`, and only when
/// the first fix lies within `levelling` of the start.
fn levelling_window<'a>(gnss: &'a [GnssFix], t0: f64, config: &AlignmentConfig) -> Result<Vec<&'a GnssFix>, NavError> {
    let usable = |f: &&GnssFix| f.position.is_finite() && f.std.iter().all(|s| s.is_finite() && *s > 0.0);
    let after: Vec<&GnssFix> = gnss.iter().filter(usable).filter(|f| f.time >= t0).collect();
    let within = |limit: f64| after.iter().take_while(|f| f.time <= t0 + limit).count();
    if within(config.levelling) == 0 {
        return Err(failed("no usable GNSS fix within the levelling time of the first IMU sample"));
    }
    let n = within(config.levelling).max(MIN_FIXES.min(within(MAX_LEVELLING_WINDOWS * config.levelling)));
    if n < MIN_FIXES {
        return Err(failed(
            "fewer than 4 usable GNSS fixes within the levelling time of the first IMU sample (widened up to \
             10 times for slow receivers)",
        ));
    }
    Ok(after[..n].to_vec())
}

/// The GNSS course (clockwise from north) over the first baseline after the vehicle moved, and its time.
fn course(gnss: &[GnssFix], fix0: &GnssFix, config: &AlignmentConfig) -> Result<(f64, f64), NavError> {
    let away = |a: &GnssFix, b: &GnssFix| (b.position.p - a.position.p).xy().norm();
    let later = gnss.iter().filter(|f| f.time >= fix0.time && f.position.is_finite());
    let start = later.clone().find(|f| away(fix0, f) >= config.moved).ok_or(failed("the vehicle never moves"))?;
    let end = later
        .filter(|f| f.time > start.time)
        .find(|f| away(start, f) >= config.baseline)
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
