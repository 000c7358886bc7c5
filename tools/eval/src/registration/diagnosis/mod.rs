//! Why panoramas fail to match: matched share split by whether road markings lie around the
//! panorama (ground truth), failure reasons per group, and what happened in each aerial image of the
//! panoramas with markings that failed the initial transformation (Jende et al. 2017 §3.7). Part of
//! `plumbline-eval registration` (`cargo run --release -p plumbline-eval -- registration`).

pub mod crosscheck;
/// The wrong aerial points explained (shared with the `tiny` test, which prints the same).
pub use plumbline_fixtures::registration::wrong;

use std::collections::BTreeMap;

use plumbline_registration::TileResultV1;
use plumbline_registration::aerial::{AerialImageDiagnostic, ImageRejection};

/// A panorama "has markings" when at least this much paint (m², both epochs) lies in its ortho patch:
/// about three lane-line dashes (3 m × 0.12 m each) — enough for the corners the matching needs.
pub const MARKINGS_MIN_M2: f64 = 1.0;
/// An implausible transformation whose offset is within this of the panorama's true DG error (m) is the
/// correct one: AT errors are 3 cm / 3″ (≈ 2 cm on the ground), matching errors a fraction of 12 cm.
const SAME_OFFSET_M: f64 = 0.25;

/// Images and matches of one group of panoramas.
#[derive(Default)]
pub struct Group {
    pub images: usize,
    pub matched: usize,
    pub reasons: BTreeMap<String, usize>,
}

/// Corner candidates, NCC matches and correspondences kept in one aerial image (Jende et al. 2017 §3.8).
pub type Counts = (usize, usize, usize);

/// What happened in the aerial images of the panoramas with markings discarded as too_few_plausible.
#[derive(Default)]
pub struct Causes {
    /// Panoramas diagnosed.
    pub panoramas: usize,
    /// Per aerial image, by cause.
    pub images: BTreeMap<&'static str, usize>,
    /// (offset, bound, true DG error) of implausible-but-correct transformations, metres.
    pub too_tight: Vec<(f64, f64, f64)>,
    /// (KAZE matches, best inliers, correlation NCC) of the images where no transformation was found.
    pub none_found: Vec<(usize, usize, Option<f64>)>,
    /// Panoramas with markings discarded as too_few_correspondences: MM points triangulated and, per
    /// passing aerial image, (corner candidates, NCC matches, correspondences kept).
    pub starved: Vec<(usize, Vec<Counts>)>,
}

/// Both groups and the causes, from a tile result, the paint area and true DG error per panorama id.
pub struct Split {
    pub with: Group,
    pub without: Group,
    pub causes: Causes,
}

/// The cause of one aerial image's failure (or success) in the initial transformation.
fn cause(d: &AerialImageDiagnostic, dg_error: f64) -> &'static str {
    match &d.rejection {
        _ if d.passed => "passed §3.7",
        Some(ImageRejection::FewFeatures { .. }) => "(a) too few KAZE features",
        Some(ImageRejection::NoTransform { .. }) => "(a) no KAZE transform, no correlation",
        Some(ImageRejection::Implausible { offset_m, bound_m, .. }) if offset_m <= bound_m => {
            "(b') rotation/scale out of bounds"
        }
        Some(ImageRejection::Implausible { offset_m, .. }) if (offset_m - dg_error).abs() <= SAME_OFFSET_M => {
            if d.fallback_ncc.is_some() {
                "(b) correct correlation, bound too tight"
            } else {
                "(b) correct KAZE, bound too tight"
            }
        }
        Some(ImageRejection::Implausible { .. }) => {
            if d.fallback_ncc.is_some() {
                "(c) wrong correlation rejected"
            } else {
                "(c) wrong KAZE rejected"
            }
        }
        Some(ImageRejection::PatchOutside) => "aerial patch outside the frame",
        Some(_) => "other",
        None => "none",
    }
}

impl Split {
    /// Split `result`'s panoramas by paint area (`paint` and `dg_error` keyed by panorama id).
    pub fn of(result: &TileResultV1, paint: &BTreeMap<String, f64>, dg_error: &BTreeMap<String, f64>) -> Split {
        let (mut with, mut without, mut causes) = (Group::default(), Group::default(), Causes::default());
        for d in &result.images {
            let marked = paint.get(&d.image).is_some_and(|&a| a >= MARKINGS_MIN_M2);
            let group = if marked { &mut with } else { &mut without };
            group.images += 1;
            let Some(reason) = &d.discarded else {
                group.matched += 1;
                continue;
            };
            *group.reasons.entry(reason.key()).or_insert(0) += 1;
            if marked && reason.key() == "aerial.too_few_correspondences" {
                let images = d.aerial_images.iter().filter(|a| a.passed);
                let counts = images.map(|a| (a.candidates, a.matched, a.correspondences)).collect();
                causes.starved.push((d.corners.triangulated, counts));
            }
            if marked && reason.key() == "aerial.too_few_plausible" {
                let err = dg_error.get(&d.image).copied().unwrap_or(f64::NAN);
                causes.panoramas += 1;
                for a in &d.aerial_images {
                    let c = cause(a, err);
                    *causes.images.entry(c).or_insert(0) += 1;
                    if let (true, Some(ImageRejection::Implausible { offset_m, bound_m, .. })) =
                        (c.starts_with("(b)"), &a.rejection)
                    {
                        causes.too_tight.push((*offset_m, *bound_m, err));
                    }
                    if let Some(ImageRejection::NoTransform { matches, inliers }) = &a.rejection {
                        causes.none_found.push((*matches, *inliers, a.fallback_ncc));
                    }
                }
            }
        }
        Split { with, without, causes }
    }
}
