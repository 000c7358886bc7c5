//! The adjustment driver: Levenberg–Marquardt (`lm.rs`) on the (Huber-)weighted normal equations with one
//! symbolic factorisation, then Baarda data snooping, then posterior covariances from the selected inverse.

use faer::Par;
use nalgebra::{Matrix6, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::config::AdjustmentConfig;
use crate::heights::HeightBias;
use crate::jumps::DetectedJump;
use crate::lm::{Iteration, Observed, minimize};
use crate::normal::assemble;
use crate::observations::{MotionError, ObservationError, ObservationRef, TiePointId};
use crate::problem::{AdjustmentInput, Item, Kind, Problem, node};
use crate::solver::{Factorizer, SelectedInverse, SolverError, SolverTimings};
use crate::standstill::Standstill;
use crate::stats::{Suspect, VarianceFactors, node_covariances, sigma0, variance_factors, w_tests};

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

/// An image-derived relative motion (`motions[index]`) rejected by data snooping.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct RejectedMotion {
    /// Index in the observation set's `motions`.
    pub index: usize,
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
    /// The estimated height bias of every aerial frame set with aerial heights in the adjustment.
    pub height_biases: Vec<HeightBias>,
    /// DG jumps found by data snooping on the relative constraints (those links were widened).
    pub jumps: Vec<DetectedJump>,
    /// Observations not used because they are broken or outside the trajectory.
    pub skipped: Vec<ObservationError>,
    /// Relative motions rejected by data snooping.
    pub rejected_motions: Vec<RejectedMotion>,
    /// Relative motions not used because they are broken or outside the trajectory.
    pub skipped_motions: Vec<MotionError>,
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
/// time window) until none is left — an observation is rejected, a relative constraint (with jump
/// detection) widened as a DG jump; posterior covariances at the final solution. Broken observations are
/// skipped and listed, not fatal. `par` is the parallelism of the per-observation work and the factorisation.
pub fn adjust(input: &AdjustmentInput<'_>, config: &AdjustmentConfig, par: Par) -> Result<Adjustment, AdjustmentError> {
    adjust_observed(input, config, par, &mut |_| {})
}

/// [`adjust`], reporting every Gauss–Newton/LM iteration to `observer` as it finishes (e.g. for a progress
/// display: [`Iteration::note`]).
pub fn adjust_observed(
    input: &AdjustmentInput<'_>,
    config: &AdjustmentConfig,
    par: Par,
    observer: &mut dyn FnMut(&Iteration),
) -> Result<Adjustment, AdjustmentError> {
    let mut problem = crate::build::problem(input, config, par);
    let mut x = initial_state(&problem);
    let mut active = vec![true; problem.obs.len()];
    let mut fac = Factorizer::new(&problem.pattern, par)?;
    let mut observed = Observed { observer, round: 0, rejected: 0, done: 0 };
    let mut iterations = minimize(&problem, &mut x, &active, config.huber, &mut fac, config, &mut observed)?;
    let mut snooped = Snooped::new(&problem, config);
    let selected = match config.snooping {
        Some(snoop) => {
            let mut round = 0;
            loop {
                observed.round = round + 1;
                observed.rejected = snooped.count();
                iterations += minimize(&problem, &mut x, &active, None, &mut fac, config, &mut observed)?;
                let sel = factor_at(&problem, &x, &active, None, &mut fac)?;
                let links = config.jump_detection.is_some().then_some(snooped.testable.as_slice());
                let found = w_tests(&problem, &x, &active, &sel, &snoop, links);
                if found.is_empty() || round >= snoop.max_rounds {
                    break sel;
                }
                for (suspect, w) in found {
                    snooped.apply(&mut problem, &mut active, suspect, w, round, config);
                }
                round += 1;
            }
        }
        None => factor_at(&problem, &x, &active, config.huber, &mut fac)?,
    };
    let mut out = finish(problem, &x, &active, &selected, snooped.rejected, iterations, fac.timings);
    out.standstills = snooped.standstills;
    out.jumps = snooped.jumps;
    out.rejected_motions = snooped.motions;
    Ok(out)
}

/// What data snooping found so far: rejected observations, standstills with their fate, detected jumps,
/// and the relative constraints still under test.
struct Snooped {
    rejected: Vec<RejectedObservation>,
    motions: Vec<RejectedMotion>,
    standstills: Vec<StandstillOutcome>,
    jumps: Vec<DetectedJump>,
    /// The links still tested for jumps (one widened to the largest σ is not tested again).
    testable: Vec<bool>,
}

impl Snooped {
    fn new(p: &Problem, config: &AdjustmentConfig) -> Self {
        Self {
            rejected: Vec::new(),
            motions: Vec::new(),
            standstills: p.standstills.iter().map(|s| StandstillOutcome { standstill: *s, rejected: None }).collect(),
            jumps: Vec::new(),
            testable: vec![config.jump_detection.is_some(); p.relative_sigma.len()],
        }
    }

    /// Rejected observations and standstills, and detected jumps.
    fn count(&self) -> usize {
        let standstills = self.standstills.iter().filter(|s| !s.accepted()).count();
        self.rejected.len() + self.motions.len() + standstills + self.jumps.len()
    }

    /// Act on one suspect of snooping round `round`: reject an observation (a standstill's both parts, a tie
    /// left undetermined whole) or widen a relative constraint as a DG jump.
    fn apply(
        &mut self,
        p: &mut Problem,
        active: &mut [bool],
        suspect: Suspect,
        w: f64,
        round: usize,
        config: &AdjustmentConfig,
    ) {
        let i = match (suspect, &config.jump_detection, &config.snooping) {
            (Suspect::Observation(i), _, _) => i,
            (Suspect::Link(k), Some(j), Some(snoop)) => {
                self.testable[k] = crate::jumps::widen(p, k, w, snoop.critical_value, j.sigma);
                let (start, end) = (p.nodes.times[k], p.nodes.times[k + 1]);
                if !self.jumps.iter().any(|d| d.start == start) {
                    self.jumps.push(DetectedJump { start, end, w, round });
                }
                return;
            }
            (Suspect::Link(_), _, _) => return,
        };
        active[i] = false;
        match &p.obs[i].item {
            Item::Observation(item) => {
                self.rejected.push(RejectedObservation { item: item.clone(), w, round });
                self.rejected.extend(drop_undetermined(p, i, active, w, round));
            }
            Item::Standstill(s) => {
                // Both parts (position and heading) go together.
                for (o, a) in p.obs.iter().zip(active.iter_mut()) {
                    *a &= o.item != p.obs[i].item;
                }
                self.standstills[*s].rejected = Some((w, round));
            }
            Item::Motion(index) => self.motions.push(RejectedMotion { index: *index, w, round }),
        }
    }
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
    let height_biases = p
        .biases
        .iter()
        .enumerate()
        .map(|(h, b)| {
            let i = p.bias_param(h);
            let (frames, points, prior_sigma) = (b.frames.clone(), b.points, b.prior_sigma);
            HeightBias { frames, points, bias: x[i], prior_sigma, sigma: sel.get(i, i).max(0.0).sqrt() }
        })
        .collect();
    Adjustment {
        nodes,
        cross_covariances,
        link_variances,
        points,
        rejected,
        standstills: Vec::new(),
        height_biases,
        jumps: Vec::new(),
        skipped: p.skipped,
        rejected_motions: Vec::new(),
        skipped_motions: p.skipped_motions,
        sigma0,
        redundancy,
        variance_factors,
        iterations,
        timings,
    }
}
