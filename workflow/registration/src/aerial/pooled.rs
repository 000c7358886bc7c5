//! Jende et al. 2017 §3.7's initial transformation from the KAZE matches of all aerial windows of one patch at once.
//!
//! Every window of a patch sees the same DG error (Jende et al. 2017 §3.1; the frames' AT errors are a fifth of an
//! aerial pixel, module `joint`), so their KAZE matches, brought to the ground as displacements from where
//! the DG georeferencing puts them, agree on ONE offset. A street patch gives each window a handful of
//! matches (4–5 inliers where six are asked for); pooled, the windows support each other. Matches are
//! counted by their MM keypoint: one false match repeated in every window (they all show the same ground) is
//! one piece of evidence, not three.

use std::collections::BTreeSet;

use nalgebra::Matrix3;
use plumbline_geo::metrics::median;
use plumbline_imaging::models::Correspondence;
use plumbline_imaging::ortho::GroundGrid;

use super::consensus::significant_inliers;
use super::guided::Prior;

/// The KAZE matches of one window.
pub(crate) struct WindowMatches<'a> {
    /// The orientation group of the window (windows of one group share the prepared MM patch, so an MM
    /// keypoint is identified by its group and position).
    pub group: usize,
    /// The prepared MM patch's grid (aerial orientation and GSD).
    pub grid: &'a GroundGrid,
    /// Prepared MM pixels → window pixels.
    pub pairs: &'a [Correspondence],
    /// The DG prior the matches were drawn under.
    pub prior: &'a Prior,
    /// Area over which a false match's displacement scatters, px² (`initial::match_area`).
    pub area_px: f64,
}

/// One match on the ground: its MM keypoint and its displacement from the DG prediction (E, N metres).
struct Item {
    key: (usize, i64, i64),
    offset: [f64; 2],
}

/// The ground displacement (E, N) of a window displacement `d` (pixels) on `grid`.
fn to_ground(grid: &GroundGrid, d: [f64; 2]) -> [f64; 2] {
    let (cu, cv) = (grid.width as f64 / 2.0, grid.height as f64 / 2.0);
    let (p, q) = (grid.to_map(cu + d[0], cv + d[1]), grid.to_map(cu, cv));
    [p[0] - q[0], p[1] - q[1]]
}

/// The window translation (prepared MM pixels → window pixels) that moves the patch by the ground offset
/// `offset` (E, N metres) from where the DG georeferencing (`prior.shift`) puts it.
pub(crate) fn translation_for(grid: &GroundGrid, prior: &Prior, offset: [f64; 2]) -> Matrix3<f64> {
    let (cu, cv) = (grid.width as f64 / 2.0, grid.height as f64 / 2.0);
    let q = grid.to_map(cu, cv);
    let p = grid.to_pixel(q[0] + offset[0], q[1] + offset[1]);
    let t = [prior.shift[0] + p[0] - cu, prior.shift[1] + p[1] - cv];
    Matrix3::new(1.0, 0.0, t[0], 0.0, 1.0, t[1], 0.0, 0.0, 1.0)
}

