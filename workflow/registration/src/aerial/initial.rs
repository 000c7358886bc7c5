//! Step 6 of paper 000 (§3.7): the initial transformation between the prepared MM patch and one aerial
//! patch by upright KAZE features and a RANSAC similarity, and its plausibility check against the DG
//! georeferencing (only the translation's size and a near-identity rotation and scale can be tested, since
//! the MM pose is what is being corrected).

use nalgebra::Matrix3;
use plumbline_imaging::kaze::{KazeFeatures, kaze, match_surf};
use plumbline_imaging::models::{Correspondence, Model};
use plumbline_imaging::ransac::ransac;
use plumbline_imaging::{GrayImage, ImagingError};

use super::config::{AerialConfig, Plausibility};
use super::correlate::correlate;
use super::diagnostics::ImageRejection;
use super::guided::{Prior, guided_matches};
use super::prepare::Prepared;

/// Pixels added to the plausibility bound for the guided matching's search radius (keypoint localisation).
const GUIDE_SLACK_PX: f64 = 3.0;

/// The outcome of a plausibility check on an initial transformation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlausibilityCheck {
    /// Ground distance between where the transformation and where the DG georeferencing put the patch
    /// centre, metres.
    pub offset_m: f64,
    /// The largest offset accepted, metres.
    pub bound_m: f64,
    /// Rotation of the transformation, radians (the prepared patch is already oriented like the aerial one).
    pub rotation: f64,
    /// Scale of the transformation (1 expected: both patches are at the same GSD).
    pub scale: f64,
    /// All three within their bounds.
    pub passed: bool,
}

/// Check a similarity `transform` (prepared MM pixels → aerial pixels, both at `gsd` metres per pixel):
/// it moves the patch centre `centre` to a point that must lie within `bounds.bound_m(position_sigma)` of
/// `predicted`, the aerial pixel the DG georeferencing projects the centre to (paper 000 §3.7).
pub fn check_plausibility(
    transform: &Matrix3<f64>,
    centre: [f64; 2],
    predicted: [f64; 2],
    gsd: f64,
    position_sigma: f64,
    bounds: &Plausibility,
) -> PlausibilityCheck {
    let t = transform;
    let u = t[(0, 0)] * centre[0] + t[(0, 1)] * centre[1] + t[(0, 2)];
    let v = t[(1, 0)] * centre[0] + t[(1, 1)] * centre[1] + t[(1, 2)];
    let offset_m = (u - predicted[0]).hypot(v - predicted[1]) * gsd; // paper 000 §3.7: translation threshold
    let rotation = t[(1, 0)].atan2(t[(0, 0)]);
    let scale = t[(1, 0)].hypot(t[(0, 0)]);
    let bound_m = bounds.bound_m(position_sigma);
    let passed = offset_m.is_finite()
        && offset_m <= bound_m
        && rotation.abs() <= bounds.max_rotation
        && (scale - 1.0).abs() <= bounds.max_scale_error;
    PlausibilityCheck { offset_m, bound_m, rotation, scale, passed }
}

impl PlausibilityCheck {
    /// The rejection of a transformation that failed this check.
    pub(crate) fn rejection(&self) -> ImageRejection {
        ImageRejection::Implausible {
            offset_m: self.offset_m,
            bound_m: self.bound_m,
            rotation_deg: self.rotation.to_degrees(),
            scale: self.scale,
        }
    }
}

/// An initial transformation that passed, or why there is none; with the KAZE inliers and the offset.
#[derive(Clone, Debug)]
pub(crate) struct Initial {
    /// Prepared MM pixels → aerial window pixels, when found and plausible.
    pub transform: Result<Matrix3<f64>, ImageRejection>,
    /// KAZE inliers of the best transformation.
    pub inliers: usize,
    /// NCC of the correlation fallback, when it was used.
    pub fallback_ncc: Option<f64>,
    /// Ground offset of the best transformation, metres.
    pub offset_m: Option<f64>,
}

