//! DG jumps seen in the DG's own motion, wherever they happen. A road vehicle moves along its heading (the
//! non-holonomic constraint: no sideways velocity, the land-vehicle motion model of Cazzaniga et al. 2007 §2) — up to
//! the drive's crab angle, the heading's misalignment with the direction of travel, estimated robustly over the
//! drive and subtracted ([`crate::vehicle::crab_angle`]); a multipath jump shifts the DG position within
//! about a second (Cazzaniga et al. 2007 §1.2) without turning the vehicle, so its cross-track part shows up as
//! sideways motion of the DG beyond the crab. Where that sideways displacement exceeds `threshold` per `step`, the
//! correction gets nodes every `step` (so a jump the consistency check did not flag — before the first
//! panorama, in a stop, between control — has short links of its own), and with `widen` those links follow
//! the vehicle's kinematics instead of the DG (mean −e of the sideways displacement e, σ widened by |e|, as
//! inside flagged intervals: [`crate::JumpLocalizationConfig`]) and the span counts as a DG break for the prior's
//! floor ([`crate::FaultPriorConfig`]). The along-track part of a jump is not separable from braking and
//! accelerating this way (a 0.2 m jump needs no more acceleration than driving does); it is left to the
//! consistency check and to jump detection on the chain ([`crate::JumpDetectionConfig`]).

use crate::config::KinematicJumpConfig;
use crate::vehicle::{Motion, crab_angle};
use nalgebra::{Vector3, Vector6};
use plumbline_geo::Trajectory;

/// The DG's sideways motion beyond the crab angle, sampled every `step / 4`.
struct Samples {
    motion: Motion,
    /// tan(crab angle): the sideways displacement per metre along the heading that is not a jump.
    crab: f64,
}

impl Samples {
    fn new(trajectory: &Trajectory, span: (f64, f64), c: &KinematicJumpConfig, crab: f64) -> Option<Self> {
        let motion = Motion::sample(trajectory, span, (c.step / 4.0).max(1e-3))?;
        Some(Self { motion, crab: crab.tan() })
    }

    /// The sideways displacement of sample interval i beyond the crab, metres (to the right).
    fn lateral(&self, i: usize) -> f64 {
        // Land-vehicle model (Cazzaniga et al. 2007 §2): sideways displacement = tan(crab) · along-track displacement.
        self.motion.across[i] - self.crab * self.motion.along[i]
    }

    /// The sideways displacement over [a, b) as an east, north, up vector.
    fn anomaly(&self, a: f64, b: f64) -> Vector3<f64> {
        let (i0, i1) = (self.motion.index(a), self.motion.index(b));
        (i0..i1.max(i0)).map(|i| self.motion.to_world(i, 0.0, self.lateral(i), 0.0)).sum()
    }
}

/// The DG's kinematic anomalies: the crab angle of the drive and the spans where the DG moves sideways.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Anomalies {
    /// The crab angle, radians (0 when not estimated).
    pub crab: f64,
    /// The anomalous spans, seconds.
    pub spans: Vec<(f64, f64)>,
}

