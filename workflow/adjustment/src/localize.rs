//! Where inside a flagged interval the DG jumped. The consistency check flags a whole pair of panoramas
//! (seconds long at low speed) but a multipath jump rises within about a second; weakening the chain evenly
//! over the pair makes the correction ramp linearly across it, wrong by up to the jump's size in the middle.
//! Here the interval gets nodes every `step` seconds, and over each sub-interval the DG's anomalous motion e
//! is measured: its displacement minus what the vehicle's robust reference motion explains (in the vehicle's
//! own frame, [`crate::vehicle`]; [`anomalies`]). A jump shows up as such an anomaly, of its own size and
//! direction and where it rises. The sub-interval's link then follows the reference motion instead of the
//! DG: the correction's increment over it is expected to be −e (the link's mean), with the position σ widened
//! by `anomaly_scale` · |e| for what the control must still settle. Sharing a jump's freedom out by σ alone
//! would put it where the anomaly is largest (a least-squares increment goes with σ², not with |e|) and cannot
//! tell a jump's rise from the fall of the one before. Elsewhere the chain stays as stiff as the DG σ says, so
//! an observation inside the interval cannot bend it. Attitude constraints are weakened evenly by the link's
//! factor, as without localisation.

use crate::config::JumpLocalizationConfig;
use crate::nodes::WeakLink;
use crate::standstill::Standstill;
use crate::vehicle::Motion;
use nalgebra::{Vector3, Vector6};
use plumbline_geo::Trajectory;
use plumbline_geo::metrics::median;

/// The node epochs inside the flagged intervals.
pub(crate) fn sub_nodes(flagged: &[WeakLink], c: &JumpLocalizationConfig) -> Vec<f64> {
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

/// The anomalous DG displacement (east, north, up) of each interval between consecutive `times` (inside one
/// flagged interval): ∫ (v − v_ref) dt over fine samples, v the DG's velocity in the vehicle frame (along the
/// heading, across it, up; [`Motion`]). The reference v_ref is the vehicle's robust local motion: zero inside a
/// detected standstill (`still`); elsewhere along-track and up the median over the centred `window`, rest
/// counting as zero ([`Reference::at`]), and across-track the crab angle's share of the along-track reference
/// (a car does not move sideways). A jump does not turn the vehicle, so in a turn the heading carries the
/// reference round with it, where a world-frame median would lag behind the turning velocity.
pub(crate) fn anomalies(
    trajectory: &Trajectory,
    times: &[f64],
    c: &JumpLocalizationConfig,
    still: &[Standstill],
    crab: f64,
) -> Vec<Vector3<f64>> {
    let (Some(first), Some(last)) = (times.first(), times.last()) else {
        return Vec::new();
    };
    let h = (c.step / 4.0).max(1e-3);
    let half = (0.5 * c.window / h).round() as usize;
    let start = first - half as f64 * h;
    let end = start + (((last - first) / h).ceil() as usize + 2 * half + 1) as f64 * h;
    let Some(m) = Motion::sample(trajectory, (start, end), h).or_else(|| {
        let span = trajectory.span();
        Motion::sample(trajectory, (start.max(span.0), end.min(span.1)), h)
    }) else {
        return vec![Vector3::zeros(); times.len().saturating_sub(1)];
    };
    let at_rest: Vec<bool> = (0..m.len())
        .map(|i| {
            let t = m.start + (i as f64 + 0.5) * h;
            still.iter().any(|s| t >= s.start && t <= s.end)
        })
        .collect();
    let reference = Reference { at_rest: &at_rest, half };
    let tan = crab.tan();
    let excess: Vec<Vector3<f64>> = (0..m.len())
        .map(|i| {
            let (along, up) = (reference.at(&m.along, i), reference.at(&m.up, i));
            // Excess over the land-vehicle model (Cazzaniga et al. 2007 §2): no sideways motion beyond the crab.
            m.to_world(i, m.along[i] - along, m.across[i] - tan * along, m.up[i] - up)
        })
        .collect();
    times
        .windows(2)
        .map(|w| excess[m.index(w[0])..m.index(w[1]).max(m.index(w[0]))].iter().sum::<Vector3<f64>>())
        .collect()
}

/// The robust local reference of one vehicle-frame displacement series.
struct Reference<'a> {
    at_rest: &'a [bool],
    /// Half the window, samples.
    half: usize,
}

impl Reference<'_> {
    /// The reference displacement of sample interval i of series `d` (displacements per sample): the median
    /// over the centred window with the samples at rest counted as zero. The median of a centred window of a
    /// monotone profile is its centre value, so braking into a stop, accelerating out of it and any kink
    /// between constant speed and a steady change are followed exactly; a jump's velocity bump is a minority
    /// of the window, and a jump while standing does not enter it (rest counts as zero, not as the DG's drift).
    fn at(&self, d: &[f64], i: usize) -> f64 {
        if self.at_rest[i] {
            return 0.0;
        }
        let span = i.saturating_sub(self.half)..(i + self.half + 1).min(d.len());
        median(&mut span.map(|j| if self.at_rest[j] { 0.0 } else { d[j] }).collect::<Vec<_>>()).unwrap_or(d[i])
    }
}

