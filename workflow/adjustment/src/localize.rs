//! Where inside a flagged interval the DG jumped. The consistency check flags a whole pair of panoramas
//! (seconds long at low speed) but a multipath jump rises within about a second; weakening the chain evenly
//! over the pair makes the correction ramp linearly across it, wrong by up to the jump's size in the middle.
//! Here the interval gets nodes every `step` seconds and each sub-interval's position constraint is widened by
//! the DG's anomalous motion in it: its displacement minus what the vehicle's robust (median) velocity over
//! `window` seconds explains, times `anomaly_scale`. A jump shows up as such an anomaly, of its own size and
//! where it rises; elsewhere the chain stays as stiff as the DG σ says, so an observation inside the interval
//! cannot bend it. Attitude constraints are weakened evenly by the link's factor, as without localisation.

use nalgebra::{Vector3, Vector6};
use plumbline_geo::Trajectory;
use plumbline_geo::trajectory::PositionInterpolation;
use serde::{Deserialize, Serialize};

use crate::nodes::WeakLink;
use crate::standstill::Standstill;

/// Settings of jump localisation inside flagged intervals.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JumpLocalization {
    /// Node spacing inside a flagged interval, seconds.
    pub step: f64,
    /// Length of the centred window of the median velocity, seconds (more than twice a jump's rise).
    pub window: f64,
    /// σ added to a sub-interval's position constraint per metre of anomalous DG motion in it.
    pub anomaly_scale: f64,
}

impl Default for JumpLocalization {
    fn default() -> Self {
        Self { step: 0.2, window: 3.0, anomaly_scale: 2.0 }
    }
}

/// The node epochs inside the flagged intervals.
pub(crate) fn sub_nodes(flagged: &[WeakLink], c: &JumpLocalization) -> Vec<f64> {
    if c.step.is_nan() || c.step <= 0.0 {
        return Vec::new();
    }
    let step = c.step;
    let inner = move |l: &WeakLink| {
        let (start, n) = (l.start, ((l.end - l.start) / step).floor() as usize);
        (1..n).map(move |i| start + i as f64 * step)
    };
    flagged.iter().filter(|l| l.end > l.start).flat_map(inner).collect()
}

/// The DG position at `t` (None outside the trajectory).
fn position(trajectory: &Trajectory, t: f64) -> Option<Vector3<f64>> {
    trajectory.interpolate(t, PositionInterpolation::Linear).ok().map(|r| r.position.p)
}

/// The anomalous DG displacement of each interval between consecutive `times` (inside one flagged interval):
/// |∫ (v − v_ref) dt| over fine samples. v_ref is the vehicle's robust local motion: zero inside a detected
/// standstill (`still`); elsewhere the median of the moving velocities over `window` (a jump's velocity bump
/// is a minority of it) — within `window` of a stop after removing the median acceleration's trend, so
/// braking into or accelerating out of it is followed (a jump's acceleration is a symmetric doublet) and the
/// stop's kink is not mistaken for a jump.
pub(crate) fn anomalies(
    trajectory: &Trajectory,
    times: &[f64],
    c: &JumpLocalization,
    still: &[Standstill],
) -> Vec<f64> {
    let (Some(first), Some(last)) = (times.first(), times.last()) else {
        return Vec::new();
    };
    let h = (c.step / 4.0).max(1e-3);
    let half = (0.5 * c.window / h).round() as usize;
    let start = first - half as f64 * h;
    let count = ((last - first) / h).ceil() as usize + 2 * half + 1;
    let samples: Vec<Option<Vector3<f64>>> = (0..=count).map(|i| position(trajectory, start + i as f64 * h)).collect();
    let velocity: Vec<Option<Vector3<f64>>> = samples.windows(2).map(|w| Some((w[1]? - w[0]?) / h)).collect();
    let acceleration: Vec<Option<Vector3<f64>>> = velocity.windows(2).map(|w| Some((w[1]? - w[0]?) / h)).collect();
    let at_rest: Vec<bool> = (0..velocity.len())
        .map(|i| {
            let t = start + (i as f64 + 0.5) * h;
            still.iter().any(|s| t >= s.start && t <= s.end)
        })
        .collect();
    let span = |i: usize, len: usize| i.saturating_sub(half)..(i + half + 1).min(len);
    let window = |i: usize, len: usize| span(i, len).filter(|j| !at_rest[*j]);
    let reference = |i: usize| -> Option<Vector3<f64>> {
        if at_rest[i] {
            return Some(Vector3::zeros());
        }
        if !span(i, at_rest.len()).any(|j| at_rest[j]) {
            return component_median(window(i, velocity.len()).filter_map(|j| velocity[j]));
        }
        // Braking into or accelerating out of a stop: the velocity changes fast, follow its trend.
        let a = component_median(window(i, acceleration.len()).filter_map(|j| acceleration[j]))?;
        let detrended =
            window(i, velocity.len()).filter_map(|j| velocity[j].map(|v| v - a * ((j as f64 - i as f64) * h)));
        component_median(detrended)
    };
    let excess: Vec<Vector3<f64>> = (0..velocity.len())
        .map(|i| match (velocity[i], reference(i)) {
            (Some(v), Some(r)) => (v - r) * h,
            _ => Vector3::zeros(),
        })
        .collect();
    times
        .windows(2)
        .map(|w| {
            let (a, b) = (((w[0] - start) / h).round() as usize, ((w[1] - start) / h).round() as usize);
            excess[a.min(excess.len())..b.min(excess.len())].iter().sum::<Vector3<f64>>().norm()
        })
        .collect()
}

