//! DG jumps seen in the DG's own motion, wherever they happen. A road vehicle moves along its heading (the
//! non-holonomic constraint: no sideways velocity, paper 001 §2's land-vehicle motion model); a multipath jump
//! shifts the DG position within about a second (paper 001 §1.2) without turning the vehicle, so its
//! cross-track part shows up as sideways motion of the DG. Where that sideways displacement exceeds
//! `threshold` per `step`, the correction gets nodes every `step` (so a jump the consistency check did not
//! flag — before the first panorama, in a stop, between control — has short links of its own), and with
//! `widen` those links' position σ grows by the sideways displacement as inside flagged intervals
//! ([`crate::JumpLocalization`]) and the span counts as a DG break for the prior's floor
//! ([`crate::FaultPrior`]). The along-track part of a jump is not separable from braking and accelerating
//! this way (a 0.2 m jump needs no more acceleration than driving does); it is left to the consistency check
//! and to jump detection on the chain ([`crate::JumpDetection`]).

use nalgebra::Vector6;
use plumbline_geo::Trajectory;
use plumbline_geo::trajectory::PositionInterpolation;
use serde::{Deserialize, Serialize};

/// Settings of the search for DG jumps in the DG's own motion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct KinematicJumps {
    /// Node spacing over an anomalous span, seconds.
    pub step: f64,
    /// Sideways displacement per `step` above which a span gets nodes, metres.
    pub threshold: f64,
    /// Widen the links of anomalous spans by their sideways displacement d: σ² = σ_DG² + (anomaly_scale · d)²,
    /// and count the spans as DG breaks.
    pub widen: bool,
    /// σ added per metre of sideways displacement when widening.
    pub anomaly_scale: f64,
}

impl Default for KinematicJumps {
    fn default() -> Self {
        Self { step: 0.2, threshold: 0.01, widen: true, anomaly_scale: 2.0 }
    }
}

/// The DG's sideways motion sampled every `h` seconds from `start`.
struct Samples {
    start: f64,
    h: f64,
    /// Sideways displacement of each sample interval (to the right of the heading), metres.
    lateral: Vec<f64>,
}

impl Samples {
    fn new(trajectory: &Trajectory, (t0, t1): (f64, f64), c: &KinematicJumps) -> Option<Self> {
        let h = (c.step / 4.0).max(1e-3);
        let count = ((t1 - t0) / h).floor() as usize;
        let at = |t: f64| trajectory.interpolate(t, PositionInterpolation::Linear).ok();
        let records: Vec<_> = (0..=count).map(|i| at(t0 + i as f64 * h)).collect::<Option<_>>()?;
        // The displacement across the mean heading (clockwise from north: right = (cos ψ, −sin ψ)).
        let lateral = records
            .windows(2)
            .map(|w| {
                let d = w[1].position.p - w[0].position.p;
                let psi = w[0].attitude.heading + 0.5 * wrap(w[1].attitude.heading - w[0].attitude.heading);
                let (s, c) = psi.sin_cos();
                d.x * c - d.y * s
            })
            .collect();
        Some(Self { start: t0, h, lateral })
    }

    /// |Σ sideways displacement| over [a, b).
    fn anomaly(&self, a: f64, b: f64) -> f64 {
        let index = |t: f64| (((t - self.start) / self.h).round().max(0.0) as usize).min(self.lateral.len());
        self.lateral[index(a)..index(b).max(index(a))].iter().sum::<f64>().abs()
    }
}

/// The anomalous spans of the trajectory and their node epochs (every `step` over each span, its ends
/// included), ready for [`crate::nodes::Nodes::new`].
pub(crate) fn anomalous_spans(trajectory: &Trajectory, c: &KinematicJumps) -> Vec<(f64, f64)> {
    let span = trajectory.span();
    if !(c.step > 0.0 && c.threshold > 0.0) || span.1 - span.0 < 2.0 * c.step {
        return Vec::new();
    }
    let Some(samples) = Samples::new(trajectory, span, c) else {
        return Vec::new();
    };
    let steps = ((span.1 - span.0) / c.step).floor() as usize;
    let marked: Vec<bool> = (0..steps)
        .map(|j| {
            let a = span.0 + j as f64 * c.step;
            samples.anomaly(a, a + c.step) > c.threshold
        })
        .collect();
    // Runs of marked steps (gaps of one step bridged), padded by one step on either side.
    let mut out: Vec<(usize, usize)> = Vec::new();
    for j in (0..steps).filter(|j| marked[*j]) {
        let (lo, hi) = (j.saturating_sub(1), (j + 2).min(steps));
        match out.last_mut() {
            Some(last) if lo <= last.1 + 1 => last.1 = hi,
            _ => out.push((lo, hi)),
        }
    }
    out.into_iter().map(|(a, b)| (span.0 + a as f64 * c.step, span.0 + b as f64 * c.step)).collect()
}

