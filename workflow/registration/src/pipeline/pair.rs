//! One owned panorama of the tile: pair it with a neighbour, run steps 2–4 on the pair and steps 5–8 on its
//! patch, and describe what happened.

use std::time::Instant;

use plumbline_adjustment::TiePoint;
use plumbline_geo::MapFromBody;

use super::{PipelineConfig, PreparedPanorama, StageTimings, ties};
use crate::aerial::{AerialReference, ImageTrace, MmPatch, PatchPoint, register_patch};
use crate::mm::{MmPoint, PanoramaRig, image_motion, match_corners, pair_transform, triangulate};
use crate::output::{CornerCounts, DiscardReason, ImageDiagnostic};

/// Horizontal distance between the DG camera centres of two vehicle poses, metres.
fn distance(a: &MapFromBody, b: &MapFromBody, rig: &PanoramaRig) -> f64 {
    let (ca, cb) = (rig.mount.camera_pose(a).translation, rig.mount.camera_pose(b).translation);
    (ca.x() - cb.x()).hypot(ca.y() - cb.y())
}

/// The neighbour of panorama `i` of a tile whose DG poses in time order are `poses`: the next panorama in
/// time if it lies within the pairing distance, else the previous one; the reason when neither does.
pub fn neighbour(
    i: usize,
    poses: &[&MapFromBody],
    rig: &PanoramaRig,
    config: &PipelineConfig,
) -> Result<usize, DiscardReason> {
    let candidates = [i.checked_add(1).filter(|&j| j < poses.len()), i.checked_sub(1)];
    let mut nearest: Option<f64> = None;
    for j in candidates.into_iter().flatten() {
        let d = distance(poses[i], poses[j], rig);
        if d >= config.min_pair_distance && d <= config.max_pair_distance {
            return Ok(j);
        }
        nearest = Some(nearest.map_or(d, |n: f64| n.min(d)));
    }
    Err(DiscardReason::NoNeighbour { nearest_m: nearest })
}

fn failed(step: &str, message: String) -> DiscardReason {
    DiscardReason::Failed { step: step.to_owned(), message }
}

/// Everything a pair's processing reads: the tile's prepared panoramas in time order and their DG poses.
pub(crate) struct TileInputs<'a> {
    pub order: &'a [&'a PreparedPanorama],
    pub poses: &'a [&'a MapFromBody],
    pub rig: &'a PanoramaRig,
    pub reference: &'a AerialReference,
    pub config: &'a PipelineConfig,
}

/// What steps 2–8 gave for one panorama.
pub(crate) struct PairOutcome {
    /// Its diagnostic.
    pub diagnostic: ImageDiagnostic,
    /// Its ties.
    pub ties: Vec<TiePoint>,
    /// The time its stages took.
    pub timings: StageTimings,
    /// The aerial matching's trace (empty when it did not run).
    pub trace: Vec<ImageTrace>,
}

/// Steps 2–8 for panorama `i`.
pub(crate) fn process(i: usize, tile: &TileInputs<'_>) -> PairOutcome {
    let pano = &tile.order[i].pano;
    let mut diag = ImageDiagnostic {
        image: pano.id.clone(),
        time: pano.time,
        neighbour: None,
        transform: None,
        motion: None,
        corners: CornerCounts::default(),
        aerial_images: Vec::new(),
        aerial_points: 0,
        dropped_ties: 0,
        aerial_frames: Vec::new(),
        discarded: None,
    };
    let (mut timings, mut trace) = (StageTimings::default(), Vec::new());
    let ties = match run(i, tile, &mut diag, &mut timings, &mut trace) {
        Ok(ties) => ties,
        Err((reason, ties)) => {
            diag.discarded = Some(reason);
            ties
        }
    };
    PairOutcome { diagnostic: diag, ties, timings, trace }
}

type Discard = (DiscardReason, Vec<TiePoint>);

