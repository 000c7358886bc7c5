//! GNSS/INS navigation for campaigns that supply raw GNSS positions and IMU increments (Cazzaniga et al. 2007 §2–3):
//! a loosely coupled error-state Kalman filter (15 navigation states and the GNSS fixes' lasting error) with
//! strapdown mechanisation in the map frame, the RTS smoother, innovation-based integrity tests, and the
//! consistency check of the DG trajectory against image-derived motion (Cazzaniga et al. 2007 §4).
//! Synchronous and I/O-free.
//!
//! The mechanisation runs in the east-north-up map frame on an [`Earth`]: flat with constant gravity along
//! −z (the model `plumbline_synth::motion::imu` simulates), or WGS 84 at the campaign's latitude with Earth
//! rate, transport rate, Coriolis and normal gravity (real data).
//!
//! ```text
//! screen_fixes(gnss, &Plausibility) → Screened (outliers set aside by speed and spike tests, listed)
//! ImuClass::Tactical.datasheet() → ImuDatasheet (°/h, °/√h, mg, µg, ppm) → .model() → ImuModel (SI)
//! align(imu, gnss, lever_arm, &AlignmentConfig) → InitialState (GNSS motion fit + standstill test, levelling
//!     compensated for the GNSS acceleration, GNSS course; the drive may start standing or moving)
//! filter(imu, gnss, initial, config) → ForwardPass (innovations, checkpoints; the IMU's unrecorded stretches,
//!     find_imu_gaps, mechanised with extra process noise for the motion they hide)
//! screen_steps(&first_pass, gnss, &StepTest) → StepScreen (GNSS steps and outliers found against the IMU's
//!     free displacement, independent of the filter's drift) → filter_excluding(…); the three together are
//!     filter_screened, `navigate`'s default
//! filter_adaptive(…, &Adaptation) → the same, acting on its tests: rejected fixes excluded, covariances
//!     re-opened where the IMU is blamed (a jump may build up over `transition` s); each innovation
//!     carries its Decision
//! measure_mounting(…) → the IMU's yaw and pitch against the vehicle's axes (velocity direction in straight
//!     driving, from a pass without the vehicle constraint) → VehicleConstraint::mounting
//! measure_time_offset(…) → the IMU's time-tag lag behind the GNSS (the offset that minimises the
//!     innovations' capped χ² sum, kept when a likelihood-ratio test finds it) → shift_samples
//! measure_fix_noise(&forward, gnss) → FixNoise: per axis, the factor by which the fixes' scatter exceeds
//!     the σ the receiver stated (most likely given the innovations; a likelihood-ratio test)
//! measure_gnss_correlation(…, &excluded) → GnssCorrelation: the fixes' lasting error (correlation time
//!     from the innovations, σ as the fixes state it; a likelihood-ratio test) → NavConfig::gnss_error, a
//!     Gauss–Markov state per axis
//! divergences(&forward, &Physics) → spans where the state left what a road vehicle and its IMU can be
//! smooth(&forward) → Vec<SmoothedEpoch> → to_trajectory → plumbline_geo::Trajectory with σ (a
//!     re-initialisation's re-opened position is spread over the interval before it: a bend, not a step)
//! test_innovations(&forward.innovations, &IntegrityConfig) → Vec<Flag> (each blaming a Sensor)
//! check_consistency(&dg, &image_motions, &ConsistencyConfig) → flags + WeakLinks for the adjustment
//! ```
//!
//! Modules, bottom-up (each imports only modules listed before it):
//! - `inputs` ([`ImuSample`], [`GnssFix`]), `earth`, `chi2`; `config` (the filter's settings — IMU model,
//!   vehicle constraint, [`Mounting`], [`ImuGapModel`] — and the initial state);
//! - `screen`, `consistency`, `align`, `datasheet`; `state` (the error state and its propagation);
//! - `adaptive`, `gaps`; `filter` (one forward pass); `smoother`, `guard`, `integrity`, `noise`;
//! - `passes` (the forward pass as callers run it, re-linearised over gaps); `latency`, `mount` (measures
//!   the mounting), `correlation` (measures the fixes' lasting error), `steps`.

mod adaptive;
mod align;
mod chi2;
mod config;
mod consistency;
mod correlation;
mod datasheet;
mod earth;
mod filter;
mod gaps;
mod guard;
mod inputs;
mod integrity;
mod latency;
mod mount;
mod noise;
mod passes;
mod screen;
mod smoother;
mod state;
mod steps;

