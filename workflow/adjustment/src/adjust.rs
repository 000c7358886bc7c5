//! The adjustment driver: Levenberg–Marquardt on the (Huber-)weighted normal equations with one symbolic
//! factorisation, then Baarda data snooping, then posterior covariances from the selected inverse.

use faer::Par;
use nalgebra::{Matrix6, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::config::AdjustmentConfig;
use crate::normal::{assemble, cost, node};
use crate::observations::{ObservationError, ObservationRef, TiePointId};
use crate::problem::{AdjustmentInput, Item, Kind, Problem};
use crate::solver::{Factorizer, SelectedInverse, SolverError, SolverTimings};
use crate::standstill::Standstill;
use crate::stats::{VarianceFactors, node_covariances, sigma0, variance_factors, w_tests};

/// Failures of the adjustment as a whole (single bad observations are skipped and reported instead).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AdjustmentError {
    /// The linear algebra failed.
    #[error(transparent)]
    Solver(#[from] SolverError),
}

/// The pose correction at one node epoch with its posterior covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeCorrection {
    /// Epoch, seconds.
    pub time: f64,
    /// Position correction δp (east, north, up), metres.
    pub position: [f64; 3],
    /// Attitude correction δθ, a rotation vector in the mapping frame (R' = Exp(δθ) R), radians.
    pub rotation: [f64; 3],
    /// Posterior covariance of [δp; δθ] (a-priori variance factor 1).
    pub covariance: Matrix6<f64>,
}

impl NodeCorrection {
    /// Posterior standard deviations of [δp; δθ].
    pub fn std(&self) -> [f64; 6] {
        std::array::from_fn(|i| self.covariance[(i, i)].max(0.0).sqrt())
    }
}

/// An observation rejected by data snooping.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct RejectedObservation {
    /// Which observation.
    pub item: ObservationRef,
    /// Its largest normalised residual |w| when rejected.
    pub w: f64,
    /// The snooping round (0-based) that rejected it.
    pub round: usize,
}

/// A detected standstill and the fate of its zero-velocity constraint.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct StandstillOutcome {
    /// The interval.
    pub standstill: Standstill,
    /// `Some((|w|, round))` when data snooping rejected the constraint (the vehicle was not at rest).
    pub rejected: Option<(f64, usize)>,
}

impl StandstillOutcome {
    /// Whether the constraint was kept.
    pub fn accepted(&self) -> bool {
        self.rejected.is_none()
    }
}

/// A standstill whose zero-velocity constraint data snooping rejected: the DG said the vehicle stood still,
/// the observations say it did not (or the DG jumped where the constraint could not absorb it). For the
/// report's flagged epochs, beside [`Adjustment::rejected`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct RejectedStandstill {
    /// The interval.
    pub standstill: Standstill,
    /// Its largest normalised residual |w| when rejected.
    pub w: f64,
    /// The snooping round (0-based) that rejected it.
    pub round: usize,
}

/// The adjusted coordinates of a tie point.
#[derive(Clone, Debug, PartialEq)]
pub struct AdjustedPoint {
    /// Its id.
    pub id: TiePointId,
    /// Easting, northing, height, metres.
    pub position: [f64; 3],
}

/// The result of [`adjust`].
#[derive(Clone, Debug)]
pub struct Adjustment {
    /// Corrections at the node epochs, time-sorted.
    pub nodes: Vec<NodeCorrection>,
    /// Covariance between node k and node k+1 (for interpolating σ in between).
    pub cross_covariances: Vec<Matrix6<f64>>,
    /// Variances of the random walk between node k and node k+1 (σ_rel², per component).
    pub link_variances: Vec<Vector6<f64>>,
    /// Adjusted tie points.
    pub points: Vec<AdjustedPoint>,
    /// Observations rejected by data snooping.
    pub rejected: Vec<RejectedObservation>,
    /// The detected standstills and whether their zero-velocity constraints survived snooping.
    pub standstills: Vec<StandstillOutcome>,
    /// Observations not used because they are broken or outside the trajectory.
    pub skipped: Vec<ObservationError>,
    /// A-posteriori standard deviation of unit weight.
    pub sigma0: f64,
    /// Redundancy (observation rows minus parameters).
    pub redundancy: f64,
    /// Variance factor of each observation type (Σ e² / Σ redundancy numbers).
    pub variance_factors: VarianceFactors,
    /// Gauss–Newton/LM iterations over all solves.
    pub iterations: usize,
    /// Time spent in the linear algebra.
    pub timings: SolverTimings,
}

impl Adjustment {
    /// The standstills whose zero-velocity constraint data snooping rejected, in time order.
    pub fn rejected_standstills(&self) -> Vec<RejectedStandstill> {
        let rejected = |s: &StandstillOutcome| s.rejected.map(|(w, round)| (s.standstill, w, round));
        self.standstills
            .iter()
            .filter_map(rejected)
            .map(|(standstill, w, round)| RejectedStandstill { standstill, w, round })
            .collect()
    }
}

