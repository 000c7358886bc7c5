//! Step 6 of Jende et al. 2017 (§3.7): the initial transformation between the prepared MM patch and one aerial
//! patch — a translation, since §3.6 gave the patch the aerial orientation and GSD — by upright KAZE
//! features and their consensus, and its plausibility check against the DG georeferencing (only the
//! translation's size and a near-identity rotation and scale can be tested, since the MM pose is what is
//! being corrected).

use nalgebra::Matrix3;
use plumbline_imaging::kaze::{KazeFeatures, kaze, match_surf};
use plumbline_imaging::models::Correspondence;
use plumbline_imaging::{GrayImage, ImagingError};

use super::config::{AerialConfig, Plausibility};
use super::consensus::{GroundPair, common_translation, significant_inliers};
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
/// `predicted`, the aerial pixel the DG georeferencing projects the centre to (Jende et al. 2017 §3.7).
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
    let offset_m = (u - predicted[0]).hypot(v - predicted[1]) * gsd; // Jende et al. 2017 §3.7: translation threshold
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
    /// Further plausible transformations: a second significant KAZE consensus (a repeated marking matched
    /// one period off gives one), for the corner matching to decide between.
    pub alternatives: Vec<Matrix3<f64>>,
}

/// The guided KAZE matches of one aerial window (prepared MM pixels → window pixels) and the DG prior they
/// were drawn under, or why there are none.
pub(crate) type KazePairs = Result<(Vec<Correspondence>, Prior), ImageRejection>;

/// KAZE on the Wallis-filtered aerial window and descriptor matching with the MM features, guided by the DG
/// georeferencing (pairs within the plausibility bound, module `guided`). `predicted` is the aerial-window
/// pixel of the patch centre under the DG georeferencing.
pub(crate) fn kaze_pairs(
    prepared: &Prepared,
    mm: &KazeFeatures,
    window: &GrayImage,
    predicted: [f64; 2],
    position_sigma: f64,
    config: &AerialConfig,
) -> KazePairs {
    let shift = [predicted[0] - prepared.grid.width as f64 / 2.0, predicted[1] - prepared.grid.height as f64 / 2.0];
    // Jende et al. 2017 §3.1: the DG pose constrains the search; a keypoint's own localisation adds a few pixels
    let radius = config.plausibility.bound_m(position_sigma) / prepared.grid.gsd + GUIDE_SLACK_PX;
    let prior = Prior { shift, radius };
    let aerial = kaze(window, &config.kaze).map_err(|e| ImageRejection::Imaging { message: e.to_string() })?;
    let (n_mm, n_aerial) = (mm.keypoints.len(), aerial.keypoints.len());
    if n_mm < config.min_initial_inliers || n_aerial < config.min_initial_inliers {
        return Err(ImageRejection::FewFeatures { mm: n_mm, aerial: n_aerial });
    }
    let pairs: Vec<Correspondence> = if config.guided_matching {
        guided_matches(mm, &aerial, &prior, config.match_ratio)
    } else {
        match_surf(&mm.descriptors, &aerial.descriptors, config.match_ratio, true)
            .into_iter()
            .map(|(i, j, _)| {
                let (a, b) = (&mm.keypoints[i], &aerial.keypoints[j]);
                Correspondence { a: [a.u, a.v], b: [b.u, b.v] }
            })
            .collect()
    };
    Ok((pairs, prior))
}

