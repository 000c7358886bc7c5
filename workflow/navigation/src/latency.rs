//! The time offset between the IMU's and the GNSS's time tags. A unit that low-pass filters its rates and
//! accelerations before tagging them, or a logger that stamps packets on arrival, hands the filter IMU data
//! some tens of milliseconds late. A constant velocity hides the offset (the drive is only shifted along
//! itself), but every change of speed or heading then happens at the wrong time against the fixes: at
//! 8 m/s and 2 m/s² an offset of 65 ms is 0.1–0.5 m of innovation per fix, all of it along the changes of
//! motion, and the tests read it as faults. On KITTI (OXTS RT 3003) the offset is 65 ms.
//!
//! The offset is measured from the data: the innovations' summed statistic vᵀC⁻¹v (each capped at the
//! local test's 99.9 % value, so faults weigh no more than a flagged fix) as a function of the offset,
//! searched on a grid over ±[`SEARCH`] s and refined by golden section. The offset is taken only when two
//! tests agree:
//! - the sum is −2 log-likelihood up to terms the offset barely moves, so it must fall by more than χ²₁ at
//!   99.9 % (a likelihood-ratio test with one parameter; a drive at constant velocity cannot tell);
//! - that test assumes independent fixes, and multipath makes them anything but (on a simulated street
//!   canyon it finds a "significant" 21 ms where there is none). A real offset is the same all drive long,
//!   so the drive is cut into [`SEGMENTS`] parts by fix count, each part's own best offset is read from the
//!   same passes, and their mean must stand out of their scatter (Student's t with four degrees of freedom
//!   at 99 %, two-sided).
//!
//! The offset is expressed as the IMU's lag: IMU time − GNSS time of the same instant. The GNSS time is
//! kept as the reference (mapping sensors are usually stamped in it), so a caller moves the IMU's time tags
//! back by the offset ([`shift_samples`]).

use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::chi2::chi2_critical;
use crate::config::{InitialState, NavConfig};
use crate::filter::run_once;
use crate::inputs::{GnssFix, ImuSample};
use crate::passes::prepare;

/// Largest offset searched, s.
pub const SEARCH: f64 = 0.3;
/// Grid step of the coarse search, s.
const GRID: f64 = 0.05;
/// Width of the bracket the golden section stops at, s.
const RESOLUTION: f64 = 0.002;
/// Fewest fixes with an innovation for a measurement.
const ENOUGH: usize = 20;
/// Significance of each statistic's cap and of the likelihood-ratio test.
const ALPHA: f64 = 0.001;
/// Parts of the drive whose offsets must agree.
pub const SEGMENTS: usize = 5;
/// Student's t with `SEGMENTS` − 1 = 4 degrees of freedom, two-sided 99 %.
pub const T_CRITICAL: f64 = 4.604;

/// What [`measure_time_offset`] found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct TimeOffsetMeasurement {
    /// IMU time − GNSS time of the same instant, s (zero when not significant).
    pub offset: f64,
    /// The best offset found, whether significant or not, s.
    pub best: f64,
    /// Summed capped statistic with no offset.
    pub cost_at_zero: f64,
    /// Summed capped statistic at the best offset.
    pub cost: f64,
    /// The likelihood-ratio test's critical decrease (χ²₁ at 99.9 %).
    pub critical: f64,
    /// Each part's own best offset, s, in time order.
    pub segments: Vec<f64>,
    /// The parts' mean over its standard error (Student's t; infinite when they agree exactly).
    pub t: f64,
    /// Fixes with an innovation.
    pub fixes: usize,
    /// Whether the best offset lies on the edge of the search (then `offset` is zero: the data fit no
    /// offset within ±0.3 s).
    pub at_edge: bool,
}

impl TimeOffsetMeasurement {
    /// Whether both tests took the offset.
    pub fn significant(&self) -> bool {
        self.offset != 0.0
    }
}

/// One evaluated offset: the summed capped statistic per part.
struct Evaluation {
    offset: f64,
    parts: [f64; SEGMENTS],
}

