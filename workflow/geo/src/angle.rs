//! Angles: the one wrapping rule every crate uses.

use std::f64::consts::{PI, TAU};

/// `a` wrapped into (−π, π]: the signed difference of two headings, a heading change, an angle error.
pub fn wrap(a: f64) -> f64 {
    let t = a.rem_euclid(TAU);
    if t > PI { t - TAU } else { t }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_into_the_half_open_interval() {
        assert_eq!(wrap(0.0), 0.0);
        assert_eq!(wrap(PI), PI);
        assert!((wrap(-PI) - PI).abs() < 1e-15);
        assert!((wrap(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((wrap(-5.0 * TAU + 0.25) - 0.25).abs() < 1e-12);
        assert!((wrap(7.0 * TAU - 0.25) + 0.25).abs() < 1e-12);
        for k in -20..=20 {
            let a = 0.37 * f64::from(k);
            let w = wrap(a);
            assert!(w > -PI && w <= PI, "{a} -> {w}");
            assert!(((a - w) / TAU - ((a - w) / TAU).round()).abs() < 1e-9, "{a} -> {w}");
        }
    }
}
