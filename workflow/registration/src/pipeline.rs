//! The per-tile driver of Jende et al. 2017 §3: panoramas in time order, each owned one paired with a neighbour
//! closer than a bound; per pair steps 1–4 (`crate::mm`), then steps 5–8 (`crate::aerial::register_patch`);
//! the tie points and per-image diagnostics go into a versioned [`TileResult`].
//!
//! Step 1 and the KAZE features run once per panorama, one panorama at a time if the caller wishes
//! ([`prepare_panorama`]: the full panorama is not needed afterwards); pairs run in parallel (rayon). Modules:
//! `prepared` (step 1 and the features; which panoramas need them), `pair` (one owned panorama and its
//! neighbour through steps 2–8), `pairing` (which neighbour, [`neighbour`], from the DG poses alone; below
//! both), `ties` (the tie points of a pair) and [`crosscheck`].

pub mod crosscheck;
mod pair;
mod pairing;
mod prepared;
mod ties;

use std::time::{Duration, Instant};

use plumbline_geo::tiling::TileId;
use rayon::prelude::*;

use crate::aerial::{AerialConfig, AerialReference, ImageTrace};
use crate::mm::{MmConfig, PanoramaRig};
use crate::output::{CrossCheck, Disagreement, DiscardReason, ImageDiagnostic, TileResult, TileResultV1, TileSummary};
use crosscheck::{Comparison, CrossCheckConfig, Link, Offset, Verdict};

pub use pairing::neighbour;
pub use prepared::{
    PanoramaInfo, PreparedPanorama, panoramas_to_prepare, panoramas_to_prepare_for, prepare_panorama,
    prepare_panoramas, time_order,
};

#[cfg(test)]
mod context_tests;
#[cfg(test)]
mod tests;

/// Settings of the whole pipeline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineConfig {
    /// Steps 1–4.
    pub mm: MmConfig,
    /// Steps 5–8.
    pub aerial: AerialConfig,
    /// Largest distance between the DG camera centres of a pair, metres.
    pub max_pair_distance: f64,
    /// Smallest distance of a pair, metres (below it the rays are too close to parallel).
    pub min_pair_distance: f64,
    /// Fewest triangulated MM points for an aerial registration (Jende et al. 2017 §3.8 needs ten correspondences).
    pub min_mm_points: usize,
    /// Keep MM↔MM points without an aerial match as ties (they link neighbouring panoramas).
    pub keep_mm_only_ties: bool,
    /// The cross-panorama check of the aerial offsets (Jende et al. 2017 §3.9).
    pub cross_check: CrossCheckConfig,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self {
            mm: MmConfig::default(),
            aerial: AerialConfig::default(),
            max_pair_distance: 14.0,
            min_pair_distance: 1.0,
            min_mm_points: 10,
            keep_mm_only_ties: true,
            cross_check: CrossCheckConfig::default(),
        }
    }
}

/// Wall-clock time spent in each stage, summed over panoramas (stages run in parallel, so these are
/// thread-seconds rather than elapsed time). Not part of the result: results must be reproducible.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimings {
    /// Step 1, §3.2.
    pub ortho: Duration,
    /// KAZE detection and description (§3.3).
    pub features: Duration,
    /// KAZE matching, RANSAC, verification (§3.3) and corner matching (§3.4).
    pub matching: Duration,
    /// Step 4, §3.5.
    pub triangulation: Duration,
    /// Steps 5–8, §3.6–§3.9.
    pub aerial: Duration,
    /// Road-marking extraction from the ortho patches.
    pub lines: Duration,
    /// Elapsed time of the `register_tile` call: the pairs (preparation, timed in `ortho` and `features`,
    /// happens before it, panorama by panorama).
    pub total: Duration,
}

impl StageTimings {
    fn add(&mut self, other: &StageTimings) {
        self.ortho += other.ortho;
        self.features += other.features;
        self.matching += other.matching;
        self.triangulation += other.triangulation;
        self.aerial += other.aerial;
        self.lines += other.lines;
    }
}

/// A tile's result and how long its stages took.
#[derive(Clone, Debug)]
pub struct TileRun {
    /// The versioned result.
    pub result: TileResult,
    /// Stage timings.
    pub timings: StageTimings,
    /// Per owned panorama (in the order of the result's diagnostics): the aerial matching's trace, for
    /// diagnosis against ground truth; not part of the result.
    pub traces: Vec<Vec<ImageTrace>>,
}

/// Register every owned panorama of a tile with its neighbour and with the aerial reference (Jende et al. 2017 §3).
/// `panoramas` are the tile's panoramas prepared one at a time ([`prepare_panorama`]), owned and context, in
/// any order; context panoramas serve only as neighbours and get no diagnostic. Bad panoramas (wrong size,
/// no neighbour, failed steps) get a diagnostic; the others go on.
pub fn register_tile(
    tile: TileId,
    panoramas: &[PreparedPanorama],
    rig: &PanoramaRig,
    reference: &AerialReference,
    config: &PipelineConfig,
) -> TileRun {
    register_tile_reporting(tile, panoramas, rig, reference, config, &|_| {})
}

