//! Steps 5–7 of paper 000 (§3.6–3.8) for one aerial image: its window, the initial transformation from the
//! MM side prepared for its orientation, the corner matching and the RANSAC outlier removal.

use plumbline_imaging::kaze::KazeFeatures;

use super::MmPatch;
use super::config::AerialConfig;
use super::correspond::{match_corners, remove_outliers};
use super::diagnostics::{AerialImageDiagnostic, ImageRejection};
use super::initial::initial_transform;
use super::prepare::Prepared;
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
        ImageResult { diagnostic: d.clone(), matches: Vec::new() }
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
    let transform = match initial.transform {
        Ok(t) => t,
        Err(r) => return fail(&mut diagnostic, r),
    };
    diagnostic.passed = true;
    let corners: Vec<[f64; 2]> = patch.points.iter().map(|p| prepared.pixel_of_mm(patch.grid, p.pixel)).collect();
    let found = match_corners(prepared, &corners, &aerial, &transform, config);
    diagnostic.candidates = found.candidates;
    diagnostic.matched = found.matches.len();
    match remove_outliers(found.matches, config) {
        Ok(kept) => {
            diagnostic.correspondences = kept.len();
            let o = window.origin;
            let matches = kept.iter().map(|m| (m.slot, [m.window[0] + o[0], m.window[1] + o[1]])).collect();
            ImageResult { diagnostic, matches }
        }
        Err(r) => fail(&mut diagnostic, r),
    }
}
