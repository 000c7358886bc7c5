//! The filter acting on its own tests (Cazzaniga et al. 2007 §3.2: detect, identify, then remove or re-model): each
//! GNSS innovation is tested before it is used.
//!
//! - **Local overall test rejects** (Cazzaniga et al. 2007 §3.1.2): the fix disagrees abruptly with the prediction — a
//!   GNSS jump is the hypothesis, the fix is excluded. While fixes keep being rejected, each rejected
//!   innovation is compared with the episode's reference (the same χ² test on v_k − v_ref with covariance
//!   C_v,k + C_v,ref): a GNSS jump shifts them all by the same amount once it has built up, and shrinks
//!   them back as the fixes recover; an IMU fault makes them grow away from the reference. Multipath builds
//!   up over a second or so, so during the first `transition` seconds a significant growth moves the
//!   reference instead (the jump is still arriving). Later, a significant drift *away* from zero
//!   (v_kᵀC⁻¹v_k > v_refᵀC⁻¹v_ref, both with the current C_v,k) blames the IMU, as does an episode that
//!   outlasts `max_exclusion`: the filter re-opens position, velocity and bias covariances and takes the
//!   fix. A drift back towards zero is the GNSS recovering, never the IMU.
//! - **Local test passes, global tests over the last `window` used innovations reject**: a slow trend the
//!   local test cannot see — an IMU bias step is the hypothesis (§3.1.2, "little jumps in bias"), so the
//!   bias covariances are re-opened to their turn-on σ and the bias is re-estimated; the window restarts.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::chi2::chi2_critical;
use crate::config::ImuModel;
use crate::state::{BA, BG, ErrMat, POS, VEL};

/// Parameters of the adaptive filter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Adaptation {
    /// Significance level α of the local and global tests.
    pub alpha: f64,
    /// Used innovations in the moving window of the global tests (≥ 1).
    pub window: usize,
    /// Longest run of excluded fixes before the filter blames itself and re-opens its covariance, s.
    pub max_exclusion: f64,
    /// Time a GNSS jump may take to build up (multipath onsets ramp over about a second), s: within it a
    /// growing innovation is the jump still arriving, not an IMU fault.
    #[serde(default = "default_transition")]
    pub transition: f64,
}

fn default_transition() -> f64 {
    2.0
}

impl Default for Adaptation {
    fn default() -> Self {
        Self { alpha: 0.001, window: 25, max_exclusion: 30.0, transition: default_transition() }
    }
}

impl Adaptation {
    /// Check every parameter; the error names the first bad one.
    pub fn check(&self) -> Result<(), NavError> {
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return Err(NavError::Config { field: "adaptation.alpha", value: self.alpha, expected: "in (0, 1)" });
        }
        if self.window == 0 {
            return Err(NavError::Config { field: "adaptation.window", value: 0.0, expected: ">= 1 fix" });
        }
        if !(self.max_exclusion.is_finite() && self.max_exclusion > 0.0) {
            let value = self.max_exclusion;
            return Err(NavError::Config { field: "adaptation.max_exclusion", value, expected: "a finite time > 0 s" });
        }
        if !(self.transition.is_finite() && self.transition >= 0.0) {
            let value = self.transition;
            return Err(NavError::Config { field: "adaptation.transition", value, expected: "a finite time >= 0 s" });
        }
        Ok(())
    }
}

/// What the filter did with a fix.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Decision {
    /// Used as it is.
    Used,
    /// Rejected by the local test and not used (GNSS blamed).
    Excluded,
    /// Used after re-opening the bias covariances (global tests rejected: IMU blamed).
    BiasReset,
    /// Used after re-opening position, velocity and bias covariances (rejected fixes drifted apart, or the
    /// exclusion lasted too long: IMU blamed).
    Reinitialised,
}

/// The per-innovation pieces of the tests: vᵀC⁻¹v, C⁻¹v, diag(C⁻¹).
#[derive(Clone, Copy, Debug)]
struct Parts {
    nis: f64,
    weighted: Vector3<f64>,
    inv_diag: Vector3<f64>,
}

impl Parts {
    fn of(v: &Vector3<f64>, c: &Matrix3<f64>) -> Option<Self> {
        let inv = c.try_inverse()?;
        let weighted = inv * v;
        Some(Self { nis: v.dot(&weighted), weighted, inv_diag: inv.diagonal() })
    }
}

/// A run of rejected fixes: when it started, and the innovation (with covariance) the others are compared to.
#[derive(Clone, Copy, Debug)]
struct Episode {
    start: f64,
    reference: Vector3<f64>,
    covariance: Matrix3<f64>,
}

/// The running state of the tests inside the filter.
#[derive(Clone, Debug)]
pub(crate) struct Monitor {
    config: Adaptation,
    local: f64,
    global: f64,
    slippage: f64,
    window: std::collections::VecDeque<Parts>,
    /// The current exclusion episode.
    episode: Option<Episode>,
    /// Re-openings in a row, each within [`ESCALATION_SPAN`] of the one before: the IMU errs beyond its model.
    escalation: i32,
    /// Time of the last re-opening.
    last_reopen: Option<f64>,
}

