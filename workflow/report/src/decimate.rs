//! Thin long series for plotting without hiding their extremes: each bucket of consecutive samples keeps
//! the sample holding its minimum and the one holding its maximum, per column, so a one-epoch spike still
//! shows in a plot of a million epochs.

/// Indices (ascending, unique) of the samples to keep from equally long `columns` so that at most about
/// `max_points` remain; always keeps the first and last sample. Non-finite values are never chosen as
/// extremes.
pub fn keep_extremes(columns: &[&[f64]], max_points: usize) -> Vec<usize> {
    let len = columns.iter().map(|c| c.len()).min().unwrap_or(0);
    if len <= max_points.max(2) {
        return (0..len).collect();
    }
    let per_bucket_kept = 2 * columns.len().max(1);
    let buckets = (max_points / per_bucket_kept).max(1);
    let mut keep = vec![0, len - 1];
    for b in 0..buckets {
        let (start, end) = (b * len / buckets, ((b + 1) * len / buckets).max(b * len / buckets + 1));
        for column in columns {
            let finite = (start..end.min(len)).filter(|&i| column[i].is_finite());
            let mut extremes: Option<(usize, usize)> = None;
            for i in finite {
                extremes = Some(match extremes {
                    None => (i, i),
                    Some((lo, hi)) => {
                        (if column[i] < column[lo] { i } else { lo }, if column[i] > column[hi] { i } else { hi })
                    }
                });
            }
            if let Some((lo, hi)) = extremes {
                keep.extend([lo, hi]);
            }
        }
    }
    keep.sort_unstable();
    keep.dedup();
    keep
}

/// The elements of `values` at `indices`.
pub fn pick<T: Copy>(values: &[T], indices: &[usize]) -> Vec<T> {
    indices.iter().filter_map(|&i| values.get(i).copied()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_series_are_kept_whole() {
        assert_eq!(keep_extremes(&[&[1.0, 2.0, 3.0]], 10), [0, 1, 2]);
        assert!(keep_extremes(&[&[]], 10).is_empty());
    }

    #[test]
    fn a_single_spike_in_a_million_samples_survives() {
        let mut a = vec![0.0; 1_000_000];
        a[654_321] = 5.0;
        let mut b = vec![1.0; 1_000_000];
        b[10] = -3.0;
        let keep = keep_extremes(&[&a, &b], 2_000);
        assert!(keep.len() <= 2_002, "{} kept", keep.len());
        assert!(keep.contains(&654_321) && keep.contains(&10));
        assert_eq!((keep[0], *keep.last().unwrap()), (0, 999_999));
        assert!(keep.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(pick(&a, &keep).iter().copied().fold(f64::MIN, f64::max), 5.0);
    }

    #[test]
    fn non_finite_values_are_not_extremes() {
        let mut a: Vec<f64> = (0..1000).map(|i| (i % 7) as f64).collect();
        a[500] = f64::NAN;
        a[501] = f64::INFINITY;
        let keep = keep_extremes(&[&a], 100);
        assert!(!keep.contains(&500) && !keep.contains(&501));
    }
}
