//! The direct-georeferencing (DG) error process: what a post-processed GNSS/INS solution delivers in a city.
//!
//! The error of every epoch (east, north, up; roll, pitch, heading) is the sum of
//! - a **slow drift**: Gauss–Markov per axis (knots every `knot_interval` = 1 s,
//!   correlation time `drift_correlation_time` = 300 s) whose σ follows the street's environment — open
//!   1.5 cm / 3 cm (horizontal per axis / height), urban 3 / 8 cm, canyon 5 / 15 cm (Cazzaniga et al. 2007 §1.2: a slow
//!   drift of ~40 cm in height); attitude: roll/pitch 0.0015° / 0.0025° / 0.004°, heading 0.003° / 0.006° /
//!   0.01° (Grejner-Brzezinska and Toth 2000 §2.1: 5–10″ in good conditions);
//! - **faults** ([`Fault`]): multipath jumps (urban: 1 per 90 s, 0.1–0.5 m for 3–20 s; canyon: 1 per 45 s,
//!   0.2–1.5 m for 5–40 s; never in the open; rising and falling within `jump_transition` = 1 s; height offset `jump_height_factor` = 1.0 × size × N(0, 1))
//!   and outages (urban 1 per 240 s, canyon 1 per 60 s; mean duration 10 s × ratio, at most `max_outage` =
//!   120 s; bump σ per axis `outage_growth` × (D / 60 s)², default 0.15 m for a navigation-grade IMU,
//!   Grejner-Brzezinska and Toth 2000 §2.1) — see [`faults`] for the exact rules;
//! - **white noise** of `white_horizontal` = 0.5 mm and `white_height` = 1 mm, so consecutive epochs differ by
//!   millimetres except while a jump rises or falls (centimetres per epoch then).
//!
//! The environment comes from the height-to-width ratio: open below 0.3, urban below 1.0, canyon above
//! ([`Environment::of_ratio`]). The reported standard deviations are the environment's `reported_*` values
//! (open 1.5 / 3 cm: equal to the true σ; urban 2 / 3.5 cm, canyon 2.5 / 4 cm: blind to multipath, so
//! optimistic), combined in quadrature with the outage bump's σ during an outage (the filter knows that
//! GNSS is missing). Reported attitude σ are the open-sky drift σ everywhere.
//!
//! Expected statistics per hour of driving at ~45 km/h entirely in one environment (tests check them over
//! several seeds): open: horizontal RMS 1.0–3.5 cm, 99 % 3–7 cm; urban: RMS 6–16 cm, 99 % 25–65 cm;
//! canyon: RMS 25–60 cm, 99 % 0.9–2.0 m.

mod drift;
pub mod environment;
pub mod faults;
mod stream;

use plumbline_geo::{Attitude, Map, PoseStd, Trajectory, TrajectoryRecord, ValidationLimits, Vec3};
use serde::{Deserialize, Serialize};

pub use environment::{Environment, EnvironmentParameters};
pub use faults::{Fault, FaultKind};
pub use stream::DgStream;

use super::rng::{Purpose, Stream};
use super::{Drive, MotionError};
use drift::Knots;

/// Parameters of the DG error process (see the module doc for what each does).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct DgConfig {
    /// Per-environment parameters, indexed open, urban, canyon.
    pub environments: [EnvironmentParameters; 3],
    /// Correlation time of the slow drift, s. Default 300.
    pub drift_correlation_time: f64,
    /// Spacing of the drift knots, s. Default 1.
    pub knot_interval: f64,
    /// Rise and fall time of a jump, s. Default 1.
    pub jump_transition: f64,
    /// Height offset of a jump relative to its horizontal size (σ of the factor). Default 1.0.
    pub jump_height_factor: f64,
    /// Per-axis σ of the outage bump after a 60 s outage, m. Default 0.15 (navigation-grade IMU,
    /// Grejner-Brzezinska and Toth 2000 §2.1); a consumer MEMS IMU (the BMI160 class of Meyer et al. 2023) is
    /// nearer 1.5.
    pub outage_growth: f64,
    /// Longest outage, s. Default 120.
    pub max_outage: f64,
    /// White noise per horizontal axis, m. Default 0.0005.
    pub white_horizontal: f64,
    /// White noise in height, m. Default 0.001.
    pub white_height: f64,
}

