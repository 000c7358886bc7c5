//! Jende et al. 2017 §3.8's RANSAC outlier removal over all aerial images of one MM patch at once.
//!
//! The corner matches of every aerial image pass through the same transformation: the patch's DG
//! georeferencing error (a horizontal offset and a heading error, Jende et al. 2017 §3.1), while the frames' AT errors
//! (3 cm, 3″ ≈ 2 cm on the ground) are a fifth of an aerial pixel. So the correspondences of all images,
//! brought to the ground plane the patch was matched in (MM: the corner's ortho-image cell, DG-georeferenced,
//! as the per-image RANSAC saw it; aerial: the ray met at the patch height), share ONE offset. Estimating it
//! from all images together keeps the paper's "ten correspondences for a stable estimation" for the one
//! transformation that is estimated, instead of asking ten of every image — the threshold the paper found
//! to discard most images with only lane markings (§4.2, §4.3).

use super::MmPatch;
use super::config::AerialConfig;
use super::image::ImageResult;
use super::view::View;

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

/// Keep in every image only the matches that fit the patch's common offset (threshold: the per-image
/// RANSAC's, in aerial pixels of `gsd` metres; aerial rays met at the patch height `height` plus the ground's
/// rise at each point); when fewer than
/// `config.min_correspondences` fit, drop all.
/// Returns the matches kept over all images.
pub(super) fn keep_common(
    results: &mut [ImageResult],
    views: &[View<'_>],
    patch: &MmPatch<'_>,
    height: f64,
    gsd: f64,
    config: &AerialConfig,
) -> usize {
    let c = patch.grid.centre;
    let mut owners = Vec::new();
    let mut pairs = Vec::new();
    let threshold = config.match_ransac.threshold * gsd;
    for (i, r) in results.iter().enumerate() {
        for (k, &(slot, pixel)) in r.matches.iter().enumerate() {
            let q = patch.points[slot].pixel;
            let m = patch.grid.to_map(q[0], q[1]);
            let Some(g) = views[i].ground(pixel, height + patch.points[slot].rise) else { continue };
            owners.push((i, k));
            pairs.push(([m[0] - c[0], m[1] - c[1]], [g[0] - c[0], g[1] - c[1]]));
        }
    }
    let inliers = common_translation(&pairs, threshold, config.min_correspondences)
        .map_or_else(|| vec![false; pairs.len()], |f| f.0);
    let mut keep: Vec<Vec<bool>> = results.iter().map(|r| vec![false; r.matches.len()]).collect();
    for (&(i, k), &ok) in owners.iter().zip(&inliers) {
        keep[i][k] = ok;
    }
    for (r, keep) in results.iter_mut().zip(keep) {
        let mut flags = keep.into_iter();
        r.matches.retain(|_| flags.next().unwrap_or(false));
        r.trace.ransac = r.matches.iter().map(|m| m.0).collect();
    }
    inliers.iter().filter(|&&b| b).count()
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
}
