//! One panorama of the tile: pair it with a neighbour, run steps 2–4 on the pair and steps 5–8 on its
//! patch, and describe what happened.

use std::time::Instant;

use plumbline_adjustment::TiePoint;

use super::{PipelineConfig, Prepared, StageTimings, ties};
use crate::aerial::{AerialReference, MmPatch, PatchPoint, register_patch};
use crate::mm::{MmPoint, Panorama, PanoramaRig, image_motion, match_corners, pair_transform, triangulate};
use crate::output::{CornerCounts, DiscardReason, ImageDiagnostic};

/// Horizontal distance between the DG camera centres of two panoramas, metres.
fn distance(a: &Panorama, b: &Panorama, rig: &PanoramaRig) -> f64 {
    let (ca, cb) = (rig.mount.camera_pose(&a.pose).translation, rig.mount.camera_pose(&b.pose).translation);
    (ca.x() - cb.x()).hypot(ca.y() - cb.y())
}

/// The neighbour of `order[i]`: the next panorama in time if it lies within the pairing distance, else the
/// previous one; the reason when neither does.
pub fn neighbour(
    i: usize,
    order: &[&Panorama],
    rig: &PanoramaRig,
    config: &PipelineConfig,
) -> Result<usize, DiscardReason> {
    let candidates = [i.checked_add(1).filter(|&j| j < order.len()), i.checked_sub(1)];
    let mut nearest: Option<f64> = None;
    for j in candidates.into_iter().flatten() {
        let d = distance(order[i], order[j], rig);
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

/// Everything a pair's processing reads: the tile's panoramas in time order and what was prepared for them.
pub(crate) struct TileInputs<'a> {
    pub order: &'a [&'a Panorama],
    pub prepared: &'a [Prepared],
    pub rig: &'a PanoramaRig,
    pub reference: &'a AerialReference,
    pub config: &'a PipelineConfig,
}

/// Steps 2–8 for panorama `i`: its diagnostic, its ties and the time its stages took.
pub(crate) fn process(i: usize, tile: &TileInputs<'_>) -> (ImageDiagnostic, Vec<TiePoint>, StageTimings) {
    let pano = tile.order[i];
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
        discarded: None,
    };
    let mut timings = StageTimings::default();
    let ties = match run(i, tile, &mut diag, &mut timings) {
        Ok(ties) => ties,
        Err((reason, ties)) => {
            diag.discarded = Some(reason);
            ties
        }
    };
    (diag, ties, timings)
}

type Discard = (DiscardReason, Vec<TiePoint>);

fn run(
    i: usize,
    tile: &TileInputs<'_>,
    diag: &mut ImageDiagnostic,
    timings: &mut StageTimings,
) -> Result<Vec<TiePoint>, Discard> {
    let TileInputs { order, prepared, rig, reference, config } = *tile;
    let (pano, mm) = (order[i], &config.mm);
    let (patch, fa) = prepared[i].patch.as_ref().map_err(|e| (failed("ortho/features", e.to_string()), vec![]))?;
    let j = neighbour(i, order, rig, config).map_err(|r| (r, vec![]))?;
    diag.neighbour = Some(order[j].id.clone());
    let (patch_b, fb) =
        prepared[j].patch.as_ref().map_err(|e| (failed("neighbour ortho/features", e.to_string()), vec![]))?;
    let t0 = Instant::now();
    let transform = pair_transform(patch, fa, patch_b, fb, mm);
    diag.transform = Some(transform.source.clone());
    // paper 001 §4.1: the motion whenever KAZE measured it, also when it disagreed with the DG poses.
    let measure = |fit| image_motion((pano, patch), (order[j], patch_b), fit, rig.camera_height, mm);
    diag.motion = transform.fit.as_ref().and_then(measure);
    let corners = match_corners(patch, patch_b, &transform, &pano.id, mm);
    timings.matching += t0.elapsed();
    let corners = corners.map_err(|e| (failed("corner matching", e.to_string()), vec![]))?;
    let t1 = Instant::now();
    let (points, stats) = triangulate((patch, pano), (patch_b, order[j]), rig, &corners.matches, mm);
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
        let (mm_ties, dropped) = ties::assemble(pano, order[j], &points, &[], config.keep_mm_only_ties);
        diag.dropped_ties = dropped;
        return Err((DiscardReason::TooFewMmPoints { points: points.len(), needed: config.min_mm_points }, mm_ties));
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
    let (ties, dropped) = ties::assemble(pano, order[j], &points, &outcome.points, config.keep_mm_only_ties);
    diag.dropped_ties = dropped;
    diag.aerial_images = outcome.images;
    diag.aerial_points = ties.iter().filter(|t| t.aerial.is_some()).count();
    match outcome.discarded {
        Some(d) => Err((DiscardReason::Aerial(d), ties)),
        None => Ok(ties),
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