/// [`register_tile`], calling `done` with each owned panorama's diagnostic as soon as it is registered
/// (from several threads; for progress reports; before the cross-panorama check, which may still discard it).
pub fn register_tile_reporting(
    tile: TileId,
    panoramas: &[PreparedPanorama],
    rig: &PanoramaRig,
    reference: &AerialReference,
    config: &PipelineConfig,
    done: &(dyn Fn(&ImageDiagnostic) + Sync),
) -> TileRun {
    let mut registration = TileRegistration::new(tile);
    let owned: Vec<&str> = panoramas.iter().filter(|p| p.owned).map(PreparedPanorama::id).collect();
    let inputs = TileInputs { rig, reference, config };
    registration.register(panoramas, &owned, &inputs, done);
    registration.finish(panoramas, config)
}

/// What steps 2–8 read besides the panoramas: the rig, the aerial reference and the settings.
#[derive(Clone, Copy, Debug)]
pub struct TileInputs<'a> {
    /// The panoramic camera on the vehicle.
    pub rig: &'a PanoramaRig,
    /// Aerial frames or an orthophoto window over the tile.
    pub reference: &'a AerialReference,
    /// The pipeline's settings.
    pub config: &'a PipelineConfig,
}

/// A tile's registration done a few owned panoramas at a time, so that a caller can prepare the panoramas of
/// one stretch of the drive, register the owned ones, release their patches ([`PreparedPanorama::release`])
/// and go on: a pair only reads its panorama's patch and its neighbour's (the next or the previous in time,
/// [`neighbour`]). [`TileRegistration::finish`] runs the cross-panorama check over every outcome. Fed the
/// whole tile at once it is [`register_tile`].
pub struct TileRegistration {
    tile: TileId,
    start: Instant,
    outcomes: Vec<pair::PairOutcome>,
}

impl std::fmt::Debug for TileRegistration {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TileRegistration")
            .field("tile", &self.tile)
            .field("registered", &self.outcomes.len())
            .finish_non_exhaustive()
    }
}

impl TileRegistration {
    /// Nothing registered yet.
    pub fn new(tile: TileId) -> Self {
        Self { tile, start: Instant::now(), outcomes: Vec::new() }
    }

    /// Steps 2–8 for the owned panoramas named in `ids`, in parallel. `panoramas` are the tile's panoramas
    /// that can be read (owned and context, in any order): the named ones and their neighbours must be
    /// prepared; the others may be unprepared or released. `done` is called as in [`register_tile_reporting`].
    pub fn register(
        &mut self,
        panoramas: &[PreparedPanorama],
        ids: &[&str],
        inputs: &TileInputs<'_>,
        done: &(dyn Fn(&ImageDiagnostic) + Sync),
    ) {
        let order: Vec<&PreparedPanorama> =
            time_order(panoramas, |p| (p.pano.time, p.pano.id.as_str())).into_iter().map(|k| &panoramas[k]).collect();
        let poses: Vec<_> = order.iter().map(|p| &p.pano.pose).collect();
        let pairs = pair::TileInputs {
            order: &order,
            poses: &poses,
            rig: inputs.rig,
            reference: inputs.reference,
            config: inputs.config,
        };
        let wanted: std::collections::HashSet<&str> = ids.iter().copied().collect();
        let owned: Vec<usize> =
            (0..order.len()).filter(|&i| order[i].owned && wanted.contains(order[i].pano.id.as_str())).collect();
        let outcomes: Vec<pair::PairOutcome> = owned
            .par_iter()
            .map(|&i| {
                let outcome = pair::process(i, &pairs);
                done(&outcome.diagnostic);
                outcome
            })
            .collect();
        self.outcomes.extend(outcomes);
    }

    /// Owned panoramas registered so far.
    pub fn registered(&self) -> usize {
        self.outcomes.len()
    }

    /// The cross-panorama check over everything registered (Jende et al. 2017 §3.9) and the tile's result;
    /// `panoramas` are the tile's readable panoramas as in the last [`TileRegistration::register`] (their
    /// patches may be released).
    pub fn finish(self, panoramas: &[PreparedPanorama], config: &PipelineConfig) -> TileRun {
        let order: Vec<&PreparedPanorama> =
            time_order(panoramas, |p| (p.pano.time, p.pano.id.as_str())).into_iter().map(|k| &panoramas[k]).collect();
        let position: std::collections::HashMap<&str, usize> =
            order.iter().enumerate().map(|(i, p)| (p.pano.id.as_str(), i)).collect();
        // Outcomes in time order, each with its place in `order` (a registered panorama is readable, so it
        // is there).
        let mut placed: Vec<(usize, pair::PairOutcome)> = self
            .outcomes
            .into_iter()
            .filter_map(|o| position.get(o.diagnostic.image.as_str()).map(|&i| (i, o)))
            .collect();
        placed.sort_by_key(|(i, _)| *i);
        let (owned, mut outcomes): (Vec<usize>, Vec<pair::PairOutcome>) = placed.into_iter().unzip();
        if config.cross_check.enabled {
            cross_check(&order, &owned, &mut outcomes, config);
        }
        let mut timings = StageTimings::default();
        order.iter().for_each(|p| timings.add(&p.timings));
        let (mut images, mut all_ties, mut traces) = (Vec::with_capacity(outcomes.len()), Vec::new(), Vec::new());
        for o in outcomes {
            timings.add(&o.timings);
            images.push(o.diagnostic);
            all_ties.extend(o.ties);
            traces.push(o.trace);
        }
        let summary = TileSummary::of(&images, &all_ties);
        timings.total = self.start.elapsed();
        let result = TileResult::V1(TileResultV1 { tile: self.tile, ties: all_ties, images, summary });
        TileRun { result, timings, traces }
    }
}