/// The per-component median of some vectors (None if there are none).
fn component_median(values: impl Iterator<Item = Vector3<f64>>) -> Option<Vector3<f64>> {
    let all: Vec<Vector3<f64>> = values.collect();
    (!all.is_empty()).then(|| Vector3::from_fn(|r, _| median_of(all.iter().map(|v| v[r]).collect())))
}

fn median_of(mut v: Vec<f64>) -> f64 {
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// The σ of a flagged interval's links: `base` their unweakened σ, `anomaly` their anomalous DG displacement,
/// `factor` the interval's weakening. Position: σ² = base² + (anomaly_scale · anomaly)²; attitude: base · factor.
pub(crate) fn widen(base: &[Vector6<f64>], anomaly: &[f64], factor: f64, c: &JumpLocalization) -> Vec<Vector6<f64>> {
    base.iter()
        .zip(anomaly)
        .map(|(b, a)| {
            Vector6::from_fn(|i, _| if i < 3 { b[i].hypot(c.anomaly_scale * a) } else { b[i] * factor.min(1.0) })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::{Attitude, Point3, TrajectoryRecord, ValidationLimits};

    fn smoothstep(x: f64) -> f64 {
        let x = x.clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    }

    /// Braking at 1 m/s² from 8 m/s to rest at 8 s, with a 0.5 m jump north rising over 1 s from t = 6.
    fn braking_with_jump() -> Trajectory {
        let records = (0..600)
            .map(|i| {
                let t = i as f64 * 0.02;
                let s = if t < 8.0 { 8.0 * t - 0.5 * t * t } else { 32.0 };
                let p = Point3::new(1000.0 + s, 2000.0 + 0.5 * smoothstep(t - 6.0), 50.0);
                TrajectoryRecord { time: t, position: p, attitude: Attitude::new(0.0, 0.0, 1.57), std: None }
            })
            .collect();
        Trajectory::new(records, &ValidationLimits::default()).unwrap()
    }

    #[test]
    fn the_anomaly_sits_where_the_jump_rises() {
        let c = JumpLocalization::default();
        let link = WeakLink { start: 3.0, end: 9.0, factor: 100.0 };
        let mut times = vec![3.0];
        times.extend(sub_nodes(&[link], &c));
        times.push(9.0);
        let still = [Standstill { start: 8.0, end: 11.98 }];
        let a = anomalies(&braking_with_jump(), &times, &c, &still);
        let inside: f64 = times.windows(2).zip(&a).filter(|(w, _)| w[0] >= 6.0 && w[1] <= 7.0).map(|(_, a)| a).sum();
        let total: f64 = a.iter().sum();
        // The 0.5 m rise lies in 6–7 s; braking (a steady deceleration) is not an anomaly.
        assert!(inside > 0.4 && inside > 0.9 * total, "{inside} of {total}");
        let sigmas = widen(&vec![Vector6::repeat(0.01); a.len()], &a, 100.0, &c);
        let at = |t: f64| times.windows(2).position(|w| w[0] <= t && t < w[1]).unwrap();
        assert!(sigmas[at(6.5)][1] > 10.0 * sigmas[at(4.0)][1]);
        // The attitude is weakened evenly.
        assert_eq!(sigmas[at(6.5)][5], sigmas[at(4.0)][5]);
    }
}