/// A re-opening this soon after the previous one escalates the next (s).
const ESCALATION_SPAN: f64 = 60.0;
/// Growth of the re-opened bias σ per escalation step.
const ESCALATION_STEP: f64 = 3.0;
/// Most escalation steps (3⁵ = 243 times the turn-on σ: a tactical 1 °/h becomes 243 °/h).
const ESCALATION_MAX: i32 = 5;

impl Monitor {
    pub fn new(config: Adaptation) -> Self {
        Self {
            local: chi2_critical(3.0, config.alpha),
            global: chi2_critical(3.0 * config.window as f64, config.alpha),
            slippage: chi2_critical(1.0, config.alpha),
            window: std::collections::VecDeque::with_capacity(config.window),
            episode: None,
            escalation: 0,
            last_reopen: None,
            config,
        }
    }

    /// The factor on the turn-on bias σ of the next re-opening: grows while re-openings follow each other.
    pub fn reopen_scale(&self) -> f64 {
        ESCALATION_STEP.powi(self.escalation)
    }

    /// Count a re-opening at `time` for the escalation.
    fn reopened(&mut self, time: f64) {
        let soon = self.last_reopen.is_some_and(|t| time - t < ESCALATION_SPAN);
        self.escalation = if soon { (self.escalation + 1).min(ESCALATION_MAX) } else { 0 };
        self.last_reopen = Some(time);
    }

    /// Seconds since the current exclusion episode started (0 outside one).
    pub fn episode_age(&self, time: f64) -> f64 {
        self.episode.map_or(0.0, |e| time - e.start)
    }

    /// The decision for innovation `v` with covariance `c` of the fix at `time`.
    pub fn decide(&mut self, time: f64, v: &Vector3<f64>, c: &Matrix3<f64>) -> Decision {
        let Some(parts) = Parts::of(v, c) else {
            return Decision::Excluded;
        };
        // Cazzaniga et al. 2007 §3.1.2, local overall test
        if parts.nis >= self.local {
            return self.rejected(time, v, c);
        }
        self.episode = None;
        if self.window.len() == self.config.window {
            self.window.pop_front();
        }
        self.window.push_back(parts);
        if self.window.len() == self.config.window && self.global_rejects() {
            self.window.clear();
            self.reopened(time);
            return Decision::BiasReset;
        }
        Decision::Used
    }

    fn rejected(&mut self, time: f64, v: &Vector3<f64>, c: &Matrix3<f64>) -> Decision {
        let Some(episode) = self.episode else {
            self.episode = Some(Episode { start: time, reference: *v, covariance: *c });
            return Decision::Excluded;
        };
        // Cazzaniga et al. 2007 §3.2: a GNSS jump is an additive bias of the fixes; an IMU fault grows with time.
        let drift = Parts::of(&(v - episode.reference), &(c + episode.covariance)).map_or(f64::INFINITY, |p| p.nis);
        // Away from zero: compared in the metric of the current innovation covariance.
        let away =
            c.try_inverse().is_none_or(|inv| v.dot(&(inv * v)) > episode.reference.dot(&(inv * episode.reference)));
        let building = time - episode.start <= self.config.transition;
        if drift >= self.local && away && building {
            self.episode = Some(Episode { reference: *v, covariance: *c, ..episode });
            return Decision::Excluded;
        }
        if (drift >= self.local && away) || time - episode.start > self.config.max_exclusion {
            self.episode = None;
            self.window.clear();
            self.reopened(time);
            return Decision::Reinitialised;
        }
        Decision::Excluded
    }

    /// Cazzaniga et al. 2007 §3.1.2, global overall and global slippage tests over the window.
    fn global_rejects(&self) -> bool {
        let total: f64 = self.window.iter().map(|p| p.nis).sum();
        let num: Vector3<f64> = self.window.iter().map(|p| p.weighted).sum();
        let den: Vector3<f64> = self.window.iter().map(|p| p.inv_diag).sum();
        let slip = (0..3).map(|i| if den[i] > 0.0 { num[i] * num[i] / den[i] } else { 0.0 }).fold(0.0, f64::max);
        total >= self.global || slip >= self.slippage
    }
}

/// Re-open the covariance for `decision`: the bias blocks to their turn-on σ, and for a re-initialisation
/// also position and velocity to the size of the innovation (`v`) and its growth over `elapsed` seconds.
/// The smoother spreads the position part over the interval since the last used fix (see `smoother`), so
/// the smoothed trajectory does not step where the filter re-initialised.
pub(crate) fn reopen(p: &mut ErrMat, decision: Decision, imu: &ImuModel, v: &Vector3<f64>, elapsed: f64, scale: f64) {
    if matches!(decision, Decision::Used | Decision::Excluded) {
        return;
    }
    for a in 0..3 {
        p[(BA + a, BA + a)] += (scale * imu.accel_bias).powi(2);
        p[(BG + a, BG + a)] += (scale * imu.gyro_bias).powi(2);
    }
    if decision == Decision::Reinitialised {
        let rate = 2.0 / elapsed.max(1.0);
        for a in 0..3 {
            p[(POS + a, POS + a)] += v[a] * v[a];
            p[(VEL + a, VEL + a)] += (v[a] * rate).powi(2);
        }
    }
}
