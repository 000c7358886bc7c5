//! Turning a trajectory and an observation set into the internal problem: node epochs, DG poses at the
//! observation epochs, initial tie-point coordinates, chain weights and the sparsity pattern. Broken or
//! unusable observations are set aside with an error naming them; the rest go on. This drives the problem's
//! parts — relative motions, pole offsets, height biases, standstills, jump localisation, kinematic jumps
//! and the DG chain — over the plain types of `crate::problem`.

use faer::Par;
use nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use plumbline_geo::Trajectory;

use crate::config::{AdjustmentConfig, StandstillConfig};
use crate::model::DgPose;
use crate::nodes::{Nodes, WeakLink};
use crate::observations::{MotionError, ObservationError, ObservationRef, TiePoint, TiePointId, aerial_whitening};
use crate::pattern::Pattern;
use crate::problem::{AdjustmentInput, Item, Kind, Obs, Problem, dg_pose};
use crate::standstill::{Standstill, detect_standstills};

/// Validate, locate and wire up every observation.
pub(crate) fn problem(input: &AdjustmentInput<'_>, config: &AdjustmentConfig, par: Par) -> Problem {
    let mut b = Builder { input, raw: Vec::new(), skipped: Vec::new(), points: Vec::new(), point_init: Vec::new() };
    let skipped_motions = b.motions();
    b.poles();
    let offset_sigma = if config.pole_offsets { crate::offsets::share_pole_offsets(&mut b.raw) } else { Vec::new() };
    b.gnss();
    b.ties();
    let sets = &input.observations.aerial_frame_sets;
    let biases = config
        .height_biases
        .map(|c| crate::heights::share_height_biases(&mut b.raw, sets, &b.points, &c))
        .unwrap_or_default();
    let span = input.trajectory.span();
    let standstills = config.standstill.map(|c| detect_standstills(input.trajectory, &c)).unwrap_or_default();
    // Inside a standstill the zero-velocity constraint replaces the DG's relative motion.
    let mut links = match &config.standstill {
        Some(c) => unexplained(input.weak_links, &standstills, input.trajectory, c),
        None => input.weak_links.to_vec(),
    };
    let flagged = config.jump_localization.map(|_| links.clone()).unwrap_or_default();
    let factor = config.standstill.map_or(1.0, |c| c.chain_factor);
    let still: Vec<WeakLink> = standstills.iter().map(|s| WeakLink { start: s.start, end: s.end, factor }).collect();
    links.extend(still.iter().copied());
    // Weak-link and standstill boundaries are nodes too, so a jump is resolved where it happens.
    let bounds = links.iter().flat_map(|l| [l.start, l.end]);
    let inner = config.jump_localization.map(|c| crate::localize::sub_nodes(&flagged, &c)).unwrap_or_default();
    let anomalous =
        config.kinematic_jumps.map(|c| crate::kinematics::anomalous_spans(input.trajectory, &c)).unwrap_or_default();
    let kinematic = config.kinematic_jumps.map(|c| crate::kinematics::span_nodes(&anomalous.spans, &c));
    // A relative motion's both epochs are nodes.
    let times =
        b.raw.iter().flat_map(|o| [o.time, o.until]).chain(bounds).chain(inner).chain(kinematic.into_iter().flatten());
    let times = times.collect();
    let nodes = Nodes::new(times, span, config);
    let mut obs = b.raw;
    for o in &mut obs {
        match o.kind {
            Kind::Aerial { .. } => {}
            Kind::Motion { .. } => o.parts = crate::relative::difference_parts(&nodes, o.time, o.until),
            _ => o.parts = nodes.bracket(o.time),
        }
    }
    if let Some(c) = &config.standstill {
        obs.extend(standstill_obs(input.trajectory, &nodes, &standstills, c));
    }
    let mut breaks = crate::chain::breaks(input, &standstills, config);
    // Where the DG's own motion jumped (and the links are widened for it), it breaks like a flagged link.
    if config.kinematic_jumps.is_some_and(|c| c.widen) {
        breaks.extend(anomalous.spans.iter().copied());
    }
    let links = crate::chain::Links {
        all: &links,
        flagged: &flagged,
        still: &still,
        standstills: &standstills,
        anomalous: &anomalous,
    };
    let chain = crate::chain::chain(&nodes, input.trajectory, &links, &breaks, config, par);
    let layout = Layout { nodes: nodes.len(), points: b.points.len(), offsets: offset_sigma.len() };
    let widths: Vec<usize> = [(layout.points, 3), (layout.offsets, 2), (biases.len(), 1)]
        .iter()
        .flat_map(|(n, w)| std::iter::repeat_n(*w, *n))
        .collect();
    let pattern = Pattern::new(nodes.len(), &widths, pairs(&obs, &layout));
    Problem {
        nodes,
        obs,
        points: b.points,
        point_init: b.point_init,
        offset_sigma,
        biases,
        relative_sigma: chain.relative,
        relative_mean: chain.mean,
        prior_sigma: chain.prior,
        pattern,
        mount: *input.mount,
        skipped: b.skipped,
        skipped_motions,
        standstills,
        par,
    }
}

