//! Quality measures used everywhere (tests, benchmarks, reports): along-track, cross-track and height
//! differences of a trajectory against a reference, summarised as median / 95 % / 99 % / max of the absolute
//! differences (Meyer et al. 2023 §3.5, Tables 3–7), plus 2D and 3D RMSE.
//!
//! Differences are time-matched: the reference is interpolated (cubic) at each estimate epoch, and the
//! difference estimate − reference is split along the reference's horizontal direction of travel
//! (along-track, positive forward), across it (cross-track, positive to the right of travel) and vertically.
//! At standstill (reference speed below 0.2 m/s) the direction of travel is the reference heading.

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::trajectory::{PositionInterpolation, Trajectory};

/// Summary statistics of absolute differences (metres).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Stats {
    /// Number of values.
    pub count: usize,
    /// Median of |d|.
    pub median: f64,
    /// 95 % quantile of |d|.
    pub p95: f64,
    /// 99 % quantile of |d|.
    pub p99: f64,
    /// Maximum of |d|.
    pub max: f64,
    /// Root mean square of d.
    pub rms: f64,
}

/// Quantile `q` in [0, 1] of sorted values, linear between order statistics (Hyndman–Fan type 7, the
/// default of R and NumPy). `None` for an empty slice.
pub fn quantile_sorted(sorted: &[f64], q: f64) -> Option<f64> {
    let last = sorted.len().checked_sub(1)?;
    let h = q.clamp(0.0, 1.0) * last as f64;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(last);
    Some(sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo]))
}

/// Quantile `q` in [0, 1] of unsorted values, type 7 as [`quantile_sorted`]; sorts `values` in place
/// (`f64::total_cmp`: filter out NaN first if the values may hold any). `None` for an empty slice.
pub fn quantile(values: &mut [f64], q: f64) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    quantile_sorted(values, q)
}

/// Median of unsorted values: the 0.5 quantile of [`quantile`], i.e. the middle value, or the mean of the
/// two middle values for an even count. Reorders `values` (a selection, linear time; `f64::total_cmp`).
/// `None` for an empty slice. This is the project's one median: every "median" in code and reports means
/// this.
pub fn median(values: &mut [f64]) -> Option<f64> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let (lower, upper, _) = values.select_nth_unstable_by(n / 2, f64::total_cmp);
    let upper = *upper;
    if n % 2 == 1 {
        return Some(upper);
    }
    let below = lower.iter().copied().max_by(f64::total_cmp).unwrap_or(upper);
    Some(0.5 * (below + upper))
}

impl Stats {
    /// Summarise signed differences (statistics of their absolute values; RMS of the values).
    /// Non-finite values are ignored.
    pub fn of(values: &[f64]) -> Self {
        let mut abs: Vec<f64> = values.iter().filter(|v| v.is_finite()).map(|v| v.abs()).collect();
        abs.sort_by(f64::total_cmp);
        let q = |p| quantile_sorted(&abs, p).unwrap_or(f64::NAN);
        let rms =
            if abs.is_empty() { f64::NAN } else { (abs.iter().map(|v| v * v).sum::<f64>() / abs.len() as f64).sqrt() };
        Self { count: abs.len(), median: q(0.5), p95: q(0.95), p99: q(0.99), max: q(1.0), rms }
    }
}

/// Per-epoch differences of an estimate against a reference.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Differences {
    /// Epoch times (those of the estimate that fall inside the reference span).
    pub time: Vec<f64>,
    /// Along-track differences, metres (positive: estimate ahead).
    pub along: Vec<f64>,
    /// Cross-track differences, metres (positive: estimate to the right of travel).
    pub cross: Vec<f64>,
    /// Height differences, metres (positive: estimate above).
    pub height: Vec<f64>,
}

/// The comparison of a trajectory against a reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Comparison {
    /// Along-track statistics.
    pub along: Stats,
    /// Cross-track statistics.
    pub cross: Stats,
    /// Height statistics.
    pub height: Stats,
    /// Horizontal RMSE, metres.
    pub rmse_2d: f64,
    /// 3D RMSE, metres.
    pub rmse_3d: f64,
    /// Estimate epochs outside the reference's time span (not compared).
    pub outside_reference: usize,
    /// The per-epoch series.
    pub differences: Differences,
}

