//! Statistics from the cofactor matrix: Baarda's w-test with redundancy numbers from the diagonal of Q_vv,
//! the a-posteriori variance factor and the posterior node covariances.
//!
//! For whitened observations (weight I), Q_vv = I − J Q_xx Jᵀ, so the redundancy of row i is
//! r_i = 1 − (J_i Q_xx J_iᵀ)_ii; J_i touches at most two nodes and one point, whose Q_xx entries all lie on
//! the factor's pattern and come from the selected inverse. w_i = e_i / √r_i (σ0 = 1 a priori), the
//! least-squares counterpart of the slippage test of Cazzaniga et al. 2007 §3.1.

use nalgebra::{DMatrix, Matrix6};
use serde::{Deserialize, Serialize};

use crate::config::Snooping;
use crate::jumps;
use crate::normal::{blocks, linearize};
use crate::problem::{Kind, Problem, node};
use crate::solver::SelectedInverse;

/// What a w-test blames: an observation, or the relative constraint between node k and k+1 (a DG jump).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Suspect {
    Observation(usize),
    Link(usize),
}

/// What to reject (or widen) this round: (suspect, |w|), the largest first, at most one per time window
/// (spans closer than the window to a chosen one's span are left for the next round). `links` marks the
/// relative constraints still tested (None: no jump detection).
pub(crate) fn w_tests(
    p: &Problem,
    x: &[f64],
    active: &[bool],
    sel: &SelectedInverse,
    snoop: &Snooping,
    links: Option<&[bool]>,
) -> Vec<(Suspect, f64)> {
    let w = crate::parallel::map(p.par, p.obs.len(), |i| if active[i] { max_w(p, i, x, sel) } else { None });
    let observations = w.into_iter().enumerate().map(|(i, w)| (Suspect::Observation(i), w));
    let tested = links.unwrap_or(&[]);
    let link_w =
        crate::parallel::map(p.par, tested.len(), |k| tested[k].then(|| jumps::link_w(p, x, sel, k)).flatten());
    let links = link_w.into_iter().enumerate().map(|(k, w)| (Suspect::Link(k), w));
    let mut candidates: Vec<(Suspect, f64)> = observations
        .chain(links)
        .filter_map(|(s, w)| w.filter(|w| *w > snoop.critical_value).map(|w| (s, w)))
        .collect();
    candidates.sort_by(|a, b| b.1.total_cmp(&a.1));
    let span = |s: &Suspect| match *s {
        // A standstill spans its whole interval.
        Suspect::Observation(i) => (p.obs[i].time, p.obs[i].until),
        Suspect::Link(k) => (p.nodes.times[k], p.nodes.times[k + 1]),
    };
    let mut chosen: Vec<(Suspect, f64)> = Vec::new();
    for (s, w) in candidates {
        let (a0, a1) = span(&s);
        if chosen.iter().all(|(c, _)| {
            let (b0, b1) = span(c);
            (b0 - a1).max(a0 - b1) > snoop.window
        }) {
            chosen.push((s, w));
        }
    }
    chosen
}

/// The largest |w| over the rows of observation `i` (None if no row is controlled).
fn max_w(p: &Problem, i: usize, x: &[f64], sel: &SelectedInverse) -> Option<f64> {
    rows(p, i, x, sel).into_iter().filter(|(_, r)| *r > 1e-6).map(|(e, r)| e.abs() / r.sqrt()).reduce(f64::max)
}

/// (whitened residual e_i, redundancy number r_i) of each row of observation `i`.
fn rows(p: &Problem, i: usize, x: &[f64], sel: &SelectedInverse) -> Vec<(f64, f64)> {
    let o = &p.obs[i];
    let lin = linearize(p, o, x);
    let parts = blocks(p, o, &lin);
    let mut params = Vec::new();
    let mut cols = Vec::new();
    for (b, j) in &parts {
        let off = p.pattern.offsets[*b];
        for c in 0..p.pattern.offsets[b + 1] - off {
            params.push(off + c);
            cols.push(j.column(c).into_owned());
        }
    }
    let q = DMatrix::from_fn(params.len(), params.len(), |a, b| sel.get(params[a], params[b]));
    let jm = DMatrix::from_fn(lin.dim, params.len(), |r, c| cols[c][r]);
    let q_hat = &jm * q * jm.transpose();
    (0..lin.dim).map(|r| (lin.e[r], 1.0 - q_hat[(r, r)])).collect()
}

/// Variance component estimates per observation type: Σ e² / Σ r over its rows (≈ 1 when the stated
/// standard deviations are right; NaN when the type has no controlled rows).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct VarianceFactors {
    /// Pole coordinate updates.
    pub poles: f64,
    /// GNSS positions.
    pub gnss: f64,
    /// Tie rays.
    pub rays: f64,
    /// Aerial tie-point coordinates.
    pub aerial: f64,
}

/// The variance factors of the active observations at `x`.
pub(crate) fn variance_factors(p: &Problem, x: &[f64], active: &[bool], sel: &SelectedInverse) -> VarianceFactors {
    let per_obs = crate::parallel::map(p.par, p.obs.len(), |i| if active[i] { rows(p, i, x, sel) } else { Vec::new() });
    let mut sums = [[0.0f64; 2]; 4];
    for (o, rows) in p.obs.iter().zip(per_obs) {
        let kind = match o.kind {
            Kind::Pole { .. } => 0,
            Kind::Gnss { .. } => 1,
            Kind::Ray { .. } => 2,
            Kind::Aerial { .. } => 3,
            Kind::Standstill { .. } | Kind::Motion { .. } => continue,
        };
        for (e, r) in rows {
            sums[kind][0] += e * e;
            sums[kind][1] += r;
        }
    }
    let f = |k: usize| if sums[k][1] > 1e-9 { sums[k][0] / sums[k][1] } else { f64::NAN };
    VarianceFactors { poles: f(0), gnss: f(1), rays: f(2), aerial: f(3) }
}

/// σ̂0 = √(vᵀPv / redundancy) over all rows (chain and observations) and the redundancy.
pub(crate) fn sigma0(p: &Problem, x: &[f64], active: &[bool]) -> (f64, f64) {
    let mut sum = 0.0;
    let mut rows = 0usize;
    for (k, s) in p.relative_sigma.iter().enumerate() {
        sum += p.link_residual(x, k).component_div(s).norm_squared();
        rows += 6;
    }
    for (k, s) in p.prior_sigma.iter().enumerate() {
        sum += node(x, k).component_div(s).norm_squared();
        rows += 6;
    }
    for (o, _) in p.obs.iter().zip(active).filter(|(_, a)| **a) {
        let lin = linearize(p, o, x);
        sum += lin.e.norm_squared();
        rows += lin.dim;
    }
    sum += 2.0 * crate::normal::nuisance_prior(p, x);
    rows += p.nuisance_priors().count();
    let redundancy = rows as f64 - p.pattern.dim() as f64;
    ((sum / redundancy.max(1.0)).sqrt(), redundancy)
}

/// Q_xx diagonal blocks of every node and the blocks between consecutive nodes.
pub(crate) fn node_covariances(p: &Problem, sel: &SelectedInverse) -> (Vec<Matrix6<f64>>, Vec<Matrix6<f64>>) {
    let block = |a: usize, b: usize| Matrix6::from_fn(|r, c| sel.get(6 * a + r, 6 * b + c));
    let m = p.nodes.len();
    ((0..m).map(|k| block(k, k)).collect(), (1..m).map(|k| block(k - 1, k)).collect())
}