/// The initial transformation of one aerial window (Jende et al. 2017 §3.7): the translations its KAZE matches
/// agree on (`kaze`, module docs), then `pooled` (translations all windows of the patch agree on, module
/// `pooled`), the plausible ones in that order, the first as the transformation and the others as
/// alternatives for the corner matching; failing all, the whole-patch correlation; each through the
/// plausibility check. `predicted` is the aerial-window pixel of the patch centre under the DG
/// georeferencing.
pub(crate) fn initial_transform(
    prepared: &Prepared,
    kaze: &KazePairs,
    window: &GrayImage,
    predicted: [f64; 2],
    position_sigma: f64,
    pooled: &[Matrix3<f64>],
    config: &AerialConfig,
) -> Initial {
    let centre = [prepared.grid.width as f64 / 2.0, prepared.grid.height as f64 / 2.0];
    let (gsd, bounds) = (prepared.grid.gsd, &config.plausibility);
    let check = |t: &Matrix3<f64>| check_plausibility(t, centre, predicted, gsd, position_sigma, bounds);
    let judge = |t: Matrix3<f64>, inliers, fallback_ncc| {
        let c = check(&t);
        let transform = if c.passed { Ok(t) } else { Err(c.rejection()) };
        Initial { transform, inliers, fallback_ncc, offset_m: Some(c.offset_m), alternatives: Vec::new() }
    };
    let own =
        kaze.as_ref().map_err(Clone::clone).and_then(|(pairs, prior)| kaze_consensus(pairs, prior, window, config));
    let inliers = match &own {
        Ok(c) => c.first().map_or(0, |c| c.1),
        Err(ImageRejection::NoTransform { inliers, .. }) => *inliers,
        Err(_) => 0,
    };
    let own_plausible = own.iter().flatten().map(|c| c.0).filter(|t| check(t).passed);
    let mut plausible: Vec<Matrix3<f64>> = Vec::new();
    let distinct = |t: &Matrix3<f64>, others: &[Matrix3<f64>]| {
        others.iter().all(|o| (o[(0, 2)] - t[(0, 2)]).hypot(o[(1, 2)] - t[(1, 2)]) > config.initial_threshold_px)
    };
    for t in
        own_plausible.take(config.initial_candidates.max(1)).chain(pooled.iter().copied().filter(|t| check(t).passed))
    {
        if distinct(&t, &plausible) {
            plausible.push(t);
        }
    }
    if let Some((&first, rest)) = plausible.split_first() {
        let mut initial = judge(first, inliers, None);
        initial.alternatives = rest.to_vec();
        return initial;
    }
    let failure = match own {
        // a consensus that failed the plausibility check
        Ok(c) => return judge(c[0].0, inliers, None),
        Err(failure) => failure,
    };
    let radius = config.plausibility.bound_m(position_sigma) / prepared.grid.gsd;
    let fallback = config
        .correlation_fallback
        .then(|| correlate(prepared, window, predicted, radius, config.min_correlation_margin))
        .flatten();
    if let Some((t, score)) = fallback.filter(|f| f.1 >= config.min_correlation) {
        return judge(t, 0, Some(score));
    }
    Initial {
        transform: Err(failure),
        inliers,
        fallback_ncc: fallback.map(|f| f.1),
        offset_m: None,
        alternatives: Vec::new(),
    }
}

/// The translations one window's KAZE matches agree on, with their inliers (module docs).
///
/// A translation, not a similarity: the prepared patch already has the aerial image's orientation and GSD
/// (Jende et al. 2017 §3.6), and what remains is the DG position error (Jende et al. 2017 §3.1); the DG heading error
/// (milliradians) moves a corner 15 m from the centre by a few centimetres, a fraction of a pixel. A
/// similarity fitted to the handful of matches a street patch gives has a poorly determined rotation and
/// scale (5–14 % scale errors on district canyon seed 2 with 6–8 inliers), which fail the plausibility
/// check or throw the corner transfer pixels off at the patch edge.
fn kaze_consensus(
    pairs: &[Correspondence],
    prior: &Prior,
    window: &GrayImage,
    config: &AerialConfig,
) -> Result<Vec<(Matrix3<f64>, usize)>, ImageRejection> {
    let floor = config.min_initial_inliers;
    translation_consensus(pairs, config.initial_threshold_px, match_area(prior, window, config), floor)
        .map_err(|inliers| ImageRejection::NoTransform { matches: pairs.len(), inliers })
}

/// The area over which a false match's displacement scatters, px²: the guided matching's disc, or the window.
pub(crate) fn match_area(prior: &Prior, window: &GrayImage, config: &AerialConfig) -> f64 {
    if config.guided_matching {
        std::f64::consts::PI * prior.radius * prior.radius
    } else {
        (window.width() * window.height()) as f64
    }
}

