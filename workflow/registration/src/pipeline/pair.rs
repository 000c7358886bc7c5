//! One owned panorama of the tile: pair it with a neighbour, run steps 2–4 on the pair and steps 5–8 on its
//! patch, and describe what happened.

use std::time::Instant;

use plumbline_adjustment::TiePoint;
use plumbline_geo::MapFromBody;

use super::pairing::neighbour;
use super::{PipelineConfig, PreparedPanorama, StageTimings, ties};
use crate::aerial::{AerialPointResult, AerialReference, ImageTrace, MmPatch, PatchPoint, register_patch};
use crate::mm::{MmPoint, OrthoPatch, PanoramaRig, image_motion, match_corners, pair_transform, triangulate};
use crate::output::{AerialOffset, CornerCounts, DiscardReason, ImageDiagnostic};

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
        motion_contradicted: false,
        corners: CornerCounts::default(),
        aerial_images: Vec::new(),
        aerial_points: 0,
        dropped_ties: 0,
        aerial_frames: Vec::new(),
        aerial_offset: None,
        cross_check: None,
        discarded: None,
        strokes: tile.order[i].strokes.clone(),
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
    // Cazzaniga et al. 2007 §4.1: the motion whenever KAZE measured it, also when it disagreed with the DG poses.
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
    let points_for_aerial = patch_points(&points, patch);
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
    diag.aerial_offset = aerial_offset(patch, &points, &outcome.points, config.cross_check.point_std_m);
    match outcome.discarded {
        Some(d) => Err((DiscardReason::Aerial(d), ties)),
        None => Ok(ties),
    }
}

/// The patch and features of a prepared panorama; a failed or missing preparation as a discard of `step`.
fn prepared<'a>(
    p: &'a PreparedPanorama,
    step: &str,
) -> Result<&'a (OrthoPatch, plumbline_imaging::kaze::KazeFeatures), Discard> {
    match &p.patch {
        Some(Ok(prepared)) => Ok(prepared),
        Some(Err(e)) => Err((failed(step, e.to_string()), vec![])),
        None => Err((failed(step, format!("panorama {} was not prepared", p.pano.id)), vec![])),
    }
}

fn patch_points(points: &[MmPoint], patch: &OrthoPatch) -> Vec<PatchPoint> {
    points
        .iter()
        .enumerate()
        .map(|(index, p)| {
            let [e, n] = patch.grid.to_map(p.corner.a[0], p.corner.a[1]);
            PatchPoint {
                index,
                pixel: p.corner.a,
                map: [p.position.x(), p.position.y(), p.position.z()],
                rise: patch.height_at(e, n) - patch.plane_height,
            }
        })
        .collect()
}

/// The panorama's aerial offset (Jende et al. 2017 §3.9): the median of (aerial − MM) east and north over its
/// aerial points, σ = max(1.4826 · MAD, `point_std`) / √n per axis (a MAD of two or three points means
/// little), at least the points' median own σ (they share frames and blur, so their errors do not all
/// average out). The MM position is where A's DG ortho-image shows the point (its corner on the ortho
/// plane, §3.2): it carries A's DG error alone. The two-ray intersection (§3.5) would mix in B's DG error
/// and its depth error along the rays (a few points of a district panorama put it 0.3 m off with the
/// aerial points correct); flat ground is assumed, as the ortho-images themselves assume it.
fn aerial_offset(
    patch: &OrthoPatch,
    points: &[MmPoint],
    aerial: &[AerialPointResult],
    point_std: f64,
) -> Option<AerialOffset> {
    let (differences, own): (Vec<[f64; 2]>, Vec<[f64; 2]>) = aerial
        .iter()
        .filter_map(|r| {
            let [u, v] = points.get(r.index)?.corner.a;
            let p = patch.ground_point(u, v);
            let own = [0, 1].map(|c| r.covariance[c][c].max(0.0).sqrt());
            Some(([r.position[0] - p.x(), r.position[1] - p.y()], own))
        })
        .unzip();
    offset_of(&differences, &own, point_std)
}

/// [`aerial_offset`] of the differences (aerial − MM, east and north), the points' own σ and the prior σ of
/// one point.
pub(super) fn offset_of(differences: &[[f64; 2]], own: &[[f64; 2]], point_std: f64) -> Option<AerialOffset> {
    let n = differences.len();
    let axis = |c: usize| {
        let d: Vec<f64> = differences.iter().map(|v| v[c]).collect();
        let m = median(d.clone());
        let mad = median(d.iter().map(|v| (v - m).abs()).collect());
        let spread = (1.4826 * mad).max(point_std) / (n as f64).sqrt();
        (m, spread.max(median(own.iter().map(|s| s[c]).collect())))
    };
    let ((east, se), (north, sn)) = (axis(0), axis(1));
    let finite = n > 0 && [east, se, north, sn].iter().all(|v| v.is_finite());
    finite.then_some(AerialOffset { offset: [east, north], std: [se, sn], points: n })
}

/// The median of a list (`plumbline_geo::metrics::median`); NaN when empty.
fn median(mut v: Vec<f64>) -> f64 {
    plumbline_geo::metrics::median(&mut v).unwrap_or(f64::NAN)
}
