//! Step 7 of Jende et al. 2017 (§3.8): every MM corner transferred into each passing aerial image with its initial
//! transformation, matched by NCC in a small window and refined by least-squares matching; RANSAC outlier
//! removal per image; and the consistency of the same point across aerial images (ground intersections).

use nalgebra::Matrix3;
use plumbline_imaging::GrayImage;
use plumbline_imaging::lsm::{least_squares_match, translation};
use plumbline_imaging::models::{Correspondence, Model};
use plumbline_imaging::ncc::NccSearcher;
use plumbline_imaging::ransac::ransac;
use plumbline_imaging::warp::apply_h;

use super::config::AerialConfig;
use super::correlate::search;
use super::diagnostics::ImageRejection;
use super::prepare::Prepared;

/// One MM corner found in one aerial image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PointMatch {
    /// Index into the patch's points.
    pub slot: usize,
    /// Position in the prepared MM patch.
    pub prepared: [f64; 2],
    /// Position in the aerial window.
    pub window: [f64; 2],
}

/// Matches of one image and how many corners could be tried.
#[derive(Clone, Debug, Default)]
pub(crate) struct CornerMatches {
    /// Corners with a full valid template whose transfer lies inside the aerial patch.
    pub candidates: usize,
    /// Corners matched above the NCC threshold.
    pub matches: Vec<PointMatch>,
    /// Every candidate's search (slot; window pixels), for the trace.
    pub attempts: Vec<SlotAttempt>,
}

/// One candidate's search, in window pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SlotAttempt {
    /// Index into the patch's points.
    pub slot: usize,
    /// Where the transformation put the corner.
    pub transfer: [f64; 2],
    /// The NCC peak: position, coefficient, and the runner-up's coefficient (≥ 2 px from the peak).
    pub peak: Option<([f64; 2], f64, f64)>,
    /// The accepted (LSM-refined) position.
    pub matched: Option<[f64; 2]>,
    /// Förstner roundness of the template at the aerial GSD ([`roundness`]).
    pub roundness: f64,
}

/// Match the corners (`corners[slot]` in prepared pixels) into the Wallis-filtered aerial `window` around
/// their transfer by `transform` within `radius` pixels (Jende et al. 2017 §3.8: template in the MM patch, search
/// window in the aerial one).
pub(crate) fn match_corners(
    prepared: &Prepared,
    corners: &[[f64; 2]],
    window: &GrayImage,
    transform: &Matrix3<f64>,
    radius: usize,
    config: &AerialConfig,
) -> CornerMatches {
    let searcher = NccSearcher::new(window);
    let reach = (radius + config.template_half) as f64;
    let (w, h) = (window.width() as f64, window.height() as f64);
    let candidates: Vec<(usize, [f64; 2], (f64, f64))> = corners
        .iter()
        .enumerate()
        .filter(|(_, q)| prepared.valid_around(**q, config.template_half))
        .filter_map(|(slot, &q)| Some((slot, q, apply_h(transform, q[0], q[1])?)))
        .filter(|(_, _, (u, v))| *u >= reach && *v >= reach && *u <= w - reach && *v <= h - reach)
        .collect();
    let attempts: Vec<SlotAttempt> = candidates
        .iter()
        .map(|&(slot, q, (u, v))| {
            let template = prepared.template(q, config.template_half);
            let roundness = roundness(&template);
            let mut attempt = SlotAttempt { slot, transfer: [u, v], peak: None, matched: None, roundness };
            let Some(m) = search(&searcher, &template, [u, v], radius) else { return attempt };
            attempt.peak = Some(([m.u, m.v], m.score, m.second));
            if m.score < config.min_ncc {
                return attempt;
            }
            // Jende et al. 2017 §3.8: NCC, then least-squares matching to subpixel precision
            let refined = least_squares_match(&template, window, translation(m.u, m.v), &config.lsm)
                .ok()
                .map(|l| [l.affine[0], l.affine[3]])
                .filter(|p| (p[0] - m.u).hypot(p[1] - m.v) <= config.lsm_max_shift_px);
            attempt.matched = Some(refined.unwrap_or([m.u, m.v]));
            attempt
        })
        .collect();
    let matches = candidates
        .iter()
        .zip(&attempts)
        .filter_map(|(&(slot, q, _), a)| a.matched.map(|window| PointMatch { slot, prepared: q, window }))
        .collect();
    CornerMatches { candidates: candidates.len(), matches, attempts }
}

/// Förstner's roundness q = 4 det N / tr² N ∈ [0, 1] of a template's structure tensor N (central differences
/// over its interior; Förstner & Gülch 1987): 1 for an isotropic corner, 0 for a straight edge or no contrast.
pub(crate) fn roundness(template: &GrayImage) -> f64 {
    let (w, h) = (template.width(), template.height());
    let mut n = [0.0f64; 3];
    for r in 1..h.saturating_sub(1) {
        for c in 1..w.saturating_sub(1) {
            let gx = 0.5 * f64::from(template.get(c + 1, r) - template.get(c - 1, r));
            let gy = 0.5 * f64::from(template.get(c, r + 1) - template.get(c, r - 1));
            n = [n[0] + gx * gx, n[1] + gx * gy, n[2] + gy * gy];
        }
    }
    let (det, trace) = (n[0] * n[2] - n[1] * n[1], n[0] + n[2]);
    if trace > 1e-12 { (4.0 * det / (trace * trace)).clamp(0.0, 1.0) } else { 0.0 }
}

