//! Steps 5–7 of Jende et al. 2017 (§3.6–3.8) for one aerial image: its window, the initial transformation from the
//! MM side prepared for its orientation and the corner matching. The matches of an image with an initial
//! transformation go unfiltered to the patch's common RANSAC (module `joint`).
//!
//! When KAZE finds two plausible translations (a repeated marking matched one period off), the one under
//! which more corners match is taken.
//!
//! When KAZE and the whole-patch correlation find no plausible initial transformation, the
//! corners are searched over the whole DG bound instead (`AerialConfig::dg_search`) and the image's own
//! RANSAC (ten correspondences, §3.8) becomes its transformation; such an image reads `passed` with
//! `initial_inliers` 0 and no `fallback_ncc`; its `offset_m` is that of the RANSAC similarity of the kept
//! matches, which passes the same plausibility check (Jende et al. 2017 §3.7) as a KAZE transformation.

use nalgebra::Matrix3;
use plumbline_imaging::GrayImage;
use plumbline_imaging::kaze::KazeFeatures;

use super::MmPatch;
use super::config::AerialConfig;
use super::correspond::{CornerMatches, PointMatch, match_corners, remove_outliers};
use super::diagnostics::{AerialImageDiagnostic, ImageRejection};
use super::initial::{KazePairs, check_plausibility, initial_transform, kaze_pairs, match_area};
use super::pooled::translation_for;
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

/// One aerial image after step 6's KAZE matching, before its initial transformation is decided (the
/// windows of a patch pool their matches first, module `pooled`).
pub(super) struct Opened<'a> {
    diagnostic: AerialImageDiagnostic,
    /// The MM side prepared for this image's orientation.
    side: &'a MmSide,
    /// The Wallis-filtered aerial window and its place in the full image.
    aerial: GrayImage,
    origin: [f64; 2],
    /// Where the DG georeferencing puts the patch centre in the window.
    predicted: [f64; 2],
    /// The window's KAZE matches.
    pub kaze: KazePairs,
}

impl Opened<'_> {
    /// The prepared MM patch's grid.
    pub fn grid(&self) -> &plumbline_imaging::ortho::GroundGrid {
        &self.side.prepared.grid
    }

    /// Area over which a false KAZE match's displacement scatters, px².
    pub fn match_area(&self, prior: &super::guided::Prior, config: &AerialConfig) -> f64 {
        match_area(prior, &self.aerial, config)
    }
}

/// Steps 5–6 for one aerial image up to its KAZE matches; an image that fails before has its result (boxed).
pub(super) fn open_image<'a>(
    patch: &MmPatch<'_>,
    side: &'a Result<MmSide, ImageRejection>,
    view: &View<'_>,
    local: &LocalGeometry,
    config: &AerialConfig,
) -> Result<Opened<'a>, Box<ImageResult>> {
    let diagnostic = AerialImageDiagnostic {
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
    let fail = |mut d: AerialImageDiagnostic, r| {
        d.rejection = Some(r);
        let trace = ImageTrace { frame: d.frame.clone(), ..ImageTrace::default() };
        Box::new(ImageResult { diagnostic: d, matches: Vec::new(), trace })
    };
    let imaging = |e: plumbline_imaging::ImagingError| ImageRejection::Imaging { message: e.to_string() };
    if let Some(reason) = view.problem() {
        return Err(fail(diagnostic, ImageRejection::InvalidImage { reason }));
    }
    let side = match side {
        Ok(side) => side,
        Err(r) => return Err(fail(diagnostic, r.clone())),
    };
    let prepared = &side.prepared;
    // Jende et al. 2017 §3.7: the aerial patch covers the MM patch plus the DG uncertainty
    let slack = config.plausibility.bound_m(patch.position_sigma) / local.gsd;
    let half = prepared.grid.width / 2 + slack.ceil() as usize + config.search_radius + config.template_half;
    let Some(window) = view.window(local.pixel, half) else {
        return Err(fail(diagnostic, ImageRejection::PatchOutside));
    };
    let aerial = match config.wallis.apply(&window.image) {
        Ok(a) => a,
        Err(e) => return Err(fail(diagnostic, imaging(e))),
    };
    let predicted = [local.pixel[0] - window.origin[0], local.pixel[1] - window.origin[1]];
    let kaze = kaze_pairs(prepared, &side.features, &aerial, predicted, patch.position_sigma, config);
    Ok(Opened { diagnostic, side, aerial, origin: window.origin, predicted, kaze })
}