/// Errors of [`compare`].
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CompareError {
    /// No estimate epoch lies within the reference's time span.
    #[error("no epoch of the estimate lies within the reference's time span [{start}, {end}]")]
    NoOverlap { start: f64, end: f64 },
}

/// Speed below which the reference heading replaces the direction of travel, m/s.
const STANDSTILL_SPEED: f64 = 0.2;

/// Compare `estimate` against `reference`, time-matched (see the module docs).
pub fn compare(estimate: &Trajectory, reference: &Trajectory) -> Result<Comparison, CompareError> {
    let mut d = Differences::default();
    let mut outside = 0;
    for rec in estimate.records() {
        let Ok(r) = reference.interpolate(rec.time, PositionInterpolation::Cubic) else {
            outside += 1;
            continue;
        };
        let (tx, ty) = travel_direction(reference, rec.time, r.attitude.heading);
        let delta = rec.position - r.position;
        d.time.push(rec.time);
        d.along.push(delta.x() * tx + delta.y() * ty);
        d.cross.push(delta.x() * ty - delta.y() * tx);
        d.height.push(delta.z());
    }
    if d.time.is_empty() {
        let (start, end) = reference.span();
        return Err(CompareError::NoOverlap { start, end });
    }
    let n = d.time.len() as f64;
    let sum2: f64 = d.along.iter().zip(&d.cross).map(|(a, c)| a * a + c * c).sum();
    let sum_h: f64 = d.height.iter().map(|h| h * h).sum();
    Ok(Comparison {
        along: Stats::of(&d.along),
        cross: Stats::of(&d.cross),
        height: Stats::of(&d.height),
        rmse_2d: (sum2 / n).sqrt(),
        rmse_3d: ((sum2 + sum_h) / n).sqrt(),
        outside_reference: outside,
        differences: d,
    })
}

/// Unit horizontal direction of travel of the reference at `t` (east, north components).
fn travel_direction(reference: &Trajectory, t: f64, heading: f64) -> (f64, f64) {
    let (start, end) = reference.span();
    let h = 0.25;
    let (t0, t1) = ((t - h).max(start), (t + h).min(end));
    let at = |t| reference.interpolate(t, PositionInterpolation::Linear).ok().map(|r| r.position);
    if let (Some(a), Some(b)) = (at(t0), at(t1)) {
        let (dx, dy) = (b.x() - a.x(), b.y() - a.y());
        let dist = dx.hypot(dy);
        if t1 > t0 && dist / (t1 - t0) >= STANDSTILL_SPEED {
            return (dx / dist, dy / dist);
        }
    }
    // Heading is clockwise from north: direction (sin ψ, cos ψ) in east-north.
    (heading.sin(), heading.cos())
}

