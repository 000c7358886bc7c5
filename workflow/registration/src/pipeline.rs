//! The per-tile driver of paper 000 §3: panoramas in time order, each owned one paired with a neighbour
//! closer than a bound; per pair steps 1–4 (`crate::mm`), then steps 5–8 (`crate::aerial::register_patch`);
//! the tie points and per-image diagnostics go into a versioned [`TileResult`].
//!
//! Step 1 and the KAZE features run once per panorama, one panorama at a time if the caller wishes
//! ([`prepare_panorama`]: the full panorama is not needed afterwards); pairs run in parallel (rayon).

mod pair;
mod prepared;
mod ties;

use std::time::{Duration, Instant};

use plumbline_geo::tiling::TileId;
use rayon::prelude::*;

use crate::aerial::{AerialConfig, AerialReference, ImageTrace};
use crate::mm::{MmConfig, PanoramaRig};
use crate::output::{ImageDiagnostic, TileResult, TileResultV1, TileSummary};

pub use pair::neighbour;
pub use prepared::{PanoramaInfo, PreparedPanorama, panoramas_to_prepare, prepare_panorama, prepare_panoramas};

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
    /// Fewest triangulated MM points for an aerial registration (paper 000 §3.8 needs ten correspondences).
    pub min_mm_points: usize,
    /// Keep MM↔MM points without an aerial match as ties (they link neighbouring panoramas).
    pub keep_mm_only_ties: bool,
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

/// Register every owned panorama of a tile with its neighbour and with the aerial reference (paper 000 §3).
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
/// (from several threads; for progress reports).
pub fn register_tile_reporting(
    tile: TileId,
    panoramas: &[PreparedPanorama],
    rig: &PanoramaRig,
    reference: &AerialReference,
    config: &PipelineConfig,
    done: &(dyn Fn(&ImageDiagnostic) + Sync),
) -> TileRun {
    let start = Instant::now();
    let order: Vec<&PreparedPanorama> = prepared::time_order(panoramas, |p| (p.pano.time, p.pano.id.as_str()))
        .into_iter()
        .map(|k| &panoramas[k])
        .collect();
    let poses: Vec<_> = order.iter().map(|p| &p.pano.pose).collect();
    let inputs = pair::TileInputs { order: &order, poses: &poses, rig, reference, config };
    let owned: Vec<usize> = (0..order.len()).filter(|&i| order[i].owned).collect();
    let outcomes: Vec<pair::PairOutcome> = owned
        .into_par_iter()
        .map(|i| {
            let outcome = pair::process(i, &inputs);
            done(&outcome.diagnostic);
            outcome
        })
        .collect();
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
    timings.total = start.elapsed();
    TileRun { result: TileResult::V1(TileResultV1 { tile, ties: all_ties, images, summary }), timings, traces }
}
