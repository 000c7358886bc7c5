//! The driver of steps 5–8 (Jende et al. 2017 §3.6–3.9) for one MM patch: overlapping aerial images, per image the
//! prepared patch, the initial transformation and the corner matching (in parallel), the cross-image
//! consistency, and the triangulation (frames) or the orthophoto + terrain lookup.

use plumbline_geo::angle::wrap;
use rayon::prelude::*;

use super::config::AerialConfig;
use super::correspond::consistent;
use super::diagnostics::{AerialDiscard, AerialImageDiagnostic, ImageRejection};
use super::image::{ImageResult, MmSide, Opened, match_image, open_image};
use super::initial::mm_features;
use super::joint;
use super::points::{ortho_points, single_ray_points, triangulate_points};
use super::pooled::{WindowMatches, pooled_offsets};
use super::prepare::{BlurredPatch, blur_patch, prepare};
use super::trace::ImageTrace;
use super::view::{LocalGeometry, View};
use super::{AerialOutcome, AerialReference, MmPatch};

/// Views whose up directions agree within this (radians) and whose GSDs agree within `SAME_GSD` share one
/// prepared MM patch and its KAZE features (the frames of one strip).
const SAME_HEADING: f64 = 0.01;
/// Relative GSD difference for sharing a prepared MM patch.
const SAME_GSD: f64 = 0.01;