impl Default for DgConfig {
    fn default() -> Self {
        Self {
            environments: [EnvironmentParameters::OPEN, EnvironmentParameters::URBAN, EnvironmentParameters::CANYON],
            drift_correlation_time: 300.0,
            knot_interval: 1.0,
            jump_transition: 1.0,
            jump_height_factor: 1.0,
            outage_growth: 0.15,
            max_outage: 120.0,
            white_horizontal: 0.0005,
            white_height: 0.001,
        }
    }
}

/// The DG error of one epoch (estimate − truth), the ground truth of the simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DgError {
    /// Time, s.
    pub time: f64,
    /// Position error: east, north, up; metres.
    pub position: Vec3<Map>,
    /// Attitude error added to roll, pitch, heading; radians.
    pub attitude: [f64; 3],
    /// The environment at this epoch.
    pub environment: Environment,
    /// The fault active at this epoch, if any.
    pub fault: Option<FaultKind>,
}

/// A simulated DG solution with its ground truth.
#[derive(Clone, Debug)]
pub struct DgSolution {
    /// Truth + error, with the reported standard deviations; same epochs as the drive.
    pub trajectory: Trajectory,
    /// The error of every epoch.
    pub errors: Vec<DgError>,
    /// The faults in time order.
    pub faults: Vec<Fault>,
}

impl DgConfig {
    /// Check the parameters; the error names the first bad one.
    pub fn check(&self) -> Result<(), MotionError> {
        let bad = |field, value, expected| Err(MotionError::Config { config: "dg", field, value, expected });
        for (field, v) in [
            ("drift_correlation_time", self.drift_correlation_time),
            ("knot_interval", self.knot_interval),
            ("jump_transition", self.jump_transition),
            ("max_outage", self.max_outage),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(field, v, "a finite number > 0");
            }
        }
        for (field, v) in [
            ("jump_height_factor", self.jump_height_factor),
            ("outage_growth", self.outage_growth),
            ("white_horizontal", self.white_horizontal),
            ("white_height", self.white_height),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(field, v, "a finite number >= 0");
            }
        }
        for p in &self.environments {
            let sizes_ok = p.jump_size.0 > 0.0
                && p.jump_size.1 >= p.jump_size.0
                && p.jump_duration.1 >= p.jump_duration.0
                && p.jump_duration.0 >= 0.0;
            if !sizes_ok {
                return bad("environments.jump_size/jump_duration", p.jump_size.0, "0 < min <= max");
            }
            if !(p.jump_rate >= 0.0 && p.outage_rate >= 0.0 && p.outage_seconds_per_ratio >= 0.0) {
                return bad("environments.jump_rate/outage_rate", p.jump_rate, "rates >= 0");
            }
        }
        Ok(())
    }

    fn params(&self, env: Environment) -> &EnvironmentParameters {
        &self.environments[env.index()]
    }
}

/// Simulate the DG solution of `drive`; every random draw comes from `seed`.
pub fn simulate(drive: &Drive, config: &DgConfig, seed: u64) -> Result<DgSolution, MotionError> {
    config.check()?;
    let k = &drive.kinematics;
    let faults = faults::draw(k, config, seed);
    let drift = Drifts::draw(drive, config, seed);
    let mut noise = Stream::new(seed, Purpose::DgNoise);
    let position = |t: f64| drift.position(t);
    let attitude = |t: f64| drift.attitude(t);
    errors_of(drive, config, faults, (&position, &attitude), &mut noise)
}

/// Drift series at a time: position (east, north, up) and attitude (roll, pitch, heading) errors.
type DriftAt<'a> = (&'a dyn Fn(f64) -> Vec3<Map>, &'a dyn Fn(f64) -> [f64; 3]);