/// KAZE on both Wallis-filtered patches, descriptor matching (guided by the DG georeferencing: pairs within
/// the plausibility bound, module `guided`), RANSAC similarity (or, failing that, the
/// whole-patch correlation), then the plausibility check. `predicted` is the aerial-window pixel of the
/// patch centre under the DG georeferencing.
pub(crate) fn initial_transform(
    prepared: &Prepared,
    mm: &KazeFeatures,
    window: &GrayImage,
    predicted: [f64; 2],
    position_sigma: f64,
    config: &AerialConfig,
) -> Initial {
    let judge = |t: Matrix3<f64>, inliers, fallback_ncc| {
        let centre = [prepared.grid.width as f64 / 2.0, prepared.grid.height as f64 / 2.0];
        let (gsd, bounds) = (prepared.grid.gsd, &config.plausibility);
        let check = check_plausibility(&t, centre, predicted, gsd, position_sigma, bounds);
        let transform = if check.passed { Ok(t) } else { Err(check.rejection()) };
        Initial { transform, inliers, fallback_ncc, offset_m: Some(check.offset_m) }
    };
    let shift = [predicted[0] - prepared.grid.width as f64 / 2.0, predicted[1] - prepared.grid.height as f64 / 2.0];
    // paper 000 §3.1: the DG pose constrains the search; a keypoint's own localisation adds a few pixels
    let radius = config.plausibility.bound_m(position_sigma) / prepared.grid.gsd + GUIDE_SLACK_PX;
    let failure = match kaze_transform(mm, window, &Prior { shift, radius }, config) {
        Ok((t, inliers)) => return judge(t, inliers, None),
        Err(failure) => failure,
    };
    let radius = config.plausibility.bound_m(position_sigma) / prepared.grid.gsd;
    let fallback = config
        .correlation_fallback
        .then(|| correlate(prepared, window, predicted, radius, config.min_correlation_margin))
        .flatten();
    match fallback.filter(|f| f.1 >= config.min_correlation) {
        Some((t, score)) => judge(t, 0, Some(score)),
        None => {
            let inliers = if let ImageRejection::NoTransform { inliers, .. } = failure { inliers } else { 0 };
            Initial { transform: Err(failure), inliers, fallback_ncc: fallback.map(|f| f.1), offset_m: None }
        }
    }
}

/// KAZE features of the aerial window matched with the MM ones and a RANSAC similarity with its inliers.
fn kaze_transform(
    mm: &KazeFeatures,
    window: &GrayImage,
    prior: &Prior,
    config: &AerialConfig,
) -> Result<(Matrix3<f64>, usize), ImageRejection> {
    let aerial = kaze(window, &config.kaze).map_err(|e| ImageRejection::Imaging { message: e.to_string() })?;
    let (n_mm, n_aerial) = (mm.keypoints.len(), aerial.keypoints.len());
    if n_mm < config.min_initial_inliers || n_aerial < config.min_initial_inliers {
        return Err(ImageRejection::FewFeatures { mm: n_mm, aerial: n_aerial });
    }
    let pairs: Vec<Correspondence> = if config.guided_matching {
        guided_matches(mm, &aerial, prior, config.match_ratio)
    } else {
        match_surf(&mm.descriptors, &aerial.descriptors, config.match_ratio, true)
            .into_iter()
            .map(|(i, j, _)| {
                let (a, b) = (&mm.keypoints[i], &aerial.keypoints[j]);
                Correspondence { a: [a.u, a.v], b: [b.u, b.v] }
            })
            .collect()
    };
    let no_transform = |inliers| ImageRejection::NoTransform { matches: pairs.len(), inliers };
    let fit = ransac(Model::Similarity, &pairs, &config.initial_ransac).map_err(|_| no_transform(0))?;
    let inliers = fit.inlier_count();
    if inliers < config.min_initial_inliers { Err(no_transform(inliers)) } else { Ok((fit.transform, inliers)) }
}

