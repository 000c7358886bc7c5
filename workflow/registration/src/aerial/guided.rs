//! Descriptor matching for the initial transformation (Jende et al. 2017 §3.7) guided by the DG georeferencing:
//! MM poses are wrong "in the low-metre range at most, and can be thus used to constrain the search for
//! correspondences" (Jende et al. 2017 §3.1). A pair is a candidate only when the aerial keypoint lies within the
//! plausibility bound of where the DG georeferencing puts the MM keypoint, so the ratio test compares a
//! keypoint with its look-alikes nearby, not with the same marking repeated further down the street, and no
//! pair is proposed that the plausibility check would reject anyway.

use plumbline_imaging::kaze::{KazeFeatures, SurfDescriptor};
use plumbline_imaging::models::Correspondence;

fn distance2(a: &SurfDescriptor, b: &SurfDescriptor) -> f32 {
    a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum()
}

/// The DG prior of a match: MM keypoint (u, v) is expected at (u, v) + `shift` in the aerial window, at
/// most `radius` pixels off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Prior {
    /// Aerial-window pixel minus prepared-MM pixel under the DG georeferencing.
    pub shift: [f64; 2],
    /// Largest distance from the expected position, pixels.
    pub radius: f64,
}

impl Prior {
    fn allows(&self, a: [f64; 2], b: [f64; 2]) -> bool {
        (b[0] - a[0] - self.shift[0]).hypot(b[1] - a[1] - self.shift[1]) <= self.radius
    }
}

/// Best and second-best distance among `candidates` (index, distance), with the best's index.
fn two_best(candidates: impl Iterator<Item = (usize, f32)>) -> Option<(usize, f32, f32)> {
    let mut best: Option<(usize, f32)> = None;
    let mut second = f32::INFINITY;
    for (j, dist) in candidates {
        match best {
            Some((_, b)) if dist >= b => second = second.min(dist),
            _ => {
                second = best.map_or(second, |(_, b)| b.min(second));
                best = Some((j, dist));
            }
        }
    }
    best.map(|(j, b)| (j, b, second))
}

/// Mutual nearest neighbours among DG-plausible pairs that pass the distance-ratio test (`ratio` on
/// distances, against the second-nearest plausible candidate; a sole candidate passes).
pub(crate) fn guided_matches(
    mm: &KazeFeatures,
    aerial: &KazeFeatures,
    prior: &Prior,
    ratio: f32,
) -> Vec<Correspondence> {
    let pos = |f: &KazeFeatures, i: usize| [f.keypoints[i].u, f.keypoints[i].v];
    let near = |i: usize, j: usize| prior.allows(pos(mm, i), pos(aerial, j));
    let from_mm: Vec<Option<(usize, f32, f32)>> = (0..mm.keypoints.len())
        .map(|i| {
            let d = &mm.descriptors[i];
            let cands =
                (0..aerial.keypoints.len()).filter(|&j| near(i, j)).map(|j| (j, distance2(d, &aerial.descriptors[j])));
            two_best(cands)
        })
        .collect();
    let best_mm_of = |j: usize| {
        let d = &aerial.descriptors[j];
        let cands = (0..mm.keypoints.len()).filter(|&i| near(i, j)).map(|i| (i, distance2(d, &mm.descriptors[i])));
        two_best(cands).map(|(i, _, _)| i)
    };
    let r2 = ratio * ratio; // squared distances
    from_mm
        .iter()
        .enumerate()
        .filter_map(|(i, m)| {
            let (j, best, second) = (*m)?;
            (best < r2 * second && best_mm_of(j) == Some(i))
                .then(|| Correspondence { a: pos(mm, i), b: pos(aerial, j) })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use plumbline_imaging::akaze::Keypoint;

    use super::*;

    fn features(points: &[([f64; 2], f32)]) -> KazeFeatures {
        let keypoints = points
            .iter()
            .map(|&(p, _)| Keypoint { u: p[0], v: p[1], sigma: 2.0, angle: 0.0, response: 1.0, octave: 0 })
            .collect();
        let descriptors = points.iter().map(|&(_, x)| [x; 64]).collect();
        KazeFeatures { keypoints, descriptors }
    }

    #[test]
    fn a_repeated_pattern_beyond_the_bound_does_not_spoil_the_ratio_test() {
        // MM keypoint 0 (descriptor 1.0) belongs at (10, 10) + shift (5, 0) = (15, 10). The aerial window has
        // it there and, identical, 80 px away (the same marking further down the street); keypoint 1
        // (descriptor 3.0, true match 3.05) has a look-alike (2.945) 4 px away inside the radius.
        let mm = features(&[([10.0, 10.0], 1.0), ([40.0, 10.0], 3.0)]);
        let aerial = features(&[([15.5, 10.0], 1.0), ([95.0, 10.0], 1.0), ([45.0, 10.0], 3.05), ([45.0, 14.0], 2.945)]);
        let prior = Prior { shift: [5.0, 0.0], radius: 8.0 };
        let m = guided_matches(&mm, &aerial, &prior, 0.85);
        // Keypoint 0 matches its near copy; keypoint 1's look-alike within the radius fails the ratio test.
        assert_eq!(m, vec![Correspondence { a: [10.0, 10.0], b: [15.5, 10.0] }]);
        // Without the prior (a radius covering everything) keypoint 0 is ambiguous as in global matching.
        let global = guided_matches(&mm, &aerial, &Prior { shift: [5.0, 0.0], radius: 1e6 }, 0.85);
        assert!(global.is_empty(), "{global:?}");
        // Matches displaced beyond the radius are never proposed.
        let far = guided_matches(&mm, &aerial, &Prior { shift: [-20.0, 30.0], radius: 8.0 }, 0.85);
        assert!(far.is_empty(), "{far:?}");
    }
}