impl Comparison {
    /// The table of Meyer et al. 2023 (median, 95 %, 99 %, max of |d| per component) with RMSE, as aligned text.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ =
            writeln!(s, "{:<12} {:>8} {:>8} {:>8} {:>8} {:>8}", "difference", "median", "q95%", "q99%", "max", "rms");
        for (name, st) in [("along-track", &self.along), ("cross-track", &self.cross), ("height", &self.height)] {
            let _ = writeln!(
                s,
                "{name:<12} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3}",
                st.median, st.p95, st.p99, st.max, st.rms
            );
        }
        let _ = writeln!(
            s,
            "epochs {}  (outside reference: {})  RMSE 2D {:.3} m  3D {:.3} m",
            self.along.count, self.outside_reference, self.rmse_2d, self.rmse_3d
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Attitude;
    use crate::frames::Point3;
    use crate::trajectory::{TrajectoryRecord, ValidationLimits};

    fn traj(points: &[(f64, f64, f64, f64)], heading_deg: f64) -> Trajectory {
        let records = points
            .iter()
            .map(|&(t, e, n, h)| TrajectoryRecord {
                time: t,
                position: Point3::new(e, n, h),
                attitude: Attitude::from_degrees(0.0, 0.0, heading_deg),
                std: None,
            })
            .collect();
        Trajectory::new(records, &ValidationLimits::default()).unwrap()
    }

    #[test]
    fn quantiles_are_type_7() {
        let v: Vec<f64> = (1..=10).map(f64::from).collect();
        assert_eq!(quantile_sorted(&v, 0.5), Some(5.5));
        assert!((quantile_sorted(&v, 0.95).unwrap() - 9.55).abs() < 1e-12);
        assert!((quantile_sorted(&v, 0.99).unwrap() - 9.91).abs() < 1e-12);
        assert_eq!(quantile_sorted(&v, 1.0), Some(10.0));
        assert_eq!(quantile_sorted(&[], 0.5), None);
    }

    #[test]
    fn median_sorts_and_averages_the_middle_pair() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median(&mut []), None);
        assert_eq!(median(&mut [7.0, -1.0, 7.0, 2.0, 9.0, 3.0]), Some(5.0));
        assert_eq!(quantile(&mut [5.0, 1.0, 3.0], 1.0), Some(5.0));
    }

    #[test]
    fn differences_split_along_and_across_travel_to_the_east() {
        // Reference drives east at 10 m/s; the estimate is 1 m ahead, 0.5 m north (= left) and 0.2 m high.
        let reference: Vec<_> = (0..11).map(|i| (f64::from(i), 10.0 * f64::from(i), 0.0, 5.0)).collect();
        let estimate: Vec<_> = (0..11).map(|i| (f64::from(i), 10.0 * f64::from(i) + 1.0, 0.5, 5.2)).collect();
        let c = compare(&traj(&estimate, 90.0), &traj(&reference, 90.0)).unwrap();
        for i in 0..11 {
            assert!((c.differences.along[i] - 1.0).abs() < 1e-9);
            assert!((c.differences.cross[i] + 0.5).abs() < 1e-9, "left of travel is negative");
            assert!((c.differences.height[i] - 0.2).abs() < 1e-9);
        }
        assert!((c.rmse_2d - 1.25f64.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn standstill_uses_the_reference_heading() {
        // Parked facing north; estimate 0.3 m east = right of the heading.
        let reference = traj(&[(0.0, 0.0, 0.0, 0.0), (10.0, 0.0, 0.0, 0.0)], 0.0);
        let estimate = traj(&[(5.0, 0.3, 0.0, 0.0)], 0.0);
        let c = compare(&estimate, &reference).unwrap();
        assert!((c.differences.cross[0] - 0.3).abs() < 1e-12);
        assert!(c.differences.along[0].abs() < 1e-12);
    }

    #[test]
    fn hand_checked_table() {
        // Reference north at 1 m/s for 20 s; cross-track offsets 0.00, 0.01, …, 0.19 m (east = right).
        let reference: Vec<_> = (0..=20).map(|i| (f64::from(i), 0.0, f64::from(i), 0.0)).collect();
        let estimate: Vec<_> = (0..20).map(|i| (f64::from(i), 0.01 * f64::from(i), f64::from(i), 0.0)).collect();
        let c = compare(&traj(&estimate, 0.0), &traj(&reference, 0.0)).unwrap();
        // Sorted |d| = 0.00..0.19: median (0.09 + 0.10)/2; q95 at h = 18.05 → 0.1805; q99 at 18.81 → 0.1881.
        assert!((c.cross.median - 0.095).abs() < 1e-9);
        assert!((c.cross.p95 - 0.1805).abs() < 1e-9);
        assert!((c.cross.p99 - 0.1881).abs() < 1e-9);
        assert!((c.cross.max - 0.19).abs() < 1e-9);
        assert_eq!(c.along.max, 0.0);
        let table = c.table();
        let line = table.lines().find(|l| l.starts_with("cross-track")).unwrap();
        assert!(line.contains("0.095") && line.contains("0.188") && line.contains("0.190"), "{table}");
    }

    #[test]
    fn epochs_outside_the_reference_are_counted_not_compared() {
        let reference = traj(&[(0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 1.0, 0.0)], 0.0);
        let estimate = traj(&[(0.5, 0.0, 0.5, 0.0), (2.0, 0.0, 2.0, 0.0)], 0.0);
        let c = compare(&estimate, &reference).unwrap();
        assert_eq!((c.along.count, c.outside_reference), (1, 1));
        let far = traj(&[(5.0, 0.0, 0.0, 0.0)], 0.0);
        assert!(matches!(compare(&far, &reference), Err(CompareError::NoOverlap { .. })));
    }
}