/// The DG solution of `drive` from its faults, its drift series and white noise drawn from `noise`.
fn errors_of(
    drive: &Drive,
    config: &DgConfig,
    faults: Vec<Fault>,
    (drift_position, drift_attitude): DriftAt<'_>,
    noise: &mut Stream,
) -> Result<DgSolution, MotionError> {
    let k = &drive.kinematics;
    let mut active = faults.iter().peekable();
    let mut records = Vec::with_capacity(k.len());
    let mut errors = Vec::with_capacity(k.len());
    for (i, (truth, kin)) in drive.trajectory.records().iter().zip(k).enumerate() {
        while active.peek().is_some_and(|f| f.end <= i) {
            active.next();
        }
        let fault = active.peek().filter(|f| f.first <= i).copied();
        let env = Environment::of_ratio(kin.canyon.ratio());
        let (wh, wv) = (config.white_horizontal, config.white_height);
        let white = Vec3::new(wh * noise.normal(), wh * noise.normal(), wv * noise.normal());
        let position = drift_position(truth.time) + white + fault.map_or(Vec3::zeros(), |f| f.error_at(truth.time));
        let attitude = drift_attitude(truth.time);
        let std = reported(config, env, fault, truth.time);
        let a = &truth.attitude;
        let att = Attitude::new(
            a.roll + attitude[0],
            a.pitch + attitude[1],
            (a.heading + attitude[2]).rem_euclid(std::f64::consts::TAU),
        );
        records.push(TrajectoryRecord {
            time: truth.time,
            position: truth.position + position,
            attitude: att,
            std: Some(std),
        });
        errors.push(DgError { time: truth.time, position, attitude, environment: env, fault: fault.map(|f| f.kind) });
    }
    let trajectory = Trajectory::new(records, &ValidationLimits::default())?;
    Ok(DgSolution { trajectory, errors, faults })
}

/// The standard deviations the solution reports at one epoch.
fn reported(config: &DgConfig, env: Environment, fault: Option<&Fault>, t: f64) -> PoseStd {
    let p = config.params(env);
    let bump = match fault {
        Some(f) if f.kind == FaultKind::Outage => {
            let u = ((t - f.start_time) / f.duration).clamp(0.0, 1.0);
            faults::outage_sigma(config, f.duration) * (std::f64::consts::PI * u).sin().powi(2)
        }
        _ => 0.0,
    };
    let open = config.params(Environment::Open);
    let h = p.reported_horizontal.hypot(bump);
    PoseStd {
        east: h,
        north: h,
        height: p.reported_height.hypot(bump),
        roll: open.drift_roll_pitch,
        pitch: open.drift_roll_pitch,
        heading: open.drift_heading,
    }
}

/// The six drift series of a drive.
struct Drifts {
    axes: Vec<Knots>,
}

impl Drifts {
    fn draw(drive: &Drive, config: &DgConfig, seed: u64) -> Self {
        let mut rng = Stream::new(seed, Purpose::Drift);
        let k = &drive.kinematics;
        let (t0, t1) = drive.trajectory.span();
        let env_at = |t: f64| {
            let i = k.partition_point(|e| e.time < t).min(k.len() - 1);
            config.params(Environment::of_ratio(k[i].canyon.ratio()))
        };
        let pick: [fn(&EnvironmentParameters) -> f64; 6] = [
            |p| p.drift_horizontal,
            |p| p.drift_horizontal,
            |p| p.drift_height,
            |p| p.drift_roll_pitch,
            |p| p.drift_roll_pitch,
            |p| p.drift_heading,
        ];
        let axes = pick
            .iter()
            .map(|f| {
                Knots::draw(t0, t1, config.knot_interval, config.drift_correlation_time, |t| f(env_at(t)), &mut rng)
            })
            .collect();
        Self { axes }
    }

    fn position(&self, t: f64) -> Vec3<Map> {
        Vec3::new(self.axes[0].at(t), self.axes[1].at(t), self.axes[2].at(t))
    }

    fn attitude(&self, t: f64) -> [f64; 3] {
        [self.axes[3].at(t), self.axes[4].at(t), self.axes[5].at(t)]
    }
}