/// The crab angle and the anomalous spans of the trajectory, ready for [`span_nodes`].
pub(crate) fn anomalous_spans(trajectory: &Trajectory, c: &KinematicJumpConfig) -> Anomalies {
    let span = trajectory.span();
    if !(c.step > 0.0 && c.threshold > 0.0) || span.1 - span.0 < 2.0 * c.step {
        return Anomalies::default();
    }
    let Some(mut samples) = Samples::new(trajectory, span, c, 0.0) else {
        return Anomalies::default();
    };
    let crab = if c.crab { crab_angle(&samples.motion).unwrap_or(0.0) } else { 0.0 };
    samples.crab = crab.tan();
    let steps = ((span.1 - span.0) / c.step).floor() as usize;
    let marked: Vec<bool> = (0..steps)
        .map(|j| {
            let a = span.0 + j as f64 * c.step;
            samples.anomaly(a, a + c.step).norm() > c.threshold
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
    let spans = out.into_iter().map(|(a, b)| (span.0 + a as f64 * c.step, span.0 + b as f64 * c.step)).collect();
    Anomalies { crab, spans }
}

/// The node epochs inside the anomalous spans (every `step`).
pub(crate) fn span_nodes(spans: &[(f64, f64)], c: &KinematicJumpConfig) -> Vec<f64> {
    let step = c.step;
    let inner = move |&(a, b): &(f64, f64)| {
        let n = ((b - a) / step).round() as usize;
        (0..=n).map(move |i| a + i as f64 * step)
    };
    spans.iter().flat_map(inner).collect()
}

/// Inside the anomalous spans, let the links follow the vehicle's kinematics instead of the DG's sideways
/// motion: the correction's increment over a link is expected to cancel the sideways displacement e there
/// (`mean` = −e, east/north/up), with σ² = σ_DG² + (anomaly_scale · |e|)² for what the control must settle.
pub(crate) fn widen(
    relative: &mut [Vector6<f64>],
    mean: &mut [Vector3<f64>],
    times: &[f64],
    trajectory: &Trajectory,
    anomalies: &Anomalies,
    c: &KinematicJumpConfig,
) {
    for &(a, b) in &anomalies.spans {
        let k0 = times.partition_point(|t| *t < a - 1e-9);
        let k1 = times.partition_point(|t| *t <= b + 1e-9);
        if k1 <= k0 + 1 {
            continue;
        }
        let Some(samples) = Samples::new(trajectory, (a, b.min(trajectory.span().1)), c, anomalies.crab) else {
            continue;
        };
        for k in k0..k1 - 1 {
            let e = samples.anomaly(times[k], times[k + 1]);
            mean[k] = -e;
            for s in relative[k].iter_mut().take(3) {
                *s = s.hypot(c.anomaly_scale * e.norm());
            }
        }
    }
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
        drive_with(0.0, true)
    }

    /// [`drive`] with the heading reading `crab` radians left of the direction of travel (a misaligned IMU),
    /// with or without the jumps.
    fn drive_with(crab: f64, jumps: bool) -> Trajectory {
        let records = (0..3000)
            .map(|i| {
                let t = i as f64 * 0.02;
                let (x, y, heading) = path(t);
                let jump = if jumps { 0.2 * smoothstep(t - 20.0) - 0.4 * smoothstep(t - 45.0) } else { 0.0 };
                let p = Point3::new(1000.0 + x, 2000.0 + y + jump, 50.0);
                let attitude = Attitude::new(0.0, 0.0, heading - crab);
                TrajectoryRecord { time: t, position: p, attitude, std: None }
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
        let c = KinematicJumpConfig::default();
        let spans = anomalous_spans(&drive(), &c).spans;
        let hit = |t: f64| spans.iter().any(|(a, b)| *a <= t && t <= *b);
        assert!(hit(20.5) && hit(45.5), "{spans:?}");
        // Only the two jumps: 1 s rises plus padding each.
        assert_eq!(spans.len(), 2, "{spans:?}");
        assert!(spans.iter().all(|(a, b)| b - a < 2.0), "{spans:?}");
    }

    #[test]
    fn a_misaligned_heading_is_not_a_jump_and_jumps_are_still_found_beside_it() {
        let c = KinematicJumpConfig::default();
        for degrees in [1.0f64, 2.0] {
            let crab = degrees.to_radians();
            let clean = anomalous_spans(&drive_with(crab, false), &c);
            assert!((clean.crab - crab).abs() < 1e-3, "{degrees}°: {}", clean.crab.to_degrees());
            assert!(clean.spans.is_empty(), "{degrees}°: {:?}", clean.spans);
            // Taking the heading as the direction of travel, every moving step looks like a jump.
            let naive = anomalous_spans(&drive_with(crab, false), &KinematicJumpConfig { crab: false, ..c });
            let marked: f64 = naive.spans.iter().map(|(a, b)| b - a).sum();
            assert!(marked > 30.0, "{degrees}°: {marked} s marked");
            let jumps = anomalous_spans(&drive_with(crab, true), &c).spans;
            let hit = |t: f64| jumps.iter().any(|(a, b)| *a <= t && t <= *b);
            assert!(hit(20.5) && hit(45.5) && jumps.len() == 2, "{degrees}°: {jumps:?}");
        }
    }
}