/// RANSAC similarity over one image's matches (Jende et al. 2017 §3.8); the inliers and the similarity (prepared →
/// window pixels) if at least `config.min_correspondences` remain.
pub(crate) fn remove_outliers(
    matches: Vec<PointMatch>,
    config: &AerialConfig,
) -> Result<(Vec<PointMatch>, Matrix3<f64>), ImageRejection> {
    let needed = config.min_correspondences;
    let too_few = |found| ImageRejection::TooFewCorrespondences { found, needed };
    if matches.len() < needed.max(Model::Similarity.min_samples()) {
        return Err(too_few(matches.len()));
    }
    let pairs: Vec<Correspondence> = matches.iter().map(|m| Correspondence { a: m.prepared, b: m.window }).collect();
    let fit = ransac(Model::Similarity, &pairs, &config.match_ransac)
        .map_err(|e| ImageRejection::Imaging { message: e.to_string() })?;
    let kept: Vec<PointMatch> = matches.into_iter().zip(&fit.inliers).filter(|p| *p.1).map(|p| p.0).collect();
    if kept.len() < needed { Err(too_few(kept.len())) } else { Ok((kept, fit.transform)) }
}

/// Jende et al. 2017 §3.8 consistency across aerial images: `grounds[k]` is where observation k of one point meets
/// the ground; observations farther than `tolerance_m` from the component-wise median are flagged. With
/// two observations that disagree neither can be trusted, so both are flagged.
pub(crate) fn consistent(grounds: &[[f64; 2]], tolerance_m: f64) -> Vec<bool> {
    let median = |k: usize| {
        let mut v: Vec<f64> = grounds.iter().map(|g| g[k]).collect();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n == 0 {
            f64::NAN
        } else if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    };
    let m = [median(0), median(1)];
    grounds.iter().map(|g| (g[0] - m[0]).hypot(g[1] - m[1]) <= tolerance_m).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aerial::edge_roundness;

    /// A 13 × 13 template at 12 cm of a smooth step (σ ≈ 1 px) along the unit normal `n` through the centre,
    /// optionally only on one side of a second step along `m` (a corner where both are bright).
    fn template(n: [f64; 2], m: Option<[f64; 2]>) -> GrayImage {
        let step = |x: f64| 1.0 / (1.0 + (-1.7 * x).exp());
        GrayImage::from_fn(13, 13, |c, r| {
            let (x, y) = (c as f64 - 6.0 + 0.3, r as f64 - 6.0 - 0.2);
            let a = step(n[0] * x + n[1] * y);
            let b = m.map_or(1.0, |m| step(m[0] * x + m[1] * y));
            (40.0 + 150.0 * a * b) as f32
        })
    }

    #[test]
    fn roundness_tells_corners_from_edges_whatever_their_direction() {
        let dirs = [0.0f64, 0.5, 1.1, 2.3].map(|a| [a.cos(), a.sin()]);
        for d in dirs {
            let edge = roundness(&template(d, None));
            assert!(edge < 0.02, "an edge along {d:?}: q = {edge}");
            let corner = roundness(&template(d, Some([-d[1], d[0]])));
            assert!(corner > 0.6, "a right-angled corner {d:?}: q = {corner}");
        }
        // An edge with a dent (a 45° corner) lies between; no contrast is no corner at all.
        let a = 0.3f64;
        let dent = roundness(&template([a.cos(), a.sin()], Some([(a + 2.36).cos(), (a + 2.36).sin()])));
        assert!(dent > 0.15 && dent < 0.8, "{dent}");
        assert_eq!(roundness(&GrayImage::from_fn(13, 13, |_, _| 90.0)), 0.0);
        // The bound: along-edge σ = pixel_sigma · √(λmax/λmin) may reach the search radius.
        let q = edge_roundness(0.3, 3.0);
        assert!((q - 4.0 * 0.01 / 1.01f64.powi(2)).abs() < 1e-12 && (q - 0.039).abs() < 1e-3, "{q}");
        assert!(edge_roundness(0.3, 6.0) < q && edge_roundness(0.3, 0.3) == 1.0);
        assert!(q > 0.02, "the edges above are below it");
    }

    #[test]
    fn consistency_flags_the_ray_that_leaves_the_others_and_both_of_a_disagreeing_pair() {
        let three = consistent(&[[10.0, 20.0], [10.05, 19.98], [10.9, 20.1]], 0.18);
        assert_eq!(three, vec![true, true, false]);
        // Two rays 0.5 m apart: the median is halfway, 0.25 m from each.
        assert_eq!(consistent(&[[0.0, 0.0], [0.5, 0.0]], 0.18), vec![false, false]);
        assert_eq!(consistent(&[[0.0, 0.0], [0.2, 0.0]], 0.18), vec![true, true]);
    }
}