/// The cross-panorama check over the tile (Jende et al. 2017 §3.9): the matched panoramas' aerial offsets compared
/// through the image-derived motions; a flagged panorama is discarded as inconsistent and its ties keep
/// their MM rays but lose their aerial coordinates. `owned[k]` is the place of `outcomes[k]` in `order`.
fn cross_check(
    order: &[&PreparedPanorama],
    owned: &[usize],
    outcomes: &mut [pair::PairOutcome],
    config: &PipelineConfig,
) {
    let mut at: Vec<Option<usize>> = vec![None; order.len()];
    owned.iter().enumerate().for_each(|(k, &i)| at[i] = Some(k));
    let diag = |i: usize| at[i].map(|k| &outcomes[k].diagnostic);
    let offsets: Vec<Option<Offset>> = (0..order.len())
        .map(|i| {
            let d = diag(i).filter(|d| d.discarded.is_none())?;
            d.aerial_offset.map(|o| Offset { value: o.offset, std: o.std })
        })
        .collect();
    let links: Vec<Option<Link>> = (1..order.len()).map(|i| link(order, i - 1, &diag)).collect();
    let checked = crosscheck::check(&offsets, &links, &config.cross_check);
    for k in checked.broken_links {
        for (i, other) in [(k, k + 1), (k + 1, k)] {
            let Some(d) = at[i].map(|o| &mut outcomes[o].diagnostic) else { continue };
            if d.motion.is_some() && d.neighbour.as_deref() == Some(order[other].pano.id.as_str()) {
                d.motion_contradicted = true;
            }
        }
    }
    let name = |c: &Comparison| order[c.partner].pano.id.clone();
    for (i, verdict) in checked.verdicts.iter().enumerate() {
        let Some(outcome) = at[i].map(|k| &mut outcomes[k]) else { continue };
        let (comparisons, flagged) = match verdict {
            Verdict::Unchecked => continue,
            Verdict::Unverified => (&[][..], false),
            Verdict::Kept(c) => (&c[..], false),
            Verdict::Flagged(c) => (&c[..], true),
        };
        let (agreeing, disagreeing): (Vec<&Comparison>, Vec<&Comparison>) =
            comparisons.iter().partition(|c| c.agrees());
        outcome.diagnostic.cross_check = Some(if comparisons.is_empty() {
            CrossCheck::Unverified
        } else {
            CrossCheck::Compared {
                agreeing: agreeing.iter().map(|c| name(c)).collect(),
                disagreeing: disagreeing.iter().map(|c| name(c)).collect(),
            }
        });
        if flagged {
            let disagreements = disagreeing
                .iter()
                .map(|c| Disagreement { partner: name(c), residual_m: c.residual_m, tolerance_m: c.tolerance_m })
                .collect();
            discard(outcome, DiscardReason::Inconsistent { disagreements, agreeing: agreeing.len() }, config);
        }
    }
}

/// The link between panoramas `a` and `a + 1` of the time order: the image motion either measured (both
/// are reported from the earlier to the later); the one with the smaller σ when both did.
fn link<'a>(
    order: &[&PreparedPanorama],
    a: usize,
    diag: &impl Fn(usize) -> Option<&'a ImageDiagnostic>,
) -> Option<Link> {
    let (pa, pb) = (&order[a].pano, &order[a + 1].pano);
    let measured =
        |i: usize, other: &str| diag(i).filter(|d| d.neighbour.as_deref() == Some(other)).and_then(|d| d.motion);
    let horizontal = |m: &plumbline_navigation::ImageMotion| m.std[0].hypot(m.std[1]);
    let motion = match (measured(a, &pb.id), measured(a + 1, &pa.id)) {
        (Some(x), Some(y)) => Some(if horizontal(&y) < horizontal(&x) { y } else { x }),
        (x, y) => x.or(y),
    }?;
    let dg = |p: &crate::mm::Panorama| [p.pose.translation.x(), p.pose.translation.y()];
    Some(Link::of(&motion, dg(pa), dg(pb)))
}

/// Discard a matched panorama: its ties keep their MM rays (or go, without MM-only ties) but lose their
/// aerial coordinates.
fn discard(outcome: &mut pair::PairOutcome, reason: DiscardReason, config: &PipelineConfig) {
    outcome.ties.iter_mut().for_each(|t| t.aerial = None);
    if !config.keep_mm_only_ties {
        outcome.ties.clear();
    }
    let d = &mut outcome.diagnostic;
    (d.aerial_points, d.discarded) = (0, Some(reason));
    d.aerial_frames.clear();
}
