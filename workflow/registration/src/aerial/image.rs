//! Steps 5–7 of paper 000 (§3.6–3.8) for one aerial image: its window, the initial transformation from the
//! MM side prepared for its orientation and the corner matching. The matches of an image with an initial
//! transformation go unfiltered to the patch's common RANSAC (module `joint`).
//!
//! When KAZE and the whole-patch correlation find no plausible initial transformation, the corners are
//! searched over the whole DG bound instead (`AerialConfig::dg_search`) and the image's own RANSAC (ten
//! correspondences, §3.8) becomes its transformation; such an image reads `passed` with `initial_inliers` 0
//! and no `fallback_ncc`; its `offset_m` is that of the RANSAC similarity of the kept matches, which passes
//! the same plausibility check (paper 000 §3.7) as a KAZE transformation.

use nalgebra::Matrix3;
use plumbline_imaging::GrayImage;
use plumbline_imaging::kaze::KazeFeatures;

use super::MmPatch;
use super::config::AerialConfig;
use super::correspond::{PointMatch, match_corners, remove_outliers};
use super::diagnostics::{AerialImageDiagnostic, ImageRejection};
use super::initial::{check_plausibility, initial_transform};
use super::prepare::Prepared;
use super::trace::ImageTrace;
use super::view::{LocalGeometry, View};

/// The MM patch prepared for one aerial orientation (step 5) with its KAZE features (step 6).
#[derive(Clone, Debug)]
pub(super) struct MmSide {
    /// Resampled, rotated, blurred and Wallis-filtered patch.
    pub prepared: Prepared,
    /// Upright KAZE features on valid cells.
    pub features: KazeFeatures,
}

/// One image's contribution: its diagnostic and its matches (point slot, full-image pixel).
pub(super) struct ImageResult {
    /// What happened.
    pub diagnostic: AerialImageDiagnostic,
    /// Point slot and full-image pixel of every kept correspondence.
    pub matches: Vec<(usize, [f64; 2])>,
    /// Every corner's search (empty when no search ran).
    pub trace: ImageTrace,
}

/// Steps 5–7 for one aerial image.
pub(super) fn register_image(
    patch: &MmPatch<'_>,
    side: &Result<MmSide, ImageRejection>,
    view: &View<'_>,
    local: &LocalGeometry,
    config: &AerialConfig,
) -> ImageResult {
    let mut diagnostic = AerialImageDiagnostic {
        frame: view.id().to_string(),
        passed: false,
        rejection: None,
        initial_inliers: 0,
        fallback_ncc: None,
        offset_m: None,
        candidates: 0,
        matched: 0,
        correspondences: 0,
    };
    let fail = |d: &mut AerialImageDiagnostic, r| {
        d.rejection = Some(r);
        let trace = ImageTrace { frame: d.frame.clone(), ..ImageTrace::default() };
        ImageResult { diagnostic: d.clone(), matches: Vec::new(), trace }
    };
    let imaging = |e: plumbline_imaging::ImagingError| ImageRejection::Imaging { message: e.to_string() };
    if let Some(reason) = view.problem() {
        return fail(&mut diagnostic, ImageRejection::InvalidImage { reason });
    }
    let (prepared, mm_features) = match side {
        Ok(side) => (&side.prepared, &side.features),
        Err(r) => return fail(&mut diagnostic, r.clone()),
    };
    // paper 000 §3.7: the aerial patch covers the MM patch plus the DG uncertainty
    let slack = config.plausibility.bound_m(patch.position_sigma) / local.gsd;
    let half = prepared.grid.width / 2 + slack.ceil() as usize + config.search_radius + config.template_half;
    let Some(window) = view.window(local.pixel, half) else {
        return fail(&mut diagnostic, ImageRejection::PatchOutside);
    };
    let aerial = match config.wallis.apply(&window.image) {
        Ok(a) => a,
        Err(e) => return fail(&mut diagnostic, imaging(e)),
    };
    let predicted = [local.pixel[0] - window.origin[0], local.pixel[1] - window.origin[1]];
    let initial = initial_transform(prepared, mm_features, &aerial, predicted, patch.position_sigma, config);
    diagnostic.initial_inliers = initial.inliers;
    diagnostic.offset_m = initial.offset_m;
    diagnostic.fallback_ncc = initial.fallback_ncc;
    let corners: Vec<[f64; 2]> = patch.points.iter().map(|p| prepared.pixel_of_mm(patch.grid, p.pixel)).collect();
    let transform = match initial.transform {
        Ok(t) => t,
        Err(
            why @ (ImageRejection::NoTransform { .. }
            | ImageRejection::FewFeatures { .. }
            | ImageRejection::Implausible { .. }),
        ) if config.dg_search => {
            let aerial = AerialSide { image: &aerial, predicted, origin: window.origin };
            return dg_bounded(prepared, &corners, &aerial, patch.position_sigma, config, diagnostic, why);
        }
        Err(r) => return fail(&mut diagnostic, r),
    };
    diagnostic.passed = true;
    let found = match_corners(prepared, &corners, &aerial, &transform, config.search_radius, config);
    diagnostic.candidates = found.candidates;
    diagnostic.matched = found.matches.len();
    let trace = ImageTrace::of(&diagnostic.frame, config.search_radius, &found.attempts, window.origin);
    // paper 000 §3.8: the outliers are removed over all images of the patch together (module `joint`)
    finish(diagnostic, &found.matches, window.origin, trace)
}