/// Adjust the trajectory (see the crate documentation): a Huber-robust solution first; then, with
/// snooping, plain least-squares rounds that each reject the largest |w| beyond the critical value (one per
/// time window) until none is left; posterior covariances at the final solution. Broken observations are
/// skipped and listed, not fatal. `par` is the parallelism of the per-observation work and the factorisation.
pub fn adjust(input: &AdjustmentInput<'_>, config: &AdjustmentConfig, par: Par) -> Result<Adjustment, AdjustmentError> {
    let problem = Problem::build(input, config, par);
    let mut x = initial_state(&problem);
    let mut active = vec![true; problem.obs.len()];
    let mut fac = Factorizer::new(&problem.pattern, par)?;
    let mut iterations = minimize(&problem, &mut x, &active, config.huber, &mut fac, config)?;
    let mut rejected = Vec::new();
    let mut standstills: Vec<StandstillOutcome> =
        problem.standstills.iter().map(|s| StandstillOutcome { standstill: *s, rejected: None }).collect();
    let selected = match config.snooping {
        Some(snoop) => {
            let mut round = 0;
            loop {
                iterations += minimize(&problem, &mut x, &active, None, &mut fac, config)?;
                let sel = factor_at(&problem, &x, &active, None, &mut fac)?;
                let found = w_tests(&problem, &x, &active, &sel, &snoop);
                if found.is_empty() || round >= snoop.max_rounds {
                    break sel;
                }
                for (i, w) in found {
                    active[i] = false;
                    match &problem.obs[i].item {
                        Item::Observation(item) => {
                            rejected.push(RejectedObservation { item: item.clone(), w, round });
                            rejected.extend(drop_undetermined(&problem, i, &mut active, w, round));
                        }
                        Item::Standstill(s) => {
                            // Both parts (position and heading) go together.
                            for (o, a) in problem.obs.iter().zip(active.iter_mut()) {
                                *a &= o.item != problem.obs[i].item;
                            }
                            standstills[*s].rejected = Some((w, round));
                        }
                    }
                }
                round += 1;
            }
        }
        None => factor_at(&problem, &x, &active, config.huber, &mut fac)?,
    };
    let mut out = finish(problem, &x, &active, &selected, rejected, iterations, fac.timings);
    out.standstills = standstills;
    Ok(out)
}

/// After rejecting observation `i`: if it belonged to a tie point that is no longer determined (neither
/// aerial coordinates nor two rays left), reject the point's remaining observations too, as the whole tie.
fn drop_undetermined(p: &Problem, i: usize, active: &mut [bool], w: f64, round: usize) -> Option<RejectedObservation> {
    let (Kind::Ray { point, .. } | Kind::Aerial { point, .. }) = p.obs[i].kind else {
        return None;
    };
    let of_point = |o: &crate::problem::Obs| matches!(o.kind, Kind::Ray { point: q, .. } | Kind::Aerial { point: q, .. } if q == point);
    let (mut rays, mut aerial) = (0, false);
    for (o, _) in p.obs.iter().zip(active.iter()).filter(|(o, a)| **a && of_point(o)) {
        match o.kind {
            Kind::Aerial { .. } => aerial = true,
            _ => rays += 1,
        }
    }
    if aerial || rays >= 2 {
        return None;
    }
    for (o, a) in p.obs.iter().zip(active.iter_mut()) {
        if of_point(o) {
            *a = false;
        }
    }
    let index = match &p.obs[i].item {
        Item::Observation(ObservationRef::TieRay { index, .. } | ObservationRef::TieAerial { index, .. }) => *index,
        _ => return None,
    };
    Some(RejectedObservation { item: ObservationRef::Tie { index, point: p.points[point].clone() }, w, round })
}

fn initial_state(p: &Problem) -> Vec<f64> {
    let mut x = vec![0.0; p.pattern.dim()];
    for (i, init) in p.point_init.iter().enumerate() {
        x[p.point_offset(i)..p.point_offset(i) + 3].copy_from_slice(init.as_slice());
    }
    x
}

/// Factor N at `x` (no damping) and return its selected inverse.
fn factor_at(
    p: &Problem,
    x: &[f64],
    active: &[bool],
    huber: Option<f64>,
    fac: &mut Factorizer,
) -> Result<SelectedInverse, SolverError> {
    let n = assemble(p, x, active, huber);
    fac.factor(&p.pattern, &n.values)?;
    fac.selected_inverse()
}

/// Levenberg–Marquardt with IRLS weights re-evaluated at each iterate; returns the iterations taken.
fn minimize(
    p: &Problem,
    x: &mut [f64],
    active: &[bool],
    huber: Option<f64>,
    fac: &mut Factorizer,
    config: &AdjustmentConfig,
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
    n: &crate::normal::Normal,
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

fn finish(
    p: Problem,
    x: &[f64],
    active: &[bool],
    sel: &SelectedInverse,
    rejected: Vec<RejectedObservation>,
    iterations: usize,
    timings: SolverTimings,
) -> Adjustment {
    let (diag, cross_covariances) = node_covariances(&p, sel);
    let nodes = p
        .nodes
        .times
        .iter()
        .zip(diag)
        .enumerate()
        .map(|(k, (time, covariance))| {
            let d = node(x, k);
            NodeCorrection { time: *time, position: [d[0], d[1], d[2]], rotation: [d[3], d[4], d[5]], covariance }
        })
        .collect();
    let points = p
        .points
        .iter()
        .enumerate()
        .map(|(i, id)| {
            let v = Vector3::from_column_slice(&x[p.point_offset(i)..p.point_offset(i) + 3]);
            AdjustedPoint { id: id.clone(), position: [v.x, v.y, v.z] }
        })
        .collect();
    let (sigma0, redundancy) = sigma0(&p, x, active);
    let link_variances = p.relative_sigma.iter().map(|s| s.component_mul(s)).collect();
    let variance_factors = variance_factors(&p, x, active, sel);
    Adjustment {
        nodes,
        cross_covariances,
        link_variances,
        points,
        rejected,
        standstills: Vec::new(),
        skipped: p.skipped,
        sigma0,
        redundancy,
        variance_factors,
        iterations,
        timings,
    }
}
