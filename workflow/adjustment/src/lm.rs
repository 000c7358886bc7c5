//! Levenberg–Marquardt on the (Huber-)weighted normal equations with the symbolic factorisation reused, and
//! the report of every iteration to an observer (so a caller can show the adjustment's progress).

use serde::{Deserialize, Serialize};

use crate::config::AdjustmentConfig;
use crate::normal::{Normal, assemble, cost};
use crate::problem::Problem;
use crate::solver::{Factorizer, SolverError};

/// One Gauss–Newton/LM iteration of [`crate::adjust_observed`], as its observer receives it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Iteration {
    /// Iterations so far over all solves, this one included (1-based).
    pub iteration: usize,
    /// The solve it belongs to: 0 the robust (Huber) solution, k ≥ 1 the k-th data-snooping round.
    pub round: usize,
    /// The objective after the step (½ Σ of squared whitened residuals, Huber-weighted in round 0).
    pub cost: f64,
    /// σ̂0 = √(2 · cost / redundancy) after the step (a-priori 1; approximate in the Huber round).
    pub sigma0: f64,
    /// Observations (and standstills) rejected by data snooping before this solve.
    pub rejected: usize,
}

impl Iteration {
    /// A one-line summary, e.g. `iteration 4: σ0 1.08, 3 rejected`.
    pub fn note(&self) -> String {
        format!("iteration {}: σ0 {:.2}, {} rejected", self.iteration, self.sigma0, self.rejected)
    }
}

/// Where the iterations of one solve go: the observer, the solve's round and the counts so far.
pub(crate) struct Observed<'a> {
    pub observer: &'a mut dyn FnMut(&Iteration),
    pub round: usize,
    pub rejected: usize,
    pub done: usize,
}

/// Levenberg–Marquardt with IRLS weights re-evaluated at each iterate; returns the iterations taken and
/// reports each one to `observed`.
pub(crate) fn minimize(
    p: &Problem,
    x: &mut [f64],
    active: &[bool],
    huber: Option<f64>,
    fac: &mut Factorizer,
    config: &AdjustmentConfig,
    observed: &mut Observed<'_>,
) -> Result<usize, SolverError> {
    let mut lambda = 0.0;
    for it in 0..config.max_iterations {
        let n = assemble(p, x, active, huber);
        let Some((step, new_cost)) = damped_step(p, x, active, huber, fac, &n, &mut lambda, config.tolerance)? else {
            return Ok(it + 1);
        };
        for (xi, si) in x.iter_mut().zip(&step) {
            *xi += si;
        }
        observed.done += 1;
        let redundancy = (n.rows as f64 - p.pattern.dim() as f64).max(1.0);
        (observed.observer)(&Iteration {
            iteration: observed.done,
            round: observed.round,
            cost: new_cost,
            sigma0: (2.0 * new_cost / redundancy).sqrt(),
            rejected: observed.rejected,
        });
        let largest = step.iter().fold(0.0f64, |m, s| m.max(s.abs()));
        if largest < config.tolerance || n.cost - new_cost <= 1e-10 * n.cost {
            return Ok(it + 1);
        }
    }
    Ok(config.max_iterations)
}

/// A step that lowers the objective (or is below `tolerance`), raising the damping until one does; `None`
/// when none can.
#[allow(clippy::too_many_arguments)]
fn damped_step(
    p: &Problem,
    x: &[f64],
    active: &[bool],
    huber: Option<f64>,
    fac: &mut Factorizer,
    n: &Normal,
    lambda: &mut f64,
    tolerance: f64,
) -> Result<Option<(Vec<f64>, f64)>, SolverError> {
    loop {
        if *lambda == 0.0 {
            fac.factor(&p.pattern, &n.values)?;
        } else {
            let mut damped = n.values.clone();
            for i in 0..p.pattern.dim() {
                damped[p.pattern.diagonal(i)] *= 1.0 + *lambda;
            }
            fac.factor(&p.pattern, &damped)?;
        }
        let mut step: Vec<f64> = n.gradient.iter().map(|g| -g).collect();
        fac.solve(&mut step);
        if step.iter().all(|s| s.abs() < tolerance) {
            // Converged: the objective cannot drop measurably any more, rounding would only reject it.
            return Ok(Some((step, n.cost)));
        }
        let trial: Vec<f64> = x.iter().zip(&step).map(|(a, b)| a + b).collect();
        let new_cost = cost(p, &trial, active, huber);
        if new_cost <= n.cost {
            *lambda = if *lambda < 1e-6 { 0.0 } else { *lambda * 0.1 };
            return Ok(Some((step, new_cost)));
        }
        *lambda = if *lambda == 0.0 { 1e-4 } else { *lambda * 10.0 };
        if *lambda > 1e8 {
            return Ok(None);
        }
    }
}
