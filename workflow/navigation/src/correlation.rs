//! The lasting part of the GNSS fixes' error, measured from the data. A receiver's own filter, multipath
//! that changes slowly and an unmodelled atmosphere leave errors of decimetres that last for seconds: the
//! fixes of a run sit off the true path together. A filter that takes the fixes' errors as white cannot
//! describe such a run; it pulls the trajectory to it, and its innovation tests flag every fix of it. Modelled
//! as a first-order Gauss–Markov state per axis ([`CorrelatedGnssError`]), the run is explained by the
//! state and the tests judge what is left.
//!
//! The correlation time comes from the white model's innovations: their lag-1 autocorrelation ρ between
//! consecutive used fixes (normalised, averaged over the axes) at the fixes' median interval Δt gives
//! τ = −Δt / ln ρ. The σ is chosen by likelihood, as the time offset is (`latency`): the filter runs over the
//! same fixes with each candidate (the fixes the step test excluded left out, gap noise included, no
//! re-linearisation), and each axis's −2 log-likelihood of the used innovations, Σ ln Cₐₐ + min(vₐ²/Cₐₐ,
//! cap), is summed (the cap, χ²₁ at 99.9 %, keeps a fault from weighing more than a flagged fix). The
//! candidates scale the fixes' median stated σ per axis by [`FACTORS`]; the horizontal axes (east and north
//! together) and the vertical get their own factor. The model is taken when it lowers the sum by more than
//! χ² with three degrees of freedom at 99.9 % (a likelihood-ratio test: two factors and a time).
//!
//! The time is not searched by likelihood: tried with 5–60 s, then 2–20 s, the likelihood always chose the
//! longest time offered (on KITTI σ 0.2–0.4 m at 60 s): an error lasting that long competes with the IMU's
//! own drift, and the fixes before a GNSS outage then say less about the IMU's biases.

use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::chi2::chi2_critical;
use crate::config::{CorrelatedGnssError, InitialState, NavConfig};
use crate::filter::{ForwardPass, run_once};
use crate::inputs::{GnssFix, ImuSample};
use crate::passes::prepare;

/// Factors on the fixes' median stated σ searched for the lasting error's σ.
pub const FACTORS: [f64; 4] = [1.0, 2.0, 4.0, 8.0];
/// Significance of the likelihood-ratio test and of each statistic's cap.
const ALPHA: f64 = 0.001;
/// Fewest used fixes for a measurement.
const ENOUGH: usize = 30;

/// What [`measure_gnss_correlation`] found.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct GnssCorrelation {
    /// The best model found, whether significant or not.
    pub best: CorrelatedGnssError,
    /// −2 log-likelihood of the used innovations with the fixes' errors taken as white.
    pub cost_white: f64,
    /// The same with the best model.
    pub cost: f64,
    /// The likelihood-ratio test's critical decrease (χ²₃ at 99.9 %).
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
    let stated = median_std(gnss);
    let pass = |model: Option<CorrelatedGnssError>| {
        let cfg = NavConfig { gnss_error: model, ..*config };
        run_once(imu, gnss, initial, &cfg, None, excluded, gaps.clone(), &[])
    };
    let cost = |model| axis_costs(&pass(model));
    let white_pass = pass(None);
    let (white, fixes) = axis_costs(&white_pass);
    if fixes < ENOUGH {
        return Ok(None);
    }
    let white_total = white[0] + white[1] + white[2];
    let time = correlation_time(&white_pass);
    // The horizontal and the vertical factor that fit best.
    let mut horizontal = (f64::INFINITY, FACTORS[0]);
    let mut vertical = (f64::INFINITY, FACTORS[0]);
    for &factor in &FACTORS {
        let model = CorrelatedGnssError { std: stated.map(|s| s * factor), correlation_time: time };
        let (c, _) = cost(Some(model));
        if c[0] + c[1] < horizontal.0 {
            horizontal = (c[0] + c[1], factor);
        }
        if c[2] < vertical.0 {
            vertical = (c[2], factor);
        }
    }
    let (h, v) = (horizontal.1, vertical.1);
    let best =
        Some((0.0, CorrelatedGnssError { std: [stated[0] * h, stated[1] * h, stated[2] * v], correlation_time: time }));
    let Some((_, model)) = best else { return Ok(None) };
    // The chosen pair of factors ran together only if they are equal: evaluate the model itself.
    let (chosen, _) = cost(Some(model));
    Ok(Some(GnssCorrelation {
        best: model,
        cost_white: white_total,
        cost: chosen[0] + chosen[1] + chosen[2],
        critical: chi2_critical(3.0, ALPHA),
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

/// The correlation time the white model's innovations show: their lag-1 autocorrelation ρ between
/// consecutive used fixes (normalised, averaged over the axes) at the fixes' median interval Δt,
/// τ = −Δt / ln ρ (ρ within [0.05, 0.95]).
fn correlation_time(pass: &ForwardPass) -> f64 {
    let used: Vec<_> = pass.innovations.iter().filter(|i| i.decision == crate::Decision::Used).collect();
    let mut dt: Vec<f64> = used.windows(2).map(|w| w[1].time - w[0].time).filter(|d| *d > 0.0).collect();
    let dt = plumbline_geo::metrics::median(&mut dt).unwrap_or(1.0);
    let rho = (0..3)
        .map(|a| {
            let z: Vec<f64> =
                used.iter().map(|i| i.residual[a] / i.covariance[(a, a)].sqrt()).filter(|z| z.is_finite()).collect();
            crate::noise::lag_one(&z)
        })
        .sum::<f64>()
        / 3.0;
    -dt / rho.clamp(0.05, 0.95).ln()
}

/// The fixes' median stated σ per axis east, north, up (1 m where there is none).
fn median_std(gnss: &[GnssFix]) -> [f64; 3] {
    std::array::from_fn(|a| {
        let mut v: Vec<f64> = gnss.iter().map(|f| f.std[a]).filter(|s| s.is_finite() && *s > 0.0).collect();
        plumbline_geo::metrics::median(&mut v).unwrap_or(1.0)
    })
}