fn outside(item: ObservationRef, field: &'static str) -> ObservationError {
    ObservationError { item, field, problem: "lies outside the trajectory's time span".into() }
}

/// The weak links not explained by a standstill: a flagged interval (DG motion inconsistent with the image
/// motion) that contains a standstill over which the DG moves more than `c.explained_above` is taken to be
/// caused by that jump while standing, which the zero-velocity constraint absorbs; weakening the chain
/// around the standstill as well would leave it held only by the weak prior.
fn unexplained(links: &[WeakLink], still: &[Standstill], t: &Trajectory, c: &StandstillConfig) -> Vec<WeakLink> {
    let moved: Vec<(Standstill, f64)> =
        still.iter().filter_map(|s| Some((*s, (dg_pose(t, s.end)?.p - dg_pose(t, s.start)?.p).norm()))).collect();
    let explains =
        |l: &WeakLink| moved.iter().any(|(s, d)| s.start >= l.start && s.end <= l.end && *d > c.explained_above);
    links.iter().filter(|l| !explains(l)).copied().collect()
}

/// The zero-velocity constraints (position and heading) of each standstill, between the nodes at its ends
/// (interpolation weights −1 and +1 give δ_e − δ_s; model::standstill).
fn standstill_obs<'a>(
    trajectory: &'a Trajectory,
    nodes: &'a Nodes,
    standstills: &'a [Standstill],
    c: &'a StandstillConfig,
) -> impl Iterator<Item = Obs> + 'a {
    standstills
        .iter()
        .enumerate()
        .filter_map(move |(index, s)| {
            let (a, b) = (dg_pose(trajectory, s.start)?, dg_pose(trajectory, s.end)?);
            let (ka, kb) = (nodes.index_of(s.start)?, nodes.index_of(s.end)?);
            let rotation = Rotation3::from_matrix_unchecked(b.r * a.r.transpose()).scaled_axis();
            let make = move |offset, sigma, heading| Obs {
                item: Item::Standstill(index),
                time: s.start,
                until: s.end,
                dg: a,
                parts: vec![(ka, -1.0), (kb, 1.0)],
                kind: Kind::Standstill { offset, sigma, heading },
                pole_sigmas: None,
            };
            (ka != kb).then(|| [make(b.p - a.p, c.position_sigma, false), make(rotation, c.heading_sigma, true)])
        })
        .flatten()
}

/// Block counts: nodes, then tie points, cadastre offsets and height biases.
struct Layout {
    nodes: usize,
    points: usize,
    offsets: usize,
}

/// Block pairs coupled by observations (node–node, node–point, node–offset, point–bias).
fn pairs(obs: &[Obs], l: &Layout) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for o in obs {
        let mut blocks: Vec<usize> = o.parts.iter().map(|(k, _)| *k).collect();
        match o.kind {
            Kind::Ray { point, .. } | Kind::Aerial { point, bias: None, .. } => blocks.push(l.nodes + point),
            Kind::Aerial { point, bias: Some(h), .. } => {
                blocks.extend([l.nodes + point, l.nodes + l.points + l.offsets + h]);
            }
            Kind::Pole { offset: Some(g), .. } => blocks.push(l.nodes + l.points + g),
            _ => {}
        }
        for (i, a) in blocks.iter().enumerate() {
            out.extend(blocks[i + 1..].iter().map(|b| (*a, *b)));
        }
    }
    out
}

struct Builder<'a, 'b> {
    input: &'b AdjustmentInput<'a>,
    raw: Vec<Obs>,
    skipped: Vec<ObservationError>,
    points: Vec<TiePointId>,
    point_init: Vec<Vector3<f64>>,
}

impl Builder<'_, '_> {
    fn push(&mut self, item: ObservationRef, time: f64, kind: Kind) {
        match dg_pose(self.input.trajectory, time) {
            Some(dg) => self.raw.push(Obs {
                item: Item::Observation(item),
                time,
                until: time,
                dg,
                parts: Vec::new(),
                kind,
                pole_sigmas: None,
            }),
            None => self.skipped.push(outside(item, "time")),
        }
    }