/// The translations `pairs` (MM → aerial pixels) agree on within `threshold` pixels, with their inliers, best
/// first: the largest consensus when it is more than false matches scattered over `area` px² reach by chance
/// (and at least `floor`), then the largest consensus of the other matches at a clearly different
/// translation when it is significant too. A repeated marking (dashes, zebra stripes) matched one period off
/// gives such a second consensus, and the larger one is then not necessarily the true one: the corner
/// matching decides (module `image`). Otherwise the best consensus's size.
pub(crate) fn translation_consensus(
    pairs: &[Correspondence],
    threshold: f64,
    area: f64,
    floor: usize,
) -> Result<Vec<(Matrix3<f64>, usize)>, usize> {
    let needed = significant_inliers(pairs.len(), threshold, area).max(floor);
    let displaced: Vec<GroundPair> = pairs.iter().map(|p| (p.a, p.b)).collect();
    let (flags, t) = common_translation(&displaced, threshold, 1).ok_or(0usize)?;
    let inliers = flags.iter().filter(|&&f| f).count();
    if inliers < needed {
        return Err(inliers);
    }
    let translation = |t: [f64; 2]| Matrix3::new(1.0, 0.0, t[0], 0.0, 1.0, t[1], 0.0, 0.0, 1.0);
    let mut candidates = vec![(translation(t), inliers)];
    // The best consensus among the other matches, at a translation clearly apart from the first.
    let rest: Vec<GroundPair> = displaced.iter().zip(&flags).filter(|p| !*p.1).map(|p| *p.0).collect();
    let second = common_translation(&rest, threshold, 1)
        .filter(|(_, s)| (s[0] - t[0]).hypot(s[1] - t[1]) > 2.0 * threshold)
        .map(|(f, s)| (s, f.iter().filter(|&&b| b).count()));
    if let Some((s, n)) = second.filter(|s| s.1 >= significant_inliers(rest.len(), threshold, area)) {
        candidates.push((translation(s), n));
    }
    Ok(candidates)
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
    use crate::aerial::tests::scatter;

    /// A similarity of rotation `angle`, scale `s` about (50, 50), then translated by `d`.
    fn similarity(angle: f64, s: f64, d: [f64; 2]) -> Matrix3<f64> {
        let (sn, cs) = angle.sin_cos();
        let (a, b) = (s * cs, s * sn);
        Matrix3::new(a, -b, 50.0 - a * 50.0 + b * 50.0 + d[0], b, a, 50.0 - b * 50.0 - a * 50.0 + d[1], 0.0, 0.0, 1.0)
    }

    #[test]
    fn five_true_matches_among_false_ones_give_the_translation_and_three_chance_ones_do_not() {
        // True shift (7.3, −4.1) px, five matches with 0.3 px noise spread over a 200 px patch; 15 false
        // matches displaced anywhere within 20 px of the DG prediction (0, 0).
        let truth = [7.3, -4.1];
        let pair = |a: [f64; 2], d: [f64; 2]| Correspondence { a, b: [a[0] + d[0], a[1] + d[1]] };
        let mut pairs: Vec<Correspondence> = (0..5)
            .map(|k| {
                let a = [100.0 + 100.0 * scatter(k, 1), 100.0 + 100.0 * scatter(k, 2)];
                pair(a, [truth[0] + 0.3 * scatter(k, 3), truth[1] + 0.3 * scatter(k, 4)])
            })
            .collect();
        let false_pair = |k: usize| {
            let a = [100.0 + 100.0 * scatter(k, 5), 100.0 + 100.0 * scatter(k, 6)];
            pair(a, [14.0 * scatter(k, 7), 14.0 * scatter(k, 8)])
        };
        pairs.extend((0..15).map(false_pair));
        let area = std::f64::consts::PI * 400.0;
        let candidates = translation_consensus(&pairs, 1.5, area, 3).expect("a translation");
        assert_eq!(candidates.len(), 1, "false matches make no second consensus");
        let (t, inliers) = candidates[0];
        assert_eq!(inliers, 5);
        assert!((t[(0, 2)] - truth[0]).abs() < 0.2 && (t[(1, 2)] - truth[1]).abs() < 0.2, "{t}");
        assert!(t[(0, 0)] == 1.0 && t[(0, 1)] == 0.0 && t[(1, 0)] == 0.0 && t[(1, 1)] == 1.0);
        // Three false matches that happen to agree, among 17 others: not significant (four needed).
        let mut chance: Vec<Correspondence> = (0..17).map(false_pair).collect();
        chance.extend((0..3).map(|k| pair([20.0 + 50.0 * k as f64, 30.0], [-9.0, 5.0 + 0.2 * k as f64])));
        assert_eq!(translation_consensus(&chance, 1.5, area, 3), Err(3));
        // A repeated marking: the five true matches and six more one dash period (1.56 m = 13 px) along the
        // street: two significant translations, the larger (wrong) one first; both are offered.
        let mut periodic = pairs.clone();
        periodic.extend((5..11).map(|k| {
            let a = [100.0 + 100.0 * scatter(k, 1), 100.0 + 100.0 * scatter(k, 2)];
            pair(a, [truth[0] + 13.0 + 0.3 * scatter(k, 3), truth[1] + 0.3 * scatter(k, 4)])
        }));
        let both = translation_consensus(&periodic, 1.5, area, 3).expect("two translations");
        assert_eq!(both.iter().map(|c| c.1).collect::<Vec<_>>(), vec![6, 5]);
        assert!((both[0].0[(0, 2)] - truth[0] - 13.0).abs() < 0.2 && (both[1].0[(0, 2)] - truth[0]).abs() < 0.2);
        // The floor: five inliers are not enough when six are asked for.
        assert_eq!(translation_consensus(&pairs, 1.5, area, 6), Err(5));
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
