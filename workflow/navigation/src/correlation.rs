//! The lasting part of the GNSS fixes' error, measured from the data. A receiver's own filter, multipath
//! that changes slowly and an unmodelled atmosphere leave errors of decimetres that last for seconds: the
//! fixes of a run sit off the true path together. A filter that takes the fixes' errors as white cannot
//! describe such a run; it pulls the trajectory to it, and its innovation tests flag every fix of it. Modelled
//! as a first-order Gauss–Markov state per axis ([`CorrelatedGnssError`]), the run is explained by the
//! state and the tests judge what is left.
//!
//! The correlation time comes from the white model's innovations between consecutive used fixes: the ratio
//! φ of their lag-2 to their lag-1 autocorrelation (see `correlation_time`) at the fixes' median interval
//! Δt gives τ = −Δt / ln φ. The σ per axis is the fixes' median stated σ: a receiver's σ describes its whole error,
//! and how much of it lasts is what the data cannot tell apart from the IMU's own drift (below). The filter
//! then runs over the same fixes with the state (the fixes the step test excluded left out, gap noise
//! included, no re-linearisation), and each axis's −2 log-likelihood of the used innovations, Σ ln Cₐₐ +
//! min(vₐ²/Cₐₐ, cap), is summed for both models (the cap, χ²₁ at 99.9 %, keeps a fault from weighing more
//! than a flagged fix). The state is taken when it lowers the sum by more than χ² with one degree of freedom
//! at 99.9 % (a likelihood-ratio test: the one measured figure is the time).
//!
//! Neither the σ nor the time is searched by likelihood. Searched, the likelihood chose the longest time
//! offered (tried 5–60 s, then 2–20 s; on KITTI σ 0.2–0.4 m at 60 s), and among 1, 2, 4 and 8 × the stated
//! σ it chose 2 × where a GNSS outage and faults follow each other (the fixes after the outage fit the
//! drifted IMU badly): an error that large or that lasting competes with the IMU's drift, and the fixes
//! before an outage then say less about the IMU's biases when it begins (KITTI seed 1 with every fault:
//! largest error 4.4 m against 3.2 m with the stated σ).

use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::chi2::chi2_critical;
use crate::config::{CorrelatedGnssError, InitialState, NavConfig};
use crate::filter::{ForwardPass, run_once};
use crate::inputs::{GnssFix, ImuSample};
use crate::passes::prepare;

/// Significance of the likelihood-ratio test and of each statistic's cap.
const ALPHA: f64 = 0.001;
/// Fewest used fixes for a measurement.
const ENOUGH: usize = 30;

/// What [`measure_gnss_correlation`] found.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct GnssCorrelation {
    /// The model measured, whether significant or not.
    pub best: CorrelatedGnssError,
    /// −2 log-likelihood of the used innovations with the fixes' errors taken as white.
    pub cost_white: f64,
    /// The same with the best model.
    pub cost: f64,
    /// The likelihood-ratio test's critical decrease (χ²₁ at 99.9 %).
    pub critical: f64,
    /// Used fixes the measurement rests on.
    pub fixes: usize,
}

impl GnssCorrelation {
    /// Whether the likelihood-ratio test takes the model.
    pub fn significant(&self) -> bool {
        self.cost_white - self.cost > self.critical
    }

    /// The model to run the filter with: the best one when significant.
    pub fn model(&self) -> Option<CorrelatedGnssError> {
        self.significant().then_some(self.best)
    }
}

/// Measure the lasting error of `gnss` (fixes `excluded` marks left out) with `config`'s IMU model; `None`
/// with fewer than 30 used fixes. `config.gnss_error` is ignored: every candidate replaces it.
pub fn measure_gnss_correlation(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    initial: &InitialState,
    config: &NavConfig,
    excluded: &[bool],
) -> Result<Option<GnssCorrelation>, NavError> {
    let gaps = prepare(imu, initial, config)?;
    let pass = |model: Option<CorrelatedGnssError>| {
        let cfg = NavConfig { gnss_error: model, ..*config };
        run_once(imu, gnss, initial, &cfg, None, excluded, gaps.clone(), &[])
    };
    let white_pass = pass(None);
    let (white, fixes) = axis_costs(&white_pass);
    if fixes < ENOUGH {
        return Ok(None);
    }
    let model = CorrelatedGnssError { std: median_std(gnss), correlation_time: correlation_time(&white_pass) };
    let (with_state, _) = axis_costs(&pass(Some(model)));
    Ok(Some(GnssCorrelation {
        best: model,
        cost_white: white.iter().sum(),
        cost: with_state.iter().sum(),
        critical: chi2_critical(1.0, ALPHA),
        fixes,
    }))
}

/// Per axis, −2 log-likelihood of the used innovations (constants dropped, statistics capped), and their
/// count.
fn axis_costs(pass: &ForwardPass) -> ([f64; 3], usize) {
    let cap = chi2_critical(1.0, ALPHA);
    let mut cost = [0.0; 3];
    let mut n = 0;
    for i in pass.innovations.iter().filter(|i| i.decision == crate::Decision::Used) {
        let c = [0, 1, 2].map(|a| i.covariance[(a, a)]);
        if !c.iter().all(|c| c.is_finite() && *c > 0.0) || !i.residual.iter().all(|v| v.is_finite()) {
            continue;
        }
        for a in 0..3 {
            cost[a] += c[a].ln() + (i.residual[a] * i.residual[a] / c[a]).min(cap);
        }
        n += 1;
    }
    (cost, n)
}

/// The correlation time the white model's innovations show. A lasting error under white noise gives
/// autocorrelations c·φᵏ at lags k ≥ 1 between consecutive used fixes (c the lasting share of the
/// variance), so φ = ρ₂ / ρ₁ whatever the share (ρ normalised, averaged over the axes); τ = −Δt / ln φ at
/// the fixes' median interval Δt (φ within [0.05, 0.95]; ρ₁ alone where ρ₁ or ρ₂ is not positive).
fn correlation_time(pass: &ForwardPass) -> f64 {
    let used: Vec<_> = pass.innovations.iter().filter(|i| i.decision == crate::Decision::Used).collect();
    let mut dt: Vec<f64> = used.windows(2).map(|w| w[1].time - w[0].time).filter(|d| *d > 0.0).collect();
    let dt = plumbline_geo::metrics::median(&mut dt).unwrap_or(1.0);
    let z: Vec<Vec<f64>> = (0..3)
        .map(|a| used.iter().map(|i| i.residual[a] / i.covariance[(a, a)].sqrt()).filter(|z| z.is_finite()).collect())
        .collect();
    let rho = |k| z.iter().map(|z| crate::noise::autocorrelation(z, k)).sum::<f64>() / 3.0;
    let (one, two) = (rho(1), rho(2));
    let phi = if one > 0.0 && two > 0.0 { two / one } else { one };
    -dt / phi.clamp(0.05, 0.95).ln()
}

/// The fixes' median stated σ per axis east, north, up (1 m where there is none).
fn median_std(gnss: &[GnssFix]) -> [f64; 3] {
    std::array::from_fn(|a| {
        let mut v: Vec<f64> = gnss.iter().map(|f| f.std[a]).filter(|s| s.is_finite() && *s > 0.0).collect();
        plumbline_geo::metrics::median(&mut v).unwrap_or(1.0)
    })
}