/// Steps 6–7 for an opened image: its initial transformation (its own KAZE consensus, the patch's pooled
/// `offsets` (E, N metres from the DG georeferencing), the correlation fallback or the DG-bounded search)
/// and the corner matching.
pub(super) fn match_image(
    opened: Opened<'_>,
    patch: &MmPatch<'_>,
    offsets: &[[f64; 2]],
    config: &AerialConfig,
) -> ImageResult {
    let Opened { mut diagnostic, side, aerial, origin, predicted, kaze } = opened;
    let prepared = &side.prepared;
    let pooled: Vec<Matrix3<f64>> = match &kaze {
        Ok((_, prior)) => offsets.iter().map(|&o| translation_for(&prepared.grid, prior, o)).collect(),
        Err(_) => Vec::new(),
    };
    let corners: Vec<[f64; 2]> = patch.points.iter().map(|p| prepared.pixel_of_mm(patch.grid, p.pixel)).collect();
    let initial = initial_transform(prepared, &kaze, &aerial, predicted, patch.position_sigma, &pooled, config);
    diagnostic.initial_inliers = initial.inliers;
    diagnostic.offset_m = initial.offset_m;
    diagnostic.fallback_ncc = initial.fallback_ncc;
    let transform = match initial.transform {
        Ok(t) => t,
        Err(
            why @ (ImageRejection::NoTransform { .. }
            | ImageRejection::FewFeatures { .. }
            | ImageRejection::Implausible { .. }),
        ) if config.dg_search => {
            let aerial = AerialSide { image: &aerial, predicted, origin };
            return dg_bounded(prepared, &corners, &aerial, patch.position_sigma, config, diagnostic, why);
        }
        Err(r) => {
            diagnostic.rejection = Some(r);
            let trace = ImageTrace { frame: diagnostic.frame.clone(), ..ImageTrace::default() };
            return ImageResult { diagnostic, matches: Vec::new(), trace };
        }
    };
    diagnostic.passed = true;
    let candidates: Vec<Matrix3<f64>> = std::iter::once(transform).chain(initial.alternatives).collect();
    let (chosen, found) = choose(prepared, &corners, &aerial, &candidates, config);
    if chosen > 0 {
        let centre = [prepared.grid.width as f64 / 2.0, prepared.grid.height as f64 / 2.0];
        let (gsd, bounds) = (prepared.grid.gsd, &config.plausibility);
        let check = check_plausibility(&candidates[chosen], centre, predicted, gsd, patch.position_sigma, bounds);
        diagnostic.offset_m = Some(check.offset_m);
    }
    diagnostic.candidates = found.candidates;
    diagnostic.matched = found.matches.len();
    let trace = ImageTrace::of(&diagnostic.frame, config.search_radius, &found.attempts, origin);
    // Jende et al. 2017 §3.8: the outliers are removed over all images of the patch together (module `joint`)
    finish(diagnostic, &found.matches, origin, trace)
}

/// The initial transformation under which most corners match (Jende et al. 2017 §3.8's NCC and LSM in a small
/// window), with its matches: a repeated marking matched one period off by KAZE agrees with the dashes but
/// not with the rest of the patch. Ties keep the earlier candidate (the larger KAZE consensus).
fn choose(
    prepared: &Prepared,
    corners: &[[f64; 2]],
    aerial: &GrayImage,
    candidates: &[Matrix3<f64>],
    config: &AerialConfig,
) -> (usize, CornerMatches) {
    let mut best = (0, CornerMatches::default());
    for (k, t) in candidates.iter().enumerate() {
        let found = match_corners(prepared, corners, aerial, t, config.search_radius, config);
        if k == 0 || found.matches.len() > best.1.matches.len() {
            best = (k, found);
        }
    }
    best
}

