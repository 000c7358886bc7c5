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
use super::consensus::common_translation;
use super::image::ImageResult;
use super::view::View;

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