/// The Wallis-filtered aerial window, where the DG georeferencing puts the patch centre in it, and its place
/// in the full image.
struct AerialSide<'a> {
    image: &'a GrayImage,
    predicted: [f64; 2],
    origin: [f64; 2],
}

/// Steps 6–7 without an initial transformation: every corner searched over the whole plausibility bound
/// around its DG transfer (paper 000 §3.1: the DG pose bounds the search), §3.8's RANSAC for the common
/// transformation, which must pass §3.7's plausibility check like a KAZE one. `why` is kept as the rejection
/// when too few corners agree.
fn dg_bounded(
    prepared: &Prepared,
    corners: &[[f64; 2]],
    aerial: &AerialSide<'_>,
    position_sigma: f64,
    config: &AerialConfig,
    mut diagnostic: AerialImageDiagnostic,
    why: ImageRejection,
) -> ImageResult {
    let (gsd, bounds) = (prepared.grid.gsd, &config.plausibility);
    let radius = (bounds.bound_m(position_sigma) / gsd).ceil() as usize;
    let t = dg_transform(prepared, aerial.predicted);
    let found = match_corners(prepared, corners, aerial.image, &t, radius, config);
    diagnostic.candidates = found.candidates;
    diagnostic.matched = found.matches.len();
    let trace = ImageTrace::of(&diagnostic.frame, radius, &found.attempts, aerial.origin);
    let (kept, t) = match remove_outliers(found.matches, config) {
        Ok(k) => k,
        Err(_) => {
            diagnostic.rejection = Some(why);
            return ImageResult { diagnostic, matches: Vec::new(), trace };
        }
    };
    let centre = [prepared.grid.width as f64 / 2.0, prepared.grid.height as f64 / 2.0];
    let check = check_plausibility(&t, centre, aerial.predicted, gsd, position_sigma, bounds);
    diagnostic.offset_m = Some(check.offset_m);
    if !check.passed {
        diagnostic.rejection = Some(check.rejection());
        return ImageResult { diagnostic, matches: Vec::new(), trace };
    }
    diagnostic.passed = true;
    finish(diagnostic, &kept, aerial.origin, trace)
}

/// The image's result from its kept correspondences (window pixels; `origin` = the window's place).
fn finish(
    mut diagnostic: AerialImageDiagnostic,
    kept: &[PointMatch],
    origin: [f64; 2],
    mut trace: ImageTrace,
) -> ImageResult {
    diagnostic.correspondences = kept.len();
    trace.ransac = kept.iter().map(|m| m.slot).collect();
    let matches = kept.iter().map(|m| (m.slot, [m.window[0] + origin[0], m.window[1] + origin[1]])).collect();
    ImageResult { diagnostic, matches, trace }
}

/// The translation the DG georeferencing implies: prepared pixels → window pixels, the patch centre to
/// `predicted` (the prepared patch has the aerial orientation and GSD, paper 000 §3.6).
pub(super) fn dg_transform(prepared: &Prepared, predicted: [f64; 2]) -> Matrix3<f64> {
    let (cu, cv) = (prepared.grid.width as f64 / 2.0, prepared.grid.height as f64 / 2.0);
    Matrix3::new(1.0, 0.0, predicted[0] - cu, 0.0, 1.0, predicted[1] - cv, 0.0, 0.0, 1.0)
}