fn run(
    i: usize,
    tile: &TileInputs<'_>,
    diag: &mut ImageDiagnostic,
    timings: &mut StageTimings,
    trace: &mut Vec<ImageTrace>,
) -> Result<Vec<TiePoint>, Discard> {
    let TileInputs { order, poses, rig, reference, config } = *tile;
    let (pano, mm) = (&order[i].pano, &config.mm);
    let (patch, fa) = prepared(order[i], "ortho/features")?;
    let j = neighbour(i, poses, rig, config).map_err(|r| (r, vec![]))?;
    let other = &order[j].pano;
    diag.neighbour = Some(other.id.clone());
    let (patch_b, fb) = prepared(order[j], "neighbour ortho/features")?;
    let t0 = Instant::now();
    let transform = pair_transform(patch, fa, patch_b, fb, mm);
    diag.transform = Some(transform.source.clone());
    // paper 001 §4.1: the motion whenever KAZE measured it, also when it disagreed with the DG poses.
    let measure = |fit| image_motion((pano, patch), (other, patch_b), fit, rig.camera_height, mm);
    diag.motion = transform.fit.as_ref().and_then(measure);
    let corners = match_corners(patch, patch_b, &transform, &pano.id, mm);
    timings.matching += t0.elapsed();
    let corners = corners.map_err(|e| (failed("corner matching", e.to_string()), vec![]))?;
    let t1 = Instant::now();
    let (points, stats) = triangulate((patch, pano), (patch_b, other), rig, &corners.matches, mm);
    timings.triangulation += t1.elapsed();
    diag.corners = CornerCounts {
        detected: corners.detected,
        candidates: corners.candidates,
        matched: corners.matches.len(),
        triangulated: points.len(),
        rejected_geometry: stats.geometry,
        rejected_miss: stats.miss,
        rejected_off_ground: stats.off_ground,
    };
    if points.len() < config.min_mm_points {
        let only = ties::assemble(pano, other, &points, &[], config.keep_mm_only_ties);
        diag.dropped_ties = only.dropped;
        return Err((DiscardReason::TooFewMmPoints { points: points.len(), needed: config.min_mm_points }, only.ties));
    }
    let t2 = Instant::now();
    let points_for_aerial = patch_points(&points);
    let mm_patch = MmPatch {
        image: &patch.image,
        valid: &patch.valid,
        grid: &patch.grid,
        points: &points_for_aerial,
        position_sigma: pano.position_sigma,
    };
    let outcome = register_patch(&mm_patch, reference, &config.aerial);
    timings.aerial += t2.elapsed();
    let assembled = ties::assemble(pano, other, &points, &outcome.points, config.keep_mm_only_ties);
    let ties = assembled.ties;
    diag.dropped_ties = assembled.dropped;
    diag.aerial_frames = assembled.frames;
    diag.aerial_images = outcome.images;
    *trace = outcome.trace;
    diag.aerial_points = ties.iter().filter(|t| t.aerial.is_some()).count();
    match outcome.discarded {
        Some(d) => Err((DiscardReason::Aerial(d), ties)),
        None => Ok(ties),
    }
}

/// The patch and features of a prepared panorama; a failed or missing preparation as a discard of `step`.
fn prepared<'a>(
    p: &'a PreparedPanorama,
    step: &str,
) -> Result<&'a (crate::mm::OrthoPatch, plumbline_imaging::kaze::KazeFeatures), Discard> {
    match &p.patch {
        Some(Ok(prepared)) => Ok(prepared),
        Some(Err(e)) => Err((failed(step, e.to_string()), vec![])),
        None => Err((failed(step, format!("panorama {} was not prepared", p.pano.id)), vec![])),
    }
}

fn patch_points(points: &[MmPoint]) -> Vec<PatchPoint> {
    points
        .iter()
        .enumerate()
        .map(|(index, p)| PatchPoint {
            index,
            pixel: p.corner.a,
            map: [p.position.x(), p.position.y(), p.position.z()],
        })
        .collect()
}