    fn poles(&mut self) {
        for (index, pole) in self.input.observations.poles.iter().enumerate() {
            let problems = pole.problems(index);
            if !problems.is_empty() {
                self.skipped.extend(problems);
                continue;
            }
            let item = ObservationRef::Pole { index, cadastre_id: pole.cadastre_id.clone() };
            let Some(dg) = dg_pose(self.input.trajectory, pole.time) else {
                self.skipped.push(outside(item, "time"));
                continue;
            };
            // The observed pole at the vehicle's height: the update is horizontal.
            let observed = Vector3::new(pole.observed[0], pole.observed[1], dg.p.z);
            let kind =
                Kind::Pole { observed, cadastre: Vector2::from(pole.cadastre), sigma: pole.sigma(), offset: None };
            self.push(item, pole.time, kind);
            if let Some(o) = self.raw.last_mut() {
                o.pole_sigmas = Some((pole.sigma_camera, pole.sigma_pole));
            }
        }
    }

    /// The image-derived relative motions ([`crate::relative`]); the broken ones and those outside the
    /// trajectory are returned.
    fn motions(&mut self) -> Vec<MotionError> {
        let (obs, skipped) = crate::relative::observations(self.input.trajectory, &self.input.observations.motions);
        self.raw.extend(obs);
        skipped
    }

    fn gnss(&mut self) {
        for (index, g) in self.input.observations.gnss.iter().enumerate() {
            let problems = g.problems(index);
            if !problems.is_empty() {
                self.skipped.extend(problems);
                continue;
            }
            let kind = Kind::Gnss {
                lever: Vector3::from(g.lever_arm),
                measured: Vector3::from(g.position),
                sigma: Vector3::from(g.sigma),
            };
            self.push(ObservationRef::Gnss { index }, g.time, kind);
        }
    }

    fn ties(&mut self) {
        for (index, tie) in self.input.observations.ties.iter().enumerate() {
            let mut problems = tie.problems(index);
            let init = if problems.is_empty() { self.initial_point(index, tie, &mut problems) } else { None };
            match init {
                Some(x) if problems.is_empty() => self.add_tie(index, tie, x),
                _ => self.skipped.extend(problems),
            }
        }
    }

    fn add_tie(&mut self, index: usize, tie: &TiePoint, x: Vector3<f64>) {
        let point = self.points.len();
        self.points.push(tie.id.clone());
        self.point_init.push(x);
        for (ray, r) in tie.rays.iter().enumerate() {
            let item = ObservationRef::TieRay { index, point: tie.id.clone(), ray };
            self.push(item, r.time, Kind::Ray { point, direction: Vector3::from(r.direction), sigma: r.sigmas() });
        }
        if let Some(a) = &tie.aerial {
            let item = ObservationRef::TieAerial { index, point: tie.id.clone() };
            let whitening = aerial_whitening(&a.covariance).unwrap_or_else(Matrix3::identity);
            let dg = DgPose { p: Vector3::zeros(), r: Matrix3::identity() };
            let time = tie.rays.first().map_or(0.0, |r| r.time);
            let kind = Kind::Aerial { point, measured: Vector3::from(a.position), whitening, bias: None };
            let parts = Vec::new();
            self.raw.push(Obs { item: Item::Observation(item), time, until: time, dg, parts, kind, pole_sigmas: None });
        }
    }

    /// The aerial coordinates, or the least-squares intersection of the DG rays.
    fn initial_point(
        &self,
        index: usize,
        tie: &TiePoint,
        problems: &mut Vec<ObservationError>,
    ) -> Option<Vector3<f64>> {
        if let Some(a) = &tie.aerial {
            return Some(Vector3::from(a.position));
        }
        let item = ObservationRef::Tie { index, point: tie.id.clone() };
        let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
        for r in &tie.rays {
            let Some(dg) = dg_pose(self.input.trajectory, r.time) else {
                problems.push(outside(item.clone(), "rays.time"));
                return None;
            };
            let mount = self.input.mount;
            let centre = dg.p + dg.r * mount.lever_arm.v;
            let d = (dg.r * mount.boresight.matrix() * Vector3::from(r.direction)).normalize();
            let proj = Matrix3::identity() - d * d.transpose();
            a += proj;
            b += proj * centre;
        }
        // A near-singular system means (near-)parallel rays.
        let x = (a.determinant().abs() > 1e-9).then(|| a.try_inverse().map(|inv| inv * b)).flatten();
        if x.is_none() {
            problems.push(ObservationError { item, field: "rays", problem: "are parallel; cannot intersect".into() });
        }
        x
    }
}
