//! The GNSS fixes' noise measured from the filter's own innovations, for receivers whose stated σ are
//! optimistic (innovation-based adaptive estimation, Mohamed and Schwarz 1999).
//!
//! A used fix's innovation v has the covariance C = A·P·Aᵀ + R, where R holds the fix's stated variances.
//! Per axis a, the factor k on the stated variances Rₐₐ is the most likely one given the used fixes'
//! innovations vₐ ~ N(0, Cₐₐ − Rₐₐ + k·Rₐₐ) (the filter's own share of Cₐₐ kept; fixes whose innovation is
//! mostly the filter's uncertainty, as after an outage, weigh little). Whether k differs from 1 is tested
//! by the likelihood ratio, χ² with one degree of freedom — with the ratio scaled down to the independent
//! innovations: real innovations are correlated from one fix to the next, so the count is reduced by the
//! lag-1 autocorrelation ρ of the normalised innovations (n·(1 − ρ)/(1 + ρ)). The level is a model
//! check's, [`ALPHA`] = 5 %, not the integrity tests' 0.1 %.
//!
//! With optimistic σ the innovation tests flag good fixes; the measurement tells the user by how much the
//! σ fall short, axis by axis. It is reported, not applied. Re-running the filter with the fixes' σ raised
//! to it (tried on KITTI: the clean fixes' σ × 1.4/1.9/1.0) cut the innovation tests' flags on clean data
//! from 4.5 to 2.8 % but made the faulted drives worse — the fixes before a GNSS outage weighed less, the
//! IMU's biases were known less well when it began, and on the drive with every fault the largest error
//! grew from 2.4 to 7.1 m.

use serde::{Deserialize, Serialize};

use crate::GnssFix;
use crate::adaptive::Decision;
use crate::chi2::chi2_critical;
use crate::filter::ForwardPass;

/// How the fixes' noise compares with their stated σ, per axis east, north, up.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct FixNoise {
    /// Used fixes the estimate rests on.
    pub fixes: usize,
    /// Independent innovations among them (fewer where consecutive innovations correlate).
    pub effective: [f64; 3],
    /// Factor on the stated σ², the most likely given the innovations.
    pub factor: [f64; 3],
    /// The likelihood-ratio statistic of that factor against 1, scaled to the effective count.
    pub statistic: [f64; 3],
    /// Its critical value, χ² with one degree of freedom at [`ALPHA`].
    pub critical: [f64; 3],
}

impl FixNoise {
    /// Per axis: whether the fixes scatter significantly more than their σ state.
    pub fn excess(&self) -> [bool; 3] {
        std::array::from_fn(|a| self.factor[a] > 1.0 && self.statistic[a] > self.critical[a])
    }
}

/// Significance level of the test for an excess.
pub const ALPHA: f64 = 0.05;
/// Fewest used fixes for a measurement.
const MIN_FIXES: usize = 30;

/// Measure the noise of `gnss` (the fixes `forward` ran on) from `forward`'s used innovations. None with
/// fewer than 30 used fixes (`MIN_FIXES`).
pub fn measure_fix_noise(forward: &ForwardPass, gnss: &[GnssFix]) -> Option<FixNoise> {
    let used: Vec<_> = forward
        .innovations
        .iter()
        .filter(|i| i.decision == Decision::Used)
        .filter_map(|i| gnss.get(i.fix).map(|f| (i, f)))
        .filter(|(i, _)| (0..3).all(|a| i.covariance[(a, a)].is_finite() && i.covariance[(a, a)] > 0.0))
        .filter(|(i, _)| i.residual.iter().all(|v| v.is_finite()))
        .collect();
    let n = used.len();
    if n < MIN_FIXES {
        return None;
    }
    let mut noise =
        FixNoise { fixes: n, effective: [0.0; 3], factor: [1.0; 3], statistic: [0.0; 3], critical: [0.0; 3] };
    for a in 0..3 {
        // (vₐ², the filter's share Cₐₐ − Rₐₐ, the stated Rₐₐ) per fix.
        let terms: Vec<[f64; 3]> = used
            .iter()
            .map(|(i, f)| {
                let r = f.std[a] * f.std[a];
                [i.residual[a] * i.residual[a], (i.covariance[(a, a)] - r).max(0.0), r]
            })
            .collect();
        let z: Vec<f64> = used.iter().map(|(i, _)| i.residual[a] / i.covariance[(a, a)].sqrt()).collect();
        let rho = lag_one(&z).clamp(0.0, 0.95);
        let effective = (n as f64 * (1.0 - rho) / (1.0 + rho)).max(1.0);
        let factor = most_likely_factor(&terms);
        noise.effective[a] = effective;
        noise.factor[a] = factor;
        noise.statistic[a] =
            2.0 * (log_likelihood(&terms, factor) - log_likelihood(&terms, 1.0)) * effective / n as f64;
        noise.critical[a] = chi2_critical(1.0, ALPHA);
    }
    Some(noise)
}

/// ln L(k) of the innovations of one axis when the stated variances are scaled by k (constants dropped):
/// −½ Σ ln(p + k·r) + v²/(p + k·r), each term `[v², p, r]`.
fn log_likelihood(terms: &[[f64; 3]], k: f64) -> f64 {
    -0.5 * terms.iter().map(|[v2, p, r]| (p + k * r).ln() + v2 / (p + k * r)).sum::<f64>()
}

/// The k that maximises [`log_likelihood`], within [`FACTOR_RANGE`]: the root of
/// Σ r·(v² − (p + k·r))/(p + k·r)², found by bisection on ln k. Fixes whose innovation is mostly the
/// filter's own uncertainty (p ≫ r, as after an outage) weigh little, unlike in a plain mean of v² − p.
fn most_likely_factor(terms: &[[f64; 3]]) -> f64 {
    let slope = |k: f64| terms.iter().map(|[v2, p, r]| r * (v2 - (p + k * r)) / (p + k * r).powi(2)).sum::<f64>();
    let (mut lo, mut hi) = (FACTOR_RANGE.0.ln(), FACTOR_RANGE.1.ln());
    if slope(lo.exp()) <= 0.0 {
        return lo.exp();
    }
    if slope(hi.exp()) >= 0.0 {
        return hi.exp();
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if slope(mid.exp()) > 0.0 { lo = mid } else { hi = mid }
    }
    (0.5 * (lo + hi)).exp()
}

/// Range of variance factors searched.
const FACTOR_RANGE: (f64, f64) = (1e-3, 1e4);

/// Lag-1 autocorrelation of `z` about its mean (0 for fewer than 3 values or no spread).
pub(crate) fn lag_one(z: &[f64]) -> f64 {
    autocorrelation(z, 1)
}

/// Lag-`k` autocorrelation of `z` about its mean (0 for fewer than k + 2 values or no spread).
pub(crate) fn autocorrelation(z: &[f64], k: usize) -> f64 {
    if k == 0 || z.len() < k + 2 {
        return 0.0;
    }
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    let var: f64 = z.iter().map(|x| (x - mean).powi(2)).sum();
    if var <= 0.0 {
        return 0.0;
    }
    z.iter().zip(&z[k..]).map(|(a, b)| (a - mean) * (b - mean)).sum::<f64>() / var
}
