//! The per-tile driver of paper 000 §3: panoramas in time order, each paired with a neighbour closer than a
//! bound; per pair steps 1–4 (`crate::mm`), then steps 5–8 (`crate::aerial::register_patch`); the tie
//! points and per-image diagnostics go into a versioned [`TileResult`].
//!
//! Ortho-images and KAZE features are computed once per panorama; pairs run in parallel (rayon).

mod pair;
mod ties;

use std::time::{Duration, Instant};

use plumbline_geo::tiling::TileId;
use plumbline_imaging::kaze::KazeFeatures;
use rayon::prelude::*;

use crate::aerial::{AerialConfig, AerialReference};
use crate::mm::{MmConfig, MmError, OrthoPatch, Panorama, PanoramaRig, features, ortho_patch};
use crate::output::{ImageDiagnostic, TileResult, TileResultV1, TileSummary};

pub use pair::neighbour;

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
    /// Elapsed time of the whole call.
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
}

/// Per panorama: its ortho-image and features, or the error that stopped them.
pub(crate) struct Prepared {
    pub patch: Result<(OrthoPatch, KazeFeatures), MmError>,
    pub timings: StageTimings,
}

/// Register every panorama of a tile with its neighbour and with the aerial reference (paper 000 §3).
/// Bad panoramas (wrong size, no neighbour, failed steps) get a diagnostic; the others go on.
pub fn register_tile(
    tile: TileId,
    panoramas: &[Panorama],
    rig: &PanoramaRig,
    reference: &AerialReference,
    config: &PipelineConfig,
) -> TileRun {
    let start = Instant::now();
    let mut order: Vec<&Panorama> = panoramas.iter().collect();
    order.sort_by(|a, b| a.time.total_cmp(&b.time).then_with(|| a.id.cmp(&b.id)));
    let prepared: Vec<Prepared> = order.par_iter().map(|p| prepare(p, rig, &config.mm)).collect();
    let inputs = pair::TileInputs { order: &order, prepared: &prepared, rig, reference, config };
    let outcomes: Vec<(ImageDiagnostic, Vec<_>, StageTimings)> =
        (0..order.len()).into_par_iter().map(|i| pair::process(i, &inputs)).collect();
    let mut timings = StageTimings::default();
    prepared.iter().for_each(|p| timings.add(&p.timings));
    let (mut images, mut all_ties) = (Vec::with_capacity(order.len()), Vec::new());
    for (diagnostic, ties, t) in outcomes {
        timings.add(&t);
        images.push(diagnostic);
        all_ties.extend(ties);
    }
    let summary = TileSummary::of(&images, &all_ties);
    timings.total = start.elapsed();
    TileRun { result: TileResult::V1(TileResultV1 { tile, ties: all_ties, images, summary }), timings }
}

/// Step 1 and the KAZE features of one panorama.
fn prepare(pano: &Panorama, rig: &PanoramaRig, config: &MmConfig) -> Prepared {
    let mut timings = StageTimings::default();
    let t0 = Instant::now();
    let patch = ortho_patch(pano, rig, config.gsd, config.half_extent);
    timings.ortho = t0.elapsed();
    let patch = patch.and_then(|patch| {
        let t1 = Instant::now();
        let f = features(&patch, &pano.id, config);
        timings.features = t1.elapsed();
        f.map(|f| (patch, f))
    });
    Prepared { patch, timings }
}