pub use adaptive::{Adaptation, Decision};
pub use align::{AlignmentConfig, align};
pub use chi2::{chi2_cdf, chi2_critical};
pub use config::{
    CorrelatedGnssError, ImuGapModel, ImuModel, InitialState, Mounting, NavConfig, STANDARD_GRAVITY, VehicleConstraint,
};
pub use consistency::{ConsistencyConfig, ConsistencyFlag, ConsistencyReport, ImageMotion, check_consistency};
pub use correlation::{GnssCorrelation, measure_gnss_correlation};
pub use datasheet::{
    ImuClass, ImuDatasheet, MeasuredNoise, angle_random_walk_deg_per_sqrt_h, measure_noise,
    velocity_random_walk_m_per_s_per_sqrt_h,
};
pub use earth::{EARTH_RATE, Earth, normal_gravity};
pub use filter::{FilteredEpoch, ForwardPass, Innovation, SkippedFix};
pub use gaps::{GapKind, ImuGap, find_imu_gaps};
pub use guard::{Divergence, Physics, Runaway, divergences};
pub use inputs::{GnssFix, ImuSample};
pub use integrity::{Component, Flag, IntegrityConfig, Sensor, TestKind, test_innovations};
pub use latency::{
    SEARCH as TIME_OFFSET_SEARCH, T_CRITICAL as TIME_OFFSET_T_CRITICAL, TimeOffsetMeasurement, measure_time_offset,
    shift_samples,
};
pub use mount::{MountingMeasurement, measure_mounting};
pub use noise::{ALPHA as NOISE_ALPHA, FixNoise, measure_fix_noise};
pub use passes::{filter, filter_adaptive, filter_excluding};
pub use screen::{Implausible, Plausibility, Screened, ScreenedFix, screen_fixes};
pub use smoother::{SmoothedEpoch, smooth, to_trajectory};
pub use steps::{EpisodeEnd, StepEpisode, StepScreen, StepTest, filter_screened, screen_steps};

/// Why the filter or smoother could not run, naming the item and field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NavError {
    /// A configuration value is out of range.
    #[error("navigation config: `{field}` is {value}; expected {expected}")]
    Config { field: &'static str, value: f64, expected: &'static str },
    /// There is nothing to process.
    #[error("no IMU samples")]
    Empty,
    /// An IMU sample is unusable.
    #[error("IMU sample {index} (time {time}): field `{field}` is {value}; expected {expected}")]
    Sample { index: usize, time: f64, field: &'static str, value: f64, expected: &'static str },
    /// A GNSS fix is unusable.
    #[error("GNSS fix {index} (time {time}): field `{field}` is {value}; expected {expected}")]
    Fix { index: usize, time: f64, field: &'static str, value: f64, expected: &'static str },
    /// An image-motion pair of the consistency check is unusable.
    #[error("image pair {index}: field `{field}` is {value}; expected {expected}")]
    Pair { index: usize, field: &'static str, value: f64, expected: &'static str },
    /// A GNSS fix lies outside the IMU's time span (or is out of time order).
    #[error("GNSS fix {index} (time {time}) lies outside the IMU data or out of time order")]
    FixOutsideImu { index: usize, time: f64 },
    /// A predicted covariance could not be factorised.
    #[error("predicted covariance at time {time} is not positive definite")]
    Singular { time: f64 },
    /// The coarse alignment from GNSS and IMU data failed.
    #[error("alignment: {reason}")]
    Alignment { reason: &'static str },
    /// The smoothed trajectory failed validation.
    #[error("smoothed trajectory is invalid: {0}")]
    Trajectory(#[from] plumbline_geo::TrajectoryError),
}

/// Tolerance on the contiguity of IMU intervals, as a share of the interval.
const CONTIGUITY: f64 = 1e-3;

/// Every sample must have a finite, positive dt, finite increments, and start where the previous one ended.
fn check_samples(imu: &[ImuSample], start: f64) -> Result<(), NavError> {
    if imu.is_empty() {
        return Err(NavError::Empty);
    }
    let mut previous = start;
    for (index, s) in imu.iter().enumerate() {
        let bad = |field, value, expected| NavError::Sample { index, time: s.time, field, value, expected };
        if !(s.dt.is_finite() && s.dt > 0.0) {
            return Err(bad("dt", s.dt, "a finite interval > 0 s"));
        }
        if !s.delta_theta.is_finite() {
            return Err(bad("delta_theta", s.delta_theta.norm(), "finite components"));
        }
        if !s.delta_v.is_finite() {
            return Err(bad("delta_v", s.delta_v.norm(), "finite components"));
        }
        let gap = (s.time - s.dt - previous).abs();
        if gap.is_nan() || gap > CONTIGUITY * s.dt {
            return Err(bad("time", s.time, "time − dt equal to the previous sample's time (contiguous)"));
        }
        previous = s.time;
    }
    Ok(())
}

/// A fix must have finite coordinates and finite positive σ.
fn check_fix(index: usize, f: &GnssFix) -> Result<(), NavError> {
    let bad = |field, value, expected| NavError::Fix { index, time: f.time, field, value, expected };
    if !f.time.is_finite() {
        return Err(bad("time", f.time, "finite"));
    }
    if !f.position.is_finite() {
        return Err(bad("position", f.position.p.norm(), "finite coordinates"));
    }
    for (field, value) in [("std[east]", f.std[0]), ("std[north]", f.std[1]), ("std[up]", f.std[2])] {
        if !(value.is_finite() && value > 0.0) {
            return Err(bad(field, value, "a finite σ > 0"));
        }
    }
    Ok(())
}
