//! RANSAC (Fischler & Bolles 1981; Jende et al. 2017 §3.3, §3.8) for similarity, affine and homography models:
//! adaptive iteration count, least-squares refit on the inliers, deterministic for a given seed.

use nalgebra::Matrix3;

use crate::error::{ImagingError, require};
use crate::models::{Correspondence, Model, transfer_error};

/// RANSAC settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RansacConfig {
    /// Inlier threshold on the transfer error in B, pixels.
    pub threshold: f64,
    /// Probability of drawing at least one outlier-free sample; sets the adaptive iteration count.
    pub confidence: f64,
    /// Upper bound on the iterations.
    pub max_iterations: usize,
    /// Seed of the sampler: the same seed and input give the same result.
    pub seed: u64,
}

impl Default for RansacConfig {
    fn default() -> Self {
        Self { threshold: 1.5, confidence: 0.999, max_iterations: 10_000, seed: 0x5eed }
    }
}

/// The consensus transform and how every correspondence fits it.
#[derive(Clone, Debug, PartialEq)]
pub struct RansacFit {
    /// 3×3 matrix mapping A pixels to B pixels (h33 = 1).
    pub transform: Matrix3<f64>,
    /// Inlier flag per input correspondence.
    pub inliers: Vec<bool>,
    /// Transfer error per input correspondence, pixels.
    pub residuals: Vec<f64>,
    /// RMS transfer error over the inliers, pixels.
    pub rms: f64,
    /// Hypotheses drawn.
    pub iterations: usize,
}

impl RansacFit {
    /// Number of inliers.
    pub fn inlier_count(&self) -> usize {
        self.inliers.iter().filter(|&&b| b).count()
    }
}

/// SplitMix64: a tiny, seedable generator so results do not depend on a crate's sampling algorithm.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// `k` distinct indices below `n`.
    fn sample(&mut self, n: usize, k: usize, out: &mut Vec<usize>) {
        out.clear();
        while out.len() < k {
            let i = (self.next() % n as u64) as usize;
            if !out.contains(&i) {
                out.push(i);
            }
        }
    }
}

/// Iterations needed to draw an all-inlier sample of size `s` with probability `p` at inlier ratio `w`.
fn needed_iterations(p: f64, w: f64, s: usize, cap: usize) -> usize {
    let good = w.powi(s as i32);
    if good >= 1.0 - 1e-12 {
        return 1;
    }
    if good <= 0.0 {
        return cap;
    }
    // Fischler & Bolles 1981: N = log(1 − p) / log(1 − w^s)
    ((1.0 - p).ln() / (1.0 - good).ln()).ceil().clamp(1.0, cap as f64) as usize
}

/// Find the transform of `model` with the largest consensus, then refit it on its inliers until the inlier
/// set is stable.
pub fn ransac(model: Model, pairs: &[Correspondence], config: &RansacConfig) -> Result<RansacFit, ImagingError> {
    require(config.threshold > 0.0, "threshold", config.threshold, "must be a positive pixel distance")?;
    require(config.confidence > 0.0 && config.confidence < 1.0, "confidence", config.confidence, "must be in (0, 1)")?;
    let s = model.min_samples();
    if pairs.len() < s {
        return Err(ImagingError::TooFew { what: model.name(), needed: s, got: pairs.len() });
    }
    let (mut rng, mut idx, mut sample) = (SplitMix(config.seed), Vec::new(), Vec::with_capacity(s));
    let (mut best, mut best_count, mut needed, mut iterations) = (None, 0, config.max_iterations, 0);
    while iterations < needed.min(config.max_iterations) {
        iterations += 1;
        rng.sample(pairs.len(), s, &mut idx);
        sample.clear();
        sample.extend(idx.iter().map(|&i| pairs[i]));
        let Ok(h) = model.fit(&sample) else { continue };
        let count = pairs.iter().filter(|c| transfer_error(&h, c) < config.threshold).count();
        if count > best_count {
            best_count = count;
            best = Some(h);
            needed = needed_iterations(config.confidence, count as f64 / pairs.len() as f64, s, config.max_iterations);
        }
    }
    let h = best.ok_or(ImagingError::Degenerate { what: model.name(), reason: "every sample was degenerate" })?;
    refit(model, pairs, h, config.threshold, iterations)
}

/// Refit on the inliers and re-select them, at most ten rounds or until the set stops changing.
fn refit(
    model: Model,
    pairs: &[Correspondence],
    mut h: Matrix3<f64>,
    t: f64,
    iterations: usize,
) -> Result<RansacFit, ImagingError> {
    let mut inliers: Vec<bool> = pairs.iter().map(|c| transfer_error(&h, c) < t).collect();
    for _ in 0..10 {
        let chosen: Vec<Correspondence> = pairs.iter().zip(&inliers).filter(|p| *p.1).map(|p| *p.0).collect();
        h = model.fit(&chosen)?;
        let next: Vec<bool> = pairs.iter().map(|c| transfer_error(&h, c) < t).collect();
        if next == inliers || next.iter().filter(|&&b| b).count() < model.min_samples() {
            break;
        }
        inliers = next;
    }
    let residuals: Vec<f64> = pairs.iter().map(|c| transfer_error(&h, c)).collect();
    let (sum, n) = residuals.iter().zip(&inliers).filter(|p| *p.1).fold((0.0, 0), |(s, n), (r, _)| (s + r * r, n + 1));
    let rms = (sum / n.max(1) as f64).sqrt();
    Ok(RansacFit { transform: h, inliers, residuals, rms, iterations })
}

#[cfg(test)]
mod tests;
