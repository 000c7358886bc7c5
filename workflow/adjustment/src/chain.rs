//! The DG chain model of the problem: the relative random-walk constraints between consecutive nodes (with
//! the weak links, and the jumps localised inside flagged ones) and the weak absolute prior (with its floor
//! between DG breaks and its optional per-time spreading).

use faer::Par;
use nalgebra::{Vector3, Vector6};
use plumbline_geo::Trajectory;

use crate::config::AdjustmentConfig;
use crate::nodes::{Nodes, WeakLink, dg_std, link_factor, relative_sigma};
use crate::problem::{AdjustmentInput, dg_pose};
use crate::standstill::Standstill;

/// Where the DG breaks: every given weak link and every standstill over which the DG moves more than
/// `explained_above` (a jump while standing).
pub(crate) fn breaks(
    input: &AdjustmentInput<'_>,
    standstills: &[Standstill],
    config: &AdjustmentConfig,
) -> Vec<(f64, f64)> {
    let t = input.trajectory;
    let threshold = config.standstill.map_or(f64::INFINITY, |c| c.explained_above);
    let moved = |s: &&Standstill| {
        dg_pose(t, s.end).zip(dg_pose(t, s.start)).is_some_and(|(b, a)| (b.p - a.p).norm() > threshold)
    };
    let jumps = standstills.iter().filter(moved).map(|s| (s.start, s.end));
    input.weak_links.iter().map(|l| (l.start, l.end)).chain(jumps).collect()
}

/// The weak links: all of them, the flagged ones whose jump is localised, and the standstills'.
pub(crate) struct Links<'a> {
    pub all: &'a [WeakLink],
    pub flagged: &'a [WeakLink],
    pub still: &'a [WeakLink],
    pub standstills: &'a [Standstill],
    /// The crab angle and the spans where the DG's own motion is anomalous (`crate::kinematics`).
    pub anomalous: &'a crate::kinematics::Anomalies,
}

/// The DG chain of a problem: per link the relative constraint's mean and σ, per node the weak prior's σ.
pub(crate) struct Chain {
    pub relative: Vec<Vector6<f64>>,
    /// The expected position increment of the correction over each link: zero where the DG's relative
    /// motion is trusted, minus the DG's anomalous displacement where it departs from the vehicle's kinematics.
    pub mean: Vec<Vector3<f64>>,
    pub prior: Vec<Vector6<f64>>,
}

/// The σ of the relative constraint between each pair of consecutive nodes and of each node's weak prior.
pub(crate) fn chain(
    nodes: &Nodes,
    trajectory: &Trajectory,
    links: &Links<'_>,
    breaks: &[(f64, f64)],
    config: &AdjustmentConfig,
    par: Par,
) -> Chain {
    let stds = crate::parallel::map(par, nodes.len(), |k| dg_std(trajectory, nodes.times[k], config));
    let mut relative: Vec<Vector6<f64>> = nodes
        .times
        .windows(2)
        .zip(stds.windows(2))
        .map(|(t, s)| relative_sigma(t[1] - t[0], &s[0], &s[1], config, link_factor(links.all, t[0], t[1])))
        .collect();
    let mut mean = vec![Vector3::zeros(); relative.len()];
    if let Some(c) = config.kinematic_jumps.filter(|c| c.widen) {
        crate::kinematics::widen(&mut relative, &mut mean, &nodes.times, trajectory, links.anomalous, &c);
    }
    if let Some(c) = &config.jump_localization {
        for l in links.flagged {
            let mut chain = Chain { relative, mean, prior: Vec::new() };
            localize(&mut chain, l, nodes, &stds, trajectory, links, config, c);
            (relative, mean) = (chain.relative, chain.mean);
        }
    }
    let prior = priors(nodes, &stds, breaks, config);
    Chain { relative, mean, prior }
}

/// Replace the evenly weakened links inside flagged interval `l` by links that follow the vehicle's reference
/// motion where the DG departs from it (mean −e, σ widened by |e|; [`crate::localize`]).
#[allow(clippy::too_many_arguments)]
fn localize(
    chain: &mut Chain,
    l: &WeakLink,
    nodes: &Nodes,
    stds: &[Vector6<f64>],
    trajectory: &Trajectory,
    links: &Links<'_>,
    config: &AdjustmentConfig,
    c: &crate::config::JumpLocalizationConfig,
) {
    // The links [k0, k1) inside the flagged interval.
    let t = &nodes.times;
    let k0 = t.partition_point(|x| *x < l.start - 1e-9);
    let k1 = t.partition_point(|x| *x <= l.end + 1e-9).saturating_sub(1);
    if k1 <= k0 + 1 {
        return;
    }
    let base: Vec<Vector6<f64>> =
        (k0..k1).map(|k| relative_sigma(t[k + 1] - t[k], &stds[k], &stds[k + 1], config, 1.0)).collect();
    let excess = crate::localize::anomalies(trajectory, &t[k0..=k1], c, links.standstills, links.anomalous.crab);
    let sizes: Vec<f64> = excess.iter().map(|e| e.norm()).collect();
    for (j, widened) in crate::localize::widen(&base, &sizes, l.factor, c).into_iter().enumerate() {
        // At least as weak as an overlapping standstill makes it.
        chain.relative[k0 + j] = widened.sup(&(base[j] * link_factor(links.still, t[k0 + j], t[k0 + j + 1])));
        chain.mean[k0 + j] = -excess[j];
    }
}

/// The weak prior of each node: prior_scale · σ_DG (spread per time if asked), its position part floored
/// inside possible faults at σ_floor · √(span / Δt) — one offset per span, whatever the node count.
fn priors(nodes: &Nodes, stds: &[Vector6<f64>], breaks: &[(f64, f64)], config: &AdjustmentConfig) -> Vec<Vector6<f64>> {
    let spans = config.fault_prior.map(|f| (crate::faults::fault_spans(breaks, f.max_duration), f.sigma));
    let floor = |k: usize| {
        let (spans, sigma) = spans.as_ref()?;
        let duration = crate::faults::containing(spans, nodes.times[k])?;
        let share = time_share(nodes, k);
        Some(sigma * if share > 0.0 { (duration / share).sqrt().max(1.0) } else { 1.0 })
    };
    stds.iter()
        .enumerate()
        .map(|(k, s)| {
            let mut prior = s * (config.prior_scale * prior_spread(nodes, k, config));
            if let Some(f) = floor(k) {
                // A possible jump offset: the control, not the DG's own σ, decides.
                for c in 0..3 {
                    prior[c] = prior[c].max(f);
                }
            }
            prior
        })
        .collect()
}

/// √(prior_time / Δt_k) (at least 1), Δt_k the half span between node k's neighbours: the factor that makes
/// the weak prior count once per `prior_time` seconds, whatever the node density.
fn prior_spread(nodes: &Nodes, k: usize, config: &AdjustmentConfig) -> f64 {
    let Some(per) = config.prior_time.filter(|p| *p > 0.0) else {
        return 1.0;
    };
    let share = time_share(nodes, k);
    if share > 0.0 { (per / share).sqrt().max(1.0) } else { 1.0 }
}

/// The time node k stands for: half the span between its neighbours.
fn time_share(nodes: &Nodes, k: usize) -> f64 {
    let t = &nodes.times;
    0.5 * (t[(k + 1).min(t.len() - 1)] - t[k.saturating_sub(1)])
}