/// The Wallis-filtered aerial window, where the DG georeferencing puts the patch centre in it, and its place
/// in the full image.
struct AerialSide<'a> {
    image: &'a GrayImage,
    predicted: [f64; 2],
    origin: [f64; 2],
}

/// Steps 6–7 without an initial transformation: every corner searched over the whole plausibility bound
/// around its DG transfer (Jende et al. 2017 §3.1: the DG pose bounds the search), §3.8's RANSAC for the common
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
/// `predicted` (the prepared patch has the aerial orientation and GSD, Jende et al. 2017 §3.6).
pub(super) fn dg_transform(prepared: &Prepared, predicted: [f64; 2]) -> Matrix3<f64> {
    let (cu, cv) = (prepared.grid.width as f64 / 2.0, prepared.grid.height as f64 / 2.0);
    Matrix3::new(1.0, 0.0, predicted[0] - cu, 0.0, 1.0, predicted[1] - cv, 0.0, 0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use plumbline_imaging::Mask;
    use plumbline_imaging::ortho::GroundGrid;

    use super::*;

    /// A street patch at the aerial GSD: dashes repeating every `PERIOD` pixels along u, and one corner-rich
    /// marking (an arrow's head: two bars meeting at a right angle) that occurs once.
    const PERIOD: f64 = 13.0;

    fn paint(u: f64, v: f64) -> f32 {
        let dash = (40.0..43.0).contains(&v) && u.rem_euclid(PERIOD) < 6.0;
        let stem = (70.0..73.0).contains(&u) && (62.0..75.0).contains(&v);
        let bar = (62.0..65.0).contains(&v) && (70.0..83.0).contains(&u);
        if dash || stem || bar { 200.0 } else { 60.0 }
    }

    fn translation(t: [f64; 2]) -> Matrix3<f64> {
        Matrix3::new(1.0, 0.0, t[0], 0.0, 1.0, t[1], 0.0, 0.0, 1.0)
    }

    #[test]
    fn the_translation_under_which_more_corners_match_is_chosen_whichever_kaze_ranked_first() {
        let (w, h) = (110, 100);
        let image = GrayImage::from_fn(w, h, |c, r| paint(c as f64, r as f64));
        let grid = GroundGrid::new([0.0, 0.0], 0.12, w, h, 0.0).expect("grid");
        let prepared = Prepared { image, valid: Mask::from_fn(w, h, |_, _| true), grid };
        // The aerial window shows the same street moved by the true translation.
        let truth = [21.0, 17.0];
        let window = GrayImage::from_fn(160, 150, |c, r| paint(c as f64 - truth[0], r as f64 - truth[1]));
        // Corners: both ends of every dash and the arrow's corners.
        let mut corners: Vec<[f64; 2]> = (1..8)
            .flat_map(|k| {
                let u = k as f64 * PERIOD;
                [[u, 40.0], [u + 6.0, 43.0]]
            })
            .collect();
        corners.extend([[70.0, 62.0], [83.0, 65.0], [73.0, 75.0], [73.0, 65.0]]);
        let config = AerialConfig::default();
        let right = translation(truth);
        let wrong = translation([truth[0] + PERIOD, truth[1]]);
        let (k, found) = choose(&prepared, &corners, &window, &[wrong, right], &config);
        assert_eq!(k, 1, "the true translation, offered second, is chosen");
        let (k2, found2) = choose(&prepared, &corners, &window, &[right, wrong], &config);
        assert_eq!(k2, 0);
        assert_eq!(found.matches.len(), found2.matches.len());
        // Under the true translation the arrow's corners match where they are.
        let arrow = found.matches.iter().filter(|m| m.prepared[1] > 60.0).count();
        assert!(arrow >= 3, "{arrow} arrow corners matched");
        for m in &found.matches {
            let d = (m.window[0] - m.prepared[0] - truth[0]).hypot(m.window[1] - m.prepared[1] - truth[1]);
            assert!(d < 0.5, "corner {:?} matched {d} px off", m.prepared);
        }
        // Under the wrong one, only dashes (one period off) match.
        let off = choose(&prepared, &corners, &window, &[wrong], &config).1;
        assert!(off.matches.len() < found.matches.len() && off.matches.iter().all(|m| m.prepared[1] < 50.0));
    }
}