/// The node epochs inside the anomalous spans (every `step`).
pub(crate) fn span_nodes(spans: &[(f64, f64)], c: &KinematicJumps) -> Vec<f64> {
    let step = c.step;
    let inner = move |&(a, b): &(f64, f64)| {
        let n = ((b - a) / step).round() as usize;
        (0..=n).map(move |i| a + i as f64 * step)
    };
    spans.iter().flat_map(inner).collect()
}

/// Widen the position σ of the links inside the anomalous spans by their anomalous DG displacement.
pub(crate) fn widen(
    relative: &mut [Vector6<f64>],
    times: &[f64],
    trajectory: &Trajectory,
    spans: &[(f64, f64)],
    c: &KinematicJumps,
) {
    for &(a, b) in spans {
        let k0 = times.partition_point(|t| *t < a - 1e-9);
        let k1 = times.partition_point(|t| *t <= b + 1e-9);
        if k1 <= k0 + 1 {
            continue;
        }
        let Some(samples) = Samples::new(trajectory, (a, b.min(trajectory.span().1)), c) else {
            continue;
        };
        for k in k0..k1 - 1 {
            let anomaly = samples.anomaly(times[k], times[k + 1]);
            for s in relative[k].iter_mut().take(3) {
                *s = s.hypot(c.anomaly_scale * anomaly);
            }
        }
    }
}

/// An angle in (−π, π].
fn wrap(a: f64) -> f64 {
    crate::model::wrap(a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::{Attitude, Point3, TrajectoryRecord, ValidationLimits};

    fn smoothstep(x: f64) -> f64 {
        let x = x.clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    }

    /// 60 s at 50 Hz: a left turn of 90° on a 20 m radius at 8 m/s from 10 s, braking at 1 m/s² from 34 s to
    /// a stop at 42 s; sideways jumps rising over 1 s: 0.2 m north at 20 s (driving west at 8 m/s) and 0.4 m
    /// south at 45 s (standing).
    fn drive() -> Trajectory {
        let records = (0..3000)
            .map(|i| {
                let t = i as f64 * 0.02;
                let (x, y, heading) = path(t);
                let jump = 0.2 * smoothstep(t - 20.0) - 0.4 * smoothstep(t - 45.0);
                let p = Point3::new(1000.0 + x, 2000.0 + y + jump, 50.0);
                TrajectoryRecord { time: t, position: p, attitude: Attitude::new(0.0, 0.0, heading), std: None }
            })
            .collect();
        Trajectory::new(records, &ValidationLimits::default()).unwrap()
    }

    /// East, north and heading of the true path: north at 8 m/s, a quarter turn left, then west and braking.
    fn path(t: f64) -> (f64, f64, f64) {
        let (v, r) = (8.0, 20.0);
        let turn = std::f64::consts::FRAC_PI_2 * r / v;
        if t < 10.0 {
            return (0.0, v * t, 0.0);
        }
        if t < 10.0 + turn {
            let a = v * (t - 10.0) / r;
            return (r * (a.cos() - 1.0), 80.0 + r * a.sin(), -a);
        }
        let u = t - 10.0 - turn;
        let s = if u < 20.0 { v * u } else { v * 20.0 + (v * (u - 20.0) - 0.5 * (u - 20.0).powi(2)).max(0.0) };
        let s = if u >= 28.0 { v * 20.0 + 32.0 } else { s };
        (-r - s, 100.0, -std::f64::consts::FRAC_PI_2)
    }

    #[test]
    fn jumps_are_anomalous_and_turns_and_braking_are_not() {
        let c = KinematicJumps::default();
        let spans = anomalous_spans(&drive(), &c);
        let hit = |t: f64| spans.iter().any(|(a, b)| *a <= t && t <= *b);
        assert!(hit(20.5) && hit(45.5), "{spans:?}");
        // Only the two jumps: 1 s rises plus padding each.
        assert_eq!(spans.len(), 2, "{spans:?}");
        assert!(spans.iter().all(|(a, b)| b - a < 2.0), "{spans:?}");
    }
}