/// The ground offsets (E, N metres) the windows' matches agree on within `threshold_px`, best first: the
/// offset the most distinct MM keypoints support when more do than chance agreement gives (1 % false
/// alarm, `consensus::significant_inliers`) and at least `floor`; then, as for one window, the best offset of
/// the other matches when it is clearly apart and significant too (a repeated marking one period off).
pub(crate) fn pooled_offsets(windows: &[WindowMatches<'_>], threshold_px: f64, floor: usize) -> Vec<[f64; 2]> {
    let items: Vec<Item> = windows
        .iter()
        .flat_map(|w| {
            w.pairs.iter().map(move |p| {
                let d = [p.b[0] - p.a[0] - w.prior.shift[0], p.b[1] - p.a[1] - w.prior.shift[1]];
                let key = (w.group, (p.a[0] * 10.0).round() as i64, (p.a[1] * 10.0).round() as i64);
                Item { key, offset: to_ground(w.grid, d) }
            })
        })
        .collect();
    let Some(gsd) = median(&mut windows.iter().map(|w| w.grid.gsd).collect::<Vec<_>>()) else { return Vec::new() };
    let Some(area_px) = median(&mut windows.iter().map(|w| w.area_px).collect::<Vec<_>>()) else {
        return Vec::new();
    };
    let (threshold, area) = (threshold_px * gsd, area_px * gsd * gsd);
    let all: Vec<&Item> = items.iter().collect();
    let needed = significant_inliers(distinct(&all), threshold, area).max(floor);
    let Some((best, support)) = consensus(&all, threshold) else { return Vec::new() };
    if support < needed {
        return Vec::new();
    }
    let mut offsets = vec![best];
    let rest: Vec<&Item> = all.iter().copied().filter(|i| gap(i.offset, best) > threshold).collect();
    let second = consensus(&rest, threshold).filter(|(s, _)| gap(*s, best) > 2.0 * threshold);
    if let Some((s, n)) = second.filter(|(_, n)| *n >= significant_inliers(distinct(&rest), threshold, area)) {
        debug_assert!(n >= 3);
        offsets.push(s);
    }
    offsets
}

fn gap(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn distinct(items: &[&Item]) -> usize {
    items.iter().map(|i| i.key).collect::<BTreeSet<_>>().len()
}

/// The offset most distinct keypoints agree on within `threshold` (every item's offset a hypothesis, so
/// deterministic), refined to the mean of its inliers, with the distinct keypoints supporting it there.
fn consensus(items: &[&Item], threshold: f64) -> Option<([f64; 2], usize)> {
    let support = |h: [f64; 2]| {
        let inliers: Vec<&Item> = items.iter().copied().filter(|i| gap(i.offset, h) <= threshold).collect();
        (distinct(&inliers), inliers)
    };
    let (_, inliers) = items.iter().map(|i| support(i.offset)).max_by_key(|s| s.0)?;
    let n = inliers.len() as f64;
    let mean = inliers.iter().fold([0.0, 0.0], |m, i| [m[0] + i.offset[0] / n, m[1] + i.offset[1] / n]);
    let (count, _) = support(mean);
    (count > 0).then_some((mean, count))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aerial::tests::scatter;

    fn grid(up_heading: f64) -> GroundGrid {
        GroundGrid::new([1000.0, 2000.0], 0.12, 200, 200, up_heading).expect("grid")
    }

    /// Matches of one window: `keypoints` MM keypoints moved by the ground `offset` through `grid`, plus
    /// `false_matches` displaced anywhere within the prior's radius.
    fn window_pairs(
        grid: &GroundGrid,
        prior: &Prior,
        offset: [f64; 2],
        keypoints: &[usize],
        false_matches: usize,
        salt: u64,
    ) -> Vec<Correspondence> {
        let t = translation_for(grid, prior, offset);
        let mut pairs: Vec<Correspondence> = keypoints
            .iter()
            .map(|&k| {
                let a = [100.0 + 80.0 * scatter(k, 1), 100.0 + 80.0 * scatter(k, 2)];
                let noise = [0.3 * scatter(k, salt), 0.3 * scatter(k, salt + 1)];
                Correspondence { a, b: [a[0] + t[(0, 2)] + noise[0], a[1] + t[(1, 2)] + noise[1]] }
            })
            .collect();
        pairs.extend((0..false_matches).map(|k| {
            let a = [100.0 + 80.0 * scatter(k, salt + 7), 100.0 + 80.0 * scatter(k, salt + 8)];
            let d = [0.7 * prior.radius * scatter(k, salt + 9), 0.7 * prior.radius * scatter(k, salt + 10)];
            Correspondence { a, b: [a[0] + prior.shift[0] + d[0], a[1] + prior.shift[1] + d[1]] }
        }));
        pairs
    }

    #[test]
    fn a_translation_and_its_ground_offset_invert_each_other_in_any_orientation() {
        for heading in [0.0, 0.7, -2.1] {
            let g = grid(heading);
            let prior = Prior { shift: [12.5, -7.25], radius: 20.0 };
            let t = translation_for(&g, &prior, [0.3, -0.45]);
            let back = to_ground(&g, [t[(0, 2)] - prior.shift[0], t[(1, 2)] - prior.shift[1]]);
            assert!(gap(back, [0.3, -0.45]) < 1e-9, "{heading}: {back:?}");
            // 0.3 m east is 2.5 px of 12 cm.
            let px = (t[(0, 2)] - prior.shift[0]).hypot(t[(1, 2)] - prior.shift[1]);
            assert!((px - 0.3f64.hypot(0.45) / 0.12).abs() < 1e-9);
        }
    }

    #[test]
    fn windows_too_weak_alone_agree_on_the_common_offset_counting_each_keypoint_once() {
        // Three frames (two orientations) of one patch, 0.25 m E / 0.15 m N DG error: each window matches
        // 4–5 of 8 true keypoints (six needed alone) among 9 false matches.
        let truth = [0.25, 0.15];
        let (ga, gb) = (grid(0.0), grid(0.4));
        let prior = Prior { shift: [30.0, 25.0], radius: 20.0 };
        let area_px = std::f64::consts::PI * 400.0;
        let pa = window_pairs(&ga, &prior, truth, &[0, 1, 2, 3, 4], 9, 11);
        let pb = window_pairs(&ga, &prior, truth, &[2, 3, 5, 6], 9, 21);
        let pc = window_pairs(&gb, &prior, truth, &[1, 4, 6, 7], 9, 31);
        let w = |group, grid, pairs| WindowMatches { group, grid, pairs, prior: &prior, area_px };
        let windows = [w(0, &ga, &pa[..]), w(0, &ga, &pb[..]), w(1, &gb, &pc[..])];
        let offsets = pooled_offsets(&windows, 1.5, 6);
        assert!(!offsets.is_empty() && gap(offsets[0], truth) < 0.03, "{offsets:?}");
        // The same matches in one window only are not enough for six.
        assert!(pooled_offsets(&windows[..1], 1.5, 6).is_empty());
        // One window's five true matches repeated in two more windows of the same orientation are still five
        // keypoints: not six.
        let repeated = [w(0, &ga, &pa[..]), w(0, &ga, &pa[..]), w(0, &ga, &pa[..])];
        assert!(pooled_offsets(&repeated, 1.5, 6).is_empty());
        // False matches alone agree on nothing.
        let noise: Vec<Correspondence> = window_pairs(&ga, &prior, truth, &[], 30, 41);
        assert!(pooled_offsets(&[w(0, &ga, &noise[..])], 1.5, 3).is_empty());
    }
}
