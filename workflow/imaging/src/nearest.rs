//! Brute-force nearest-neighbour descriptor matching shared by AKAZE (Hamming) and KAZE (Euclidean):
//! Lowe's ratio test on the best and second-best distance, optionally mutual (A's nearest in B is also B's
//! nearest in A).

use rayon::prelude::*;

/// For each descriptor of `a`, its nearest in `b` when `passes(best, second)` holds (and, if `mutual`, `a[i]` is
/// also the nearest of `b[j]` in `a`): `(i, j, best distance)`.
pub(crate) fn match_nearest<D, T>(
    a: &[D],
    b: &[D],
    distance: impl Fn(&D, &D) -> T + Sync,
    passes: impl Fn(T, T) -> bool + Sync,
    mutual: bool,
    worst: T,
) -> Vec<(usize, usize, T)>
where
    D: Sync,
    T: PartialOrd + Copy + Send + Sync,
{
    let nearest = |d: &D, set: &[D]| {
        let mut best = (worst, worst, usize::MAX);
        for (j, e) in set.iter().enumerate() {
            let h = distance(d, e);
            if h < best.0 {
                best = (h, best.0, j);
            } else if h < best.1 {
                best.1 = h;
            }
        }
        best
    };
    let back: Vec<usize> = if mutual { b.par_iter().map(|d| nearest(d, a).2).collect() } else { Vec::new() };
    a.par_iter()
        .enumerate()
        .filter_map(|(i, d)| {
            let (best, second, j) = nearest(d, b);
            let ok = j != usize::MAX && passes(best, second) && (!mutual || back[j] == i);
            ok.then_some((i, j, best))
        })
        .collect()
}