/// Measure the IMU's time offset against the GNSS with `config`'s model (gap noise included, no
/// re-linearisation); `None` when fewer than 20 fixes fall within the IMU's span.
pub fn measure_time_offset(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    initial: &InitialState,
    config: &NavConfig,
) -> Result<Option<TimeOffsetMeasurement>, NavError> {
    let gaps = prepare(imu, initial, config)?;
    let cap = chi2_critical(3.0, ALPHA);
    let mut shifted = gnss.to_vec();
    let mut evaluations: Vec<Evaluation> = Vec::new();
    // The fixes are moved forward by the offset: the same as the IMU moved back, without re-aligning.
    let mut cost = |offset: f64| {
        for (s, f) in shifted.iter_mut().zip(gnss) {
            s.time = f.time + offset;
        }
        let pass = run_once(imu, &shifted, initial, config, None, &[], gaps.clone(), &[]);
        let mut parts = [0.0; SEGMENTS];
        for i in &pass.innovations {
            let s = i.statistic();
            if s.is_finite() {
                parts[(i.fix * SEGMENTS / gnss.len().max(1)).min(SEGMENTS - 1)] += s.min(cap);
            }
        }
        let total = parts.iter().sum();
        evaluations.push(Evaluation { offset, parts });
        (total, pass.innovations.len())
    };
    let (at_zero, fixes) = cost(0.0);
    if fixes < ENOUGH {
        return Ok(None);
    }
    let steps = (SEARCH / GRID).round() as i32;
    let (mut best, mut best_cost) = (0.0, at_zero);
    for i in (-steps..=steps).filter(|&i| i != 0) {
        let offset = f64::from(i) * GRID;
        let (c, _) = cost(offset);
        if c < best_cost {
            (best, best_cost) = (offset, c);
        }
    }
    // Golden section in the grid cell either side of the best node.
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = ((best - GRID).max(-SEARCH), (best + GRID).min(SEARCH));
    let mut a = hi - ratio * (hi - lo);
    let mut b = lo + ratio * (hi - lo);
    let (mut ca, mut cb) = (cost(a).0, cost(b).0);
    while hi - lo > RESOLUTION {
        if ca < cb {
            hi = b;
            (b, cb) = (a, ca);
            a = hi - ratio * (hi - lo);
            ca = cost(a).0;
        } else {
            lo = a;
            (a, ca) = (b, cb);
            b = lo + ratio * (hi - lo);
            cb = cost(b).0;
        }
    }
    let (refined, refined_cost) = if ca < cb { (a, ca) } else { (b, cb) };
    if refined_cost < best_cost {
        (best, best_cost) = (refined, refined_cost);
    }
    // Each part's best among the offsets evaluated (dense near the overall best, where it matters).
    let segments: Vec<f64> = (0..SEGMENTS)
        .map(|p| evaluations.iter().min_by(|x, y| x.parts[p].total_cmp(&y.parts[p])).map_or(0.0, |e| e.offset))
        .collect();
    let n = SEGMENTS as f64;
    let mean = segments.iter().sum::<f64>() / n;
    let var = segments.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let t = if var > 0.0 { mean.abs() / (var / n).sqrt() } else { f64::INFINITY };
    let at_edge = best.abs() > SEARCH - GRID / 2.0;
    let critical = chi2_critical(1.0, ALPHA);
    let significant = !at_edge && at_zero - best_cost > critical && t > T_CRITICAL;
    Ok(Some(TimeOffsetMeasurement {
        offset: if significant { best } else { 0.0 },
        best,
        cost_at_zero: at_zero,
        cost: best_cost,
        critical,
        segments,
        t,
        fixes,
        at_edge,
    }))
}

/// Move the IMU's time tags back by `offset` (IMU time − GNSS time), so that they read GNSS time.
pub fn shift_samples(imu: &mut [ImuSample], offset: f64) {
    for s in imu {
        s.time -= offset;
    }
}