/// Register one MM patch against the aerial reference (Jende et al. 2017 §3.6–3.9). Never fails: an unusable patch
/// or reference is reported in [`AerialOutcome::discarded`], each aerial image's fate in `images`.
pub fn register_patch(patch: &MmPatch<'_>, reference: &AerialReference, config: &AerialConfig) -> AerialOutcome {
    let discard = |results: Vec<ImageResult>, why| {
        let (images, trace) = split(results);
        AerialOutcome { points: Vec::new(), images, discarded: Some(why), trace }
    };
    let height = match validate(patch) {
        Ok(h) => h,
        Err(reason) => return discard(Vec::new(), AerialDiscard::InvalidPatch { reason }),
    };
    let centre = [patch.grid.centre[0], patch.grid.centre[1], height];
    let (views, needed): (Vec<View<'_>>, usize) = match reference {
        AerialReference::Frames(frames) => (frames.iter().map(View::Frame).collect(), config.min_images),
        AerialReference::Orthophoto(o) => (vec![View::Ortho(o)], 1),
    };
    // Jende et al. 2017 §3.7: the recording location projected into the whole block
    let overlapping: Vec<(View<'_>, LocalGeometry)> = views
        .into_iter()
        .filter_map(|v| {
            v.local_geometry(centre).filter(|g| v.contains(g.pixel, config.frame_margin_px)).map(|g| (v, g))
        })
        .collect();
    if overlapping.is_empty() {
        return discard(Vec::new(), AerialDiscard::NoOverlap);
    }
    let gsd = median_gsd(&overlapping);
    let blurred = match blur_patch(patch.image, patch.valid, patch.grid, gsd, config.optics_blur_px) {
        Ok(b) => b,
        Err(e) => return discard(Vec::new(), AerialDiscard::InvalidPatch { reason: e.to_string() }),
    };
    let (group, representatives) = orientation_groups(&overlapping);
    let sides: Vec<Result<MmSide, ImageRejection>> =
        representatives.par_iter().map(|g| mm_side(&blurred, g, config)).collect();
    let opened: Vec<Result<Opened<'_>, Box<ImageResult>>> =
        overlapping.par_iter().zip(&group).map(|((v, g), &k)| open_image(patch, &sides[k], v, g, config)).collect();
    // Jende et al. 2017 §3.7 for all windows together: one DG error (module `pooled`)
    let windows: Vec<WindowMatches<'_>> = opened
        .iter()
        .zip(&group)
        .filter_map(|(o, &k)| {
            let o = o.as_ref().ok()?;
            let (pairs, prior) = o.kaze.as_ref().ok()?;
            Some(WindowMatches { group: k, grid: o.grid(), pairs, prior, area_px: o.match_area(prior, config) })
        })
        .collect();
    let offsets = if config.pool_windows {
        pooled_offsets(&windows, config.initial_threshold_px, config.min_initial_inliers)
    } else {
        Vec::new()
    };
    drop(windows);
    let mut results: Vec<ImageResult> = opened
        .into_par_iter()
        .map(|o| match o {
            Ok(o) => match_image(o, patch, &offsets, config),
            Err(done) => *done,
        })
        .collect();
    // One frame is enough where its points may enter as single rays (`AerialConfig::single_ray_sigma_m`).
    let single_rays = matches!(reference, AerialReference::Frames(_)) && config.single_ray_sigma_m.is_some();
    let needed = if single_rays { 1 } else { needed };
    let passed = results.iter().filter(|r| r.diagnostic.passed).count();
    if passed < needed {
        return discard(results, AerialDiscard::TooFewPlausible { passed, needed });
    }
    let views: Vec<View<'_>> = overlapping.iter().map(|p| p.0).collect();
    // Jende et al. 2017 §3.8: RANSAC over the correspondences of all images (one DG error), then their consistency
    joint::keep_common(&mut results, &views, patch, height, gsd, config);
    if matches!(reference, AerialReference::Frames(_)) {
        enforce_consistency(&mut results, &views, patch, height, gsd, config);
    }
    let (images, correspondences) = settle(&mut results, config.min_correspondences);
    if images < needed || correspondences < config.min_correspondences {
        let why = AerialDiscard::TooFewCorrespondences {
            images,
            needed,
            correspondences,
            needed_correspondences: config.min_correspondences,
        };
        return discard(results, why);
    }
    let points = match (reference, config.single_ray_sigma_m) {
        (AerialReference::Frames(_), Some(along)) if images == 1 => {
            single_ray_points(patch, &results, &views, height, along, config)
        }
        (AerialReference::Frames(_), _) => triangulate_points(patch, &results, &views, height, config),
        (AerialReference::Orthophoto(o), _) => ortho_points(patch, &results, &views[0], o, height, config),
    };
    let discarded = points.is_empty().then_some(AerialDiscard::NoTriangulatedPoints);
    let (images, trace) = split(results);
    AerialOutcome { points, images, discarded, trace }
}

/// The group of every view and each group's local geometry (its first member's).
fn orientation_groups(views: &[(View<'_>, LocalGeometry)]) -> (Vec<usize>, Vec<LocalGeometry>) {
    let mut reps: Vec<LocalGeometry> = Vec::new();
    let group = views
        .iter()
        .map(|(_, g)| {
            let same = |r: &LocalGeometry| {
                wrap(g.up_heading - r.up_heading).abs() < SAME_HEADING && (g.gsd / r.gsd - 1.0).abs() < SAME_GSD
            };
            reps.iter().position(same).unwrap_or_else(|| {
                reps.push(*g);
                reps.len() - 1
            })
        })
        .collect();
    (group, reps)
}

/// Step 5 (and step 6's MM features) for one orientation.
fn mm_side(blurred: &BlurredPatch, local: &LocalGeometry, config: &AerialConfig) -> Result<MmSide, ImageRejection> {
    let imaging = |e: plumbline_imaging::ImagingError| ImageRejection::Imaging { message: e.to_string() };
    let prepared = prepare(blurred, local.up_heading, local.gsd, &config.wallis).map_err(imaging)?;
    let features = mm_features(&prepared, config).map_err(imaging)?;
    Ok(MmSide { prepared, features })
}

/// The patch's ground height under the camera (median of its points' heights less the ground's rise at each),
/// or what is wrong with the patch.
fn validate(patch: &MmPatch<'_>) -> Result<f64, String> {
    let (img, valid, grid) = (patch.image, patch.valid, patch.grid);
    if img.width() != grid.width || img.height() != grid.height {
        return Err(format!(
            "image {}×{} does not match its grid {}×{}",
            img.width(),
            img.height(),
            grid.width,
            grid.height
        ));
    }
    if valid.width() != grid.width || valid.height() != grid.height {
        return Err(format!("valid mask {}×{} does not match the grid", valid.width(), valid.height()));
    }
    if !(patch.position_sigma.is_finite() && patch.position_sigma >= 0.0) {
        return Err(format!("position_sigma = {} must be finite and non-negative", patch.position_sigma));
    }
    if let Some(p) = patch.points.iter().find(|p| !p.map.iter().chain(&p.pixel).chain([&p.rise]).all(|x| x.is_finite()))
    {
        return Err(format!("point {} has non-finite coordinates", p.index));
    }
    let mut heights: Vec<f64> = patch.points.iter().map(|p| p.map[2] - p.rise).collect();
    heights.sort_by(f64::total_cmp);
    heights.get(heights.len() / 2).copied().ok_or_else(|| "no points".to_string())
}

fn median_gsd(views: &[(View<'_>, LocalGeometry)]) -> f64 {
    let mut g: Vec<f64> = views.iter().map(|v| v.1.gsd).collect();
    plumbline_geo::metrics::median(&mut g).unwrap_or(f64::NAN)
}

/// The diagnostics and the traces, the latter with the correspondences each image finally kept.
fn split(results: Vec<ImageResult>) -> (Vec<AerialImageDiagnostic>, Vec<ImageTrace>) {
    results
        .into_iter()
        .map(|mut r| {
            r.trace.kept = r.matches.iter().map(|m| m.0).collect();
            (r.diagnostic, r.trace)
        })
        .unzip()
}

/// Jende et al. 2017 §3.8: drop observations whose ground intersection (at the patch height `height` plus the
/// ground's rise at the point) disagrees with the point's other observations.
fn enforce_consistency(
    results: &mut [ImageResult],
    views: &[View<'_>],
    patch: &MmPatch<'_>,
    height: f64,
    gsd: f64,
    config: &AerialConfig,
) {
    let tolerance = config.consistency_px * gsd;
    let mut dropped: Vec<Vec<bool>> = results.iter().map(|r| vec![false; r.matches.len()]).collect();
    let slots: std::collections::BTreeSet<usize> = results.iter().flat_map(|r| r.matches.iter().map(|m| m.0)).collect();
    for slot in slots {
        let obs: Vec<(usize, usize, [f64; 2])> = results
            .iter()
            .enumerate()
            .flat_map(|(i, r)| r.matches.iter().enumerate().filter(|m| m.1.0 == slot).map(move |(k, m)| (i, k, m.1)))
            .collect();
        let at = height + patch.points[slot].rise;
        let grounds: Vec<[f64; 2]> =
            obs.iter().map(|&(i, _, px)| views[i].ground(px, at).unwrap_or([f64::NAN; 2])).collect();
        for (&(i, k, _), ok) in obs.iter().zip(consistent(&grounds, tolerance)) {
            dropped[i][k] = !ok;
        }
    }
    for (r, dropped) in results.iter_mut().zip(dropped) {
        let mut flags = dropped.into_iter();
        r.matches.retain(|_| !flags.next().unwrap_or(false));
    }
}

/// Each image's count of kept correspondences, and a rejection for a passing image that kept none; the
/// images with correspondences and the correspondences of all images. Fewer than `needed` in all images
/// together (Jende et al. 2017 §3.8: ten) leave every image without.
fn settle(results: &mut [ImageResult], needed: usize) -> (usize, usize) {
    let total: usize = results.iter().map(|r| r.matches.len()).sum();
    if total < needed {
        results.iter_mut().for_each(|r| r.matches.clear());
    }
    for r in results.iter_mut() {
        let found = r.matches.len();
        r.diagnostic.correspondences = found;
        if r.diagnostic.passed && r.diagnostic.rejection.is_none() && found == 0 {
            r.diagnostic.rejection = Some(ImageRejection::TooFewCorrespondences { found, needed: 1 });
        }
    }
    (results.iter().filter(|r| !r.matches.is_empty()).count(), total)
}
