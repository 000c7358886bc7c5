//! DG jumps the consistency check did not flag, found by data snooping on the chain itself.
//!
//! The consistency check (Cazzaniga et al. 2007 §4) sees a jump only where the images measured the motion between two
//! panoramas; where they did not (no KAZE similarity, a stop, no neighbour), the relative constraint across
//! the jump stays as stiff as the DG σ says, and snooping then rejects the control after the jump one by one
//! (the masking effect: the stiff link, not the control, is the outlier). So the position rows of every
//! relative constraint x_{k+1} − x_k ~ N(0, σ²) are tested like observations: w = e / √r with
//! r = 1 − (J Q_xx Jᵀ)/σ², J = [−I, I] on the two nodes (the slippage test of Cazzaniga et al. 2007 §3.1 on the DG's
//! own relative motion). A link whose |w| is the largest in its window and beyond the critical value is not
//! dropped but its position σ inflated by |w| / critical value (so it would just pass), at most to the size of the jumps to
//! expect (σ_jump, Cazzaniga et al. 2007 §1.2: "tens of cm and more"), and reported; it stays under test, so a jump
//! larger than one inflation explains is widened again in the next round.

use serde::{Deserialize, Serialize};

use crate::problem::Problem;
use crate::solver::SelectedInverse;

/// A relative constraint that data snooping found inconsistent with the observations: the DG jumped between
/// `start` and `end`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct DetectedJump {
    /// Start of the link (node epoch), seconds.
    pub start: f64,
    /// End of the link (next node epoch), seconds.
    pub end: f64,
    /// Largest |w| of its position rows when detected.
    pub w: f64,
    /// The snooping round (0-based) that detected it.
    pub round: usize,
}

/// The largest |w| over the position rows of link k (nodes k, k+1), None when no row is controlled.
pub(crate) fn link_w(p: &Problem, x: &[f64], sel: &SelectedInverse, k: usize) -> Option<f64> {
    let d = p.link_residual(x, k);
    let sigma = &p.relative_sigma[k];
    (0..3)
        .filter_map(|c| {
            let (a, b) = (6 * k + c, 6 * (k + 1) + c);
            // Var of the estimated difference, in units of σ².
            let q = (sel.get(a, a) + sel.get(b, b) - 2.0 * sel.get(a, b)) / (sigma[c] * sigma[c]);
            let r = 1.0 - q;
            (r > 1e-6).then(|| (d[c] / sigma[c]).abs() / r.sqrt())
        })
        .reduce(f64::max)
}

/// Inflate link k's position σ by w / `critical` (so its |w| would reach the critical value; at most to
/// `max_sigma`, never narrower); whether it can still be widened.
pub(crate) fn widen(p: &mut Problem, k: usize, w: f64, critical: f64, max_sigma: f64) -> bool {
    for c in 0..3 {
        let s = p.relative_sigma[k][c];
        p.relative_sigma[k][c] = (s * w / critical).min(max_sigma).max(s);
    }
    (0..3).any(|c| p.relative_sigma[k][c] < max_sigma)
}
