//! Small statistics shared by the registration's steps.

/// The median of a list, the upper middle for an even count; None when empty.
pub(crate) fn upper_median(mut v: Vec<f64>) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied()
}