/// The σ of a flagged interval's links: `base` their unweakened σ, `anomaly` their anomalous DG displacement,
/// `factor` the interval's weakening. Position: σ² = base² + (anomaly_scale · anomaly)²; attitude: base · factor.
pub(crate) fn widen(
    base: &[Vector6<f64>],
    anomaly: &[f64],
    factor: f64,
    c: &JumpLocalizationConfig,
) -> Vec<Vector6<f64>> {
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
        let c = JumpLocalizationConfig::default();
        let link = WeakLink { start: 3.0, end: 9.0, factor: 100.0 };
        let mut times = vec![3.0];
        times.extend(sub_nodes(&[link], &c));
        times.push(9.0);
        let still = [Standstill { start: 8.0, end: 11.98 }];
        let a: Vec<f64> = anomalies(&braking_with_jump(), &times, &c, &still, 0.0).iter().map(|e| e.norm()).collect();
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

    /// 12 s at 50 Hz and 2.4 m/s: heading 59° turning at a constant rate to 11° over 5–6.5 s, then a jump of
    /// (0.68 m east, −0.62 m north) rising over 6.8–7.8 s; the heading is the direction of travel throughout.
    fn turn_then_jump() -> (Trajectory, Vector3<f64>) {
        let jump = Vector3::new(0.68, -0.62, 0.0);
        let heading = |t: f64| (59.0 - 48.0 * ((t - 5.0) / 1.5).clamp(0.0, 1.0)).to_radians();
        let (dt, mut p) = (0.02, Vector3::new(1000.0, 2000.0, 50.0));
        let records = (0..600)
            .map(|i| {
                let t = i as f64 * dt;
                if i > 0 {
                    let psi = heading(t - 0.5 * dt);
                    p += Vector3::new(psi.sin(), psi.cos(), 0.0) * 2.4 * dt;
                }
                let position = Point3::from_vector(p + jump * smoothstep(t - 6.8));
                TrajectoryRecord { time: t, position, attitude: Attitude::new(0.0, 0.0, heading(t)), std: None }
            })
            .collect();
        (Trajectory::new(records, &ValidationLimits::default()).unwrap(), jump)
    }

    /// The node epochs of flagged interval [a, b] and the anomalies of its sub-intervals.
    fn anomalies_over(t: &Trajectory, (a, b): (f64, f64), still: &[Standstill]) -> (Vec<f64>, Vec<Vector3<f64>>) {
        let c = JumpLocalizationConfig::default();
        let mut times = vec![a];
        times.extend(sub_nodes(&[WeakLink { start: a, end: b, factor: 100.0 }], &c));
        times.push(b);
        let e = anomalies(t, &times, &c, still, 0.0);
        (times, e)
    }

    #[test]
    fn a_jump_right_after_a_turn_is_found_where_it_rises_with_its_direction() {
        let (t, jump) = turn_then_jump();
        let (times, e) = anomalies_over(&t, (3.0, 9.0), &[]);
        let rise = |w: &[f64]| w[0] >= 6.8 - 1e-9 && w[1] <= 7.8 + 1e-9;
        let inside: Vector3<f64> = times.windows(2).zip(&e).filter(|(w, _)| rise(w)).map(|(_, e)| e).sum();
        let outside: f64 = times.windows(2).zip(&e).filter(|(w, _)| !rise(w)).map(|(_, e)| e.norm()).sum();
        // A world-frame velocity median over the turn and the rise puts decimetres before the jump.
        assert!((inside - jump).norm() < 0.03, "{inside:?}");
        assert!(outside < 0.03, "{outside}");
    }

    #[test]
    fn braking_smoothly_into_a_stop_is_not_an_anomaly() {
        // From 8 m/s to rest over 2–6 s (a smooth S-curve of speed), then standing.
        let speed = |t: f64| 8.0 * (1.0 - smoothstep((t - 2.0) / 4.0));
        let mut s = 0.0;
        let records = (0..600)
            .map(|i| {
                let t = i as f64 * 0.02;
                if i > 0 {
                    s += 0.5 * (speed(t - 0.02) + speed(t)) * 0.02;
                }
                let p = Point3::new(1000.0 + s, 2000.0, 50.0);
                TrajectoryRecord { time: t, position: p, attitude: Attitude::new(0.0, 0.0, 1.57), std: None }
            })
            .collect();
        let t = Trajectory::new(records, &ValidationLimits::default()).unwrap();
        let (_, e) = anomalies_over(&t, (1.0, 9.0), &[Standstill { start: 6.0, end: 11.98 }]);
        let total: f64 = e.iter().map(|e| e.norm()).sum();
        // Removing a median deceleration trend, or leaving the rest out of the window, leads the braking by
        // decimetres.
        assert!(total < 0.02, "{total}");
    }
}
