//! The consensus under one translation that the initial transformation (module `initial`, Jende et al. 2017
//! §3.7), the pooled offsets of a patch's windows (module `pooled`) and the common RANSAC over all images of
//! a patch (module `joint`, §3.8) share: the exhaustive translation consensus of ground or pixel
//! correspondences, and how many inliers a consensus needs to be more than chance.
//!
//! At the bottom of the aerial stages: it imports none of them.

/// One correspondence on the ground: the MM position and the aerial position, metres (centred).
pub(crate) type GroundPair = ([f64; 2], [f64; 2]);

/// The consensus of ground correspondences `pairs` under one translation within `threshold_m`: every
/// pair's offset is a hypothesis (exhaustive, so deterministic), the one with the most pairs within the
/// threshold wins and is refined to their mean; the inlier flags at the refined offset and the offset, or
/// None when fewer than `min_inliers` agree.
///
/// A translation, not a similarity: both sides are metric ground coordinates, and the DG heading error
/// (milliradians) turns a 20 m patch by centimetres, a fraction of the threshold; two free parameters
/// instead of four leave false matches less room to agree.
pub(crate) fn common_translation(
    pairs: &[GroundPair],
    threshold_m: f64,
    min_inliers: usize,
) -> Option<(Vec<bool>, [f64; 2])> {
    let offset = |p: &GroundPair| [p.1[0] - p.0[0], p.1[1] - p.0[1]];
    let within = |t: [f64; 2]| -> Vec<bool> {
        pairs.iter().map(|p| (offset(p)[0] - t[0]).hypot(offset(p)[1] - t[1]) <= threshold_m).collect()
    };
    let count = |f: &[bool]| f.iter().filter(|&&b| b).count();
    let best = pairs.iter().map(|p| within(offset(p))).max_by_key(|f| count(f))?;
    if count(&best) < min_inliers.max(1) {
        return None;
    }
    let n = count(&best) as f64;
    let sum = pairs.iter().zip(&best).filter(|p| *p.1).fold([0.0, 0.0], |s, (p, _)| {
        let o = offset(p);
        [s[0] + o[0], s[1] + o[1]]
    });
    let mean = [sum[0] / n, sum[1] / n];
    let refined = within(mean);
    (count(&refined) >= min_inliers).then_some((refined, mean))
}

/// Acceptable chance that false descriptor matches alone produce a translation consensus.
const FALSE_ALARM: f64 = 0.01;

/// The fewest inliers of a translation consensus among `n` matches that false matches reach by chance with
/// probability at most [`FALSE_ALARM`]: a false match's displacement scatters over `area` px², so it falls
/// within `threshold` px of a given hypothesis with probability p = π·threshold²/area, and k − 1 of the
/// other n − 1 do so for one of the n hypotheses with probability ≤ n·C(n − 1, k − 1)·p^(k − 1). Never
/// fewer than three (two agreeing matches may share one structure).
pub(crate) fn significant_inliers(n: usize, threshold: f64, area: f64) -> usize {
    let p = (std::f64::consts::PI * threshold * threshold / area.max(1.0)).min(1.0);
    let chance = |k: usize| {
        let others = n.saturating_sub(1) as f64;
        let binomial = (0..k - 1).fold(1.0, |b, i| b * (others - i as f64) / (i as f64 + 1.0));
        n as f64 * binomial.max(0.0) * p.powi(k as i32 - 1)
    };
    (3..=n.max(3)).find(|&k| chance(k) <= FALSE_ALARM).unwrap_or(n.max(3))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic scatter in [-10, 10) m.
    fn scatter(k: usize, salt: u64) -> f64 {
        let x = (k as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15).wrapping_add(salt.wrapping_mul(0xbf58_476d));
        ((x >> 11) as f64 / (1u64 << 53) as f64) * 20.0 - 10.0
    }

    #[test]
    fn the_common_offset_keeps_the_true_matches_of_all_images_and_drops_the_false() {
        // Three images with 4 true matches each (DG offset 1.3 m east, −0.8 m north; ≤ 2 cm noise) and 5
        // false matches 0.2–2 m off: no image has ten, together they have twelve.
        let offset = [1.3, -0.8];
        let mut pairs: Vec<GroundPair> = Vec::new();
        for k in 0..12 {
            let a = [scatter(k, 1), scatter(k, 2)];
            let noise = [0.002 * scatter(k, 3), 0.002 * scatter(k, 4)];
            pairs.push((a, [a[0] + offset[0] + noise[0], a[1] + offset[1] + noise[1]]));
        }
        for k in 0..5 {
            let a = [scatter(k, 5), scatter(k, 6)];
            let wrong = [0.2 * scatter(k, 7), 0.2 * scatter(k, 8)];
            let size = wrong[0].hypot(wrong[1]).max(1e-9);
            let wrong = wrong.map(|w| w / size * size.max(0.2));
            pairs.push((a, [a[0] + offset[0] + wrong[0], a[1] + offset[1] + wrong[1]]));
        }
        let (inliers, t) = common_translation(&pairs, 0.12, 10).expect("a consensus");
        assert_eq!(inliers, (0..17).map(|k| k < 12).collect::<Vec<_>>());
        assert!((t[0] - offset[0]).abs() < 0.01 && (t[1] - offset[1]).abs() < 0.01, "{t:?}");
        // Fewer than ten that agree: no consensus, however many false matches come with them.
        assert!(common_translation(&pairs[..9], 0.12, 10).is_none());
        let mixed: Vec<GroundPair> = pairs[..9].iter().chain(&pairs[12..]).copied().collect();
        assert!(common_translation(&mixed, 0.12, 10).is_none());
        assert!(common_translation(&[], 0.12, 10).is_none());
    }

    #[test]
    fn the_inliers_a_translation_needs_follow_the_false_alarm_probability() {
        // Guided matching within 20 px (1257 px²), threshold 1.5 px: p = 0.005 63. Of 20 matches, three
        // agreeing by chance has probability 20·C(19, 2)·p² = 0.11, four 20·C(19, 3)·p³ = 0.0035.
        let area = std::f64::consts::PI * 400.0;
        assert_eq!(significant_inliers(20, 1.5, area), 4);
        // 7 matches: three already significant (7·C(6, 2)·p² = 0.0033); 50 matches need six.
        assert_eq!(significant_inliers(7, 1.5, area), 3);
        assert_eq!(significant_inliers(50, 1.5, area), 6);
        // Unguided over a 300 × 300 window, three are enough among 40.
        assert_eq!(significant_inliers(40, 1.5, 90_000.0), 3);
    }
}
