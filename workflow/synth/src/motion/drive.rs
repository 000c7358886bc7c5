//! The true motion of the vehicle along a route: positions, attitude and velocities at a fixed rate.
//!
//! The timed speed profile is smoothed by a moving average over `jerk_window` (1 s), so acceleration ramps
//! rather than steps; the profile keeps its limits that far ahead, so the smoothed speed still respects them.
//!
//! Attitude (Applanix convention, ARCHITECTURE.md): heading from the path tangent (grid heading = π/2 −
//! direction), pitch from the grade plus squat/dive (`pitch_per_accel` × longitudinal acceleration, nose up
//! when accelerating), roll from the road camber (right side down, the crossfall of a right-hand lane) and the terrain's bank
//! (`PathPoint::bank`, a hillside street) plus body roll to the outside of curves (`roll_per_accel` × centripetal acceleration). Roll and pitch follow
//! their targets through a first-order lag (`attitude_lag`), as a sprung body does, so attitude is
//! continuous. The body (IMU) origin rides `imu_height` above the road surface.

use plumbline_geo::{Attitude, Map, Point3, PoseStd, Trajectory, TrajectoryRecord, ValidationLimits, Vec3};

use super::path::{Path, PathPoint};
use super::profile::{Longitudinal, Profile, Stop};
use super::{DriveConfig, MotionError};
use crate::route::{Canyon, Route};

/// Speed below which the vehicle counts as standing, m/s (ARCHITECTURE.md, quality measures).
pub const STANDSTILL_SPEED: f64 = 0.2;

/// What the error models need to know about one epoch of the true motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kinematics {
    /// Time, seconds (same scale as the trajectory).
    pub time: f64,
    /// Distance driven along the path, metres.
    pub distance: f64,
    /// Horizontal speed, m/s.
    pub speed: f64,
    /// Velocity of the body origin in the mapping frame, m/s.
    pub velocity: Vec3<Map>,
    /// The street's enclosure here.
    pub canyon: Canyon,
}

/// A simulated drive: the true trajectory (σ = 0) and the kinematics of every epoch.
#[derive(Clone, Debug)]
pub struct Drive {
    /// The true trajectory, standard deviations all zero.
    pub trajectory: Trajectory,
    /// One entry per trajectory record.
    pub kinematics: Vec<Kinematics>,
    /// The standstills (start, junction stops, end); times relative to the first epoch.
    pub stops: Vec<Stop>,
}

impl Drive {
    /// Drive `route` with `config`; stops and standstill durations are drawn from `seed`.
    pub fn simulate(route: &Route, config: &DriveConfig, seed: u64) -> Result<Self, MotionError> {
        config.check()?;
        let path = Path::new(route, config.turn_radius)?;
        let profile = Profile::plan(&path, config, seed);
        let dt = 1.0 / config.rate_hz;
        let n = (profile.duration() / dt).floor() as usize + 1;
        let raw: Vec<Longitudinal> = (0..n).map(|i| profile.at(i as f64 * dt)).collect();
        let half = (config.jerk_window * config.rate_hz / 2.0).round() as usize;
        let mut lag = Lag::new(config);
        let mut records = Vec::with_capacity(n);
        let mut kinematics = Vec::with_capacity(n);
        for (i, l) in smooth(&raw, half, dt).into_iter().enumerate() {
            let t = i as f64 * dt;
            let p = path.at(l.s);
            let (roll, pitch) = lag.step(target_roll_pitch(&p, l.speed, l.accel, config), i == 0);
            let time = config.start_time + t;
            let heading = (std::f64::consts::FRAC_PI_2 - p.direction).rem_euclid(std::f64::consts::TAU);
            let position = Point3::new(p.east, p.north, p.height + config.imu_height);
            records.push(TrajectoryRecord {
                time,
                position,
                attitude: Attitude::new(roll, pitch, heading),
                std: Some(ZERO_STD),
            });
            let velocity = Vec3::new(l.speed * p.direction.cos(), l.speed * p.direction.sin(), l.speed * p.grade);
            kinematics.push(Kinematics { time, distance: l.s, speed: l.speed, velocity, canyon: p.canyon });
        }
        let trajectory = Trajectory::new(records, &ValidationLimits::default())?;
        Ok(Self { trajectory, kinematics, stops: profile.stops().to_vec() })
    }
}

/// Moving average over `2·half + 1` epochs (shrunk at the ends): acceleration is the difference of the
/// window's end speeds over its length, the exact derivative of the averaged speed.
fn smooth(raw: &[Longitudinal], half: usize, dt: f64) -> Vec<Longitudinal> {
    if half == 0 {
        return raw.to_vec();
    }
    let mut sum_s = vec![0.0; raw.len() + 1];
    let mut sum_v = vec![0.0; raw.len() + 1];
    for (i, l) in raw.iter().enumerate() {
        sum_s[i + 1] = sum_s[i] + l.s;
        sum_v[i + 1] = sum_v[i] + l.speed;
    }
    (0..raw.len())
        .map(|i| {
            let (lo, hi) = (i.saturating_sub(half), (i + half).min(raw.len() - 1));
            let m = (hi - lo + 1) as f64;
            let accel = if hi > lo { (raw[hi].speed - raw[lo].speed) / ((hi - lo) as f64 * dt) } else { 0.0 };
            Longitudinal { s: (sum_s[hi + 1] - sum_s[lo]) / m, speed: (sum_v[hi + 1] - sum_v[lo]) / m, accel }
        })
        .collect()
}

const ZERO_STD: PoseStd = PoseStd { east: 0.0, north: 0.0, height: 0.0, roll: 0.0, pitch: 0.0, heading: 0.0 };

/// Roll and pitch the body would settle at: camber, the terrain's bank and curve roll, grade and squat/dive.
fn target_roll_pitch(p: &PathPoint, speed: f64, accel: f64, config: &DriveConfig) -> (f64, f64) {
    // Centripetal acceleration to the left is v²κ; the body rolls outward (right side down for a left turn).
    let roll = (config.camber + p.bank).atan() + config.roll_per_accel * speed * speed * p.curvature;
    let pitch = p.grade.atan() + config.pitch_per_accel * accel;
    (roll, pitch)
}

/// First-order lag of roll and pitch.
struct Lag {
    alpha: f64,
    state: (f64, f64),
}

impl Lag {
    fn new(config: &DriveConfig) -> Self {
        let dt = 1.0 / config.rate_hz;
        let alpha = if config.attitude_lag > 0.0 { 1.0 - (-dt / config.attitude_lag).exp() } else { 1.0 };
        Self { alpha, state: (0.0, 0.0) }
    }

    fn step(&mut self, target: (f64, f64), first: bool) -> (f64, f64) {
        if first {
            self.state = target;
        } else {
            self.state.0 += self.alpha * (target.0 - self.state.0);
            self.state.1 += self.alpha * (target.1 - self.state.1);
        }
        self.state
    }
}