/// Upright KAZE features of the prepared MM patch whose surroundings have MM samples (no rotated-away
/// corners, no vehicle).
pub(crate) fn mm_features(prepared: &Prepared, config: &AerialConfig) -> Result<KazeFeatures, ImagingError> {
    let f = kaze(&prepared.image, &config.kaze)?;
    let (keypoints, descriptors) =
        f.keypoints.into_iter().zip(f.descriptors).filter(|(k, _)| prepared.valid_around([k.u, k.v], 2)).unzip();
    Ok(KazeFeatures { keypoints, descriptors })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A similarity of rotation `angle`, scale `s` about (50, 50), then translated by `d`.
    fn similarity(angle: f64, s: f64, d: [f64; 2]) -> Matrix3<f64> {
        let (sn, cs) = angle.sin_cos();
        let (a, b) = (s * cs, s * sn);
        Matrix3::new(a, -b, 50.0 - a * 50.0 + b * 50.0 + d[0], b, a, 50.0 - b * 50.0 - a * 50.0 + d[1], 0.0, 0.0, 1.0)
    }

    #[test]
    fn plausibility_rejects_a_large_translation_and_passes_a_small_one() {
        let bounds = Plausibility::default();
        // DG σ 1 m → bound 3 · 1 + 0.5 = 3.5 m = 29.2 px at 12 cm. The DG georeferencing predicts the centre
        // (50, 50) at (60, 40) in the aerial patch.
        let check =
            |d: [f64; 2]| check_plausibility(&similarity(0.0, 1.0, d), [50.0, 50.0], [60.0, 40.0], 0.12, 1.0, &bounds);
        let small = check([10.0 + 12.0, -10.0 + 16.0]); // 20 px = 2.4 m from the prediction
        assert!(small.passed && (small.offset_m - 2.4).abs() < 1e-9, "{small:?}");
        let large = check([10.0 + 30.0, -10.0 - 18.0]); // 35 px·… = 4.2 m
        assert!(!large.passed && (large.offset_m - 34.985_711_369_071_8 * 0.12).abs() < 1e-6, "{large:?}");
        // The same translation passes with a larger DG σ (2 m → 6.5 m bound).
        let loose =
            check_plausibility(&similarity(0.0, 1.0, [40.0, -28.0]), [50.0, 50.0], [60.0, 40.0], 0.12, 2.0, &bounds);
        assert!(loose.passed, "{loose:?}");
        // A reported σ of 2.5 cm (blind to multipath) is raised to the 0.5 m floor: bound 2.0 m, so a 1.4 m
        // DG error passes and a 2.2 m offset does not.
        let floor = |d: [f64; 2]| {
            check_plausibility(&similarity(0.0, 1.0, d), [50.0, 50.0], [60.0, 40.0], 0.12, 0.025, &bounds)
        };
        let jump = floor([10.0, -10.0 + 1.4 / 0.12]);
        assert!(jump.passed && (jump.bound_m - 2.0).abs() < 1e-12, "{jump:?}");
        assert!(!floor([10.0, -10.0 + 2.2 / 0.12]).passed);
        // Rotation and scale far from identity fail even with no offset.
        let turned =
            check_plausibility(&similarity(0.2, 1.0, [10.0, -10.0]), [50.0, 50.0], [60.0, 40.0], 0.12, 1.0, &bounds);
        assert!(!turned.passed && turned.offset_m < 1e-9 && (turned.rotation - 0.2).abs() < 1e-12);
        let scaled =
            check_plausibility(&similarity(0.0, 1.1, [10.0, -10.0]), [50.0, 50.0], [60.0, 40.0], 0.12, 1.0, &bounds);
        assert!(!scaled.passed && (scaled.scale - 1.1).abs() < 1e-12);
    }
}
