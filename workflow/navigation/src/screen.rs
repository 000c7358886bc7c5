//! Plausibility of the GNSS fixes on their own, before the filter sees them: urban single-point fixes carry
//! outliers of tens to hundreds of metres that a filter may take in after an outage or a re-opening, when its
//! prediction is weak. Two tests on the fixes alone:
//!
//! - **speed**: a fix implying a speed above `max_speed` from the last fix kept and to the next fix;
//! - **spike**: a fix far from the line between its neighbours, farther than a road vehicle's acceleration
//!   (`max_acceleration`, ½·a·Δt₁·Δt₂) and the fixes' own noise (3σ) allow, and farther than both neighbours
//!   are from theirs (an isolated outlier displaces its neighbours' tests by half as much).
//!
//! A step that persists (multipath) is not a spike: only its edges deviate, by half the step, and the
//! filter's innovation tests deal with it. At high rates an abrupt step is implausible motion at its edges
//! (1 m in 0.2 s), and those one or two fixes are set aside as well.

use serde::{Deserialize, Serialize};

use crate::inputs::GnssFix;

/// Limits of the plausibility tests.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Plausibility {
    /// Highest horizontal acceleration of the vehicle, m/s² (hard braking is about 8).
    pub max_acceleration: f64,
    /// Highest speed, m/s.
    pub max_speed: f64,
    /// Longest gap to a neighbour for the spike test, s (beyond it the motion in between is unknown).
    pub max_gap: f64,
}

impl Default for Plausibility {
    fn default() -> Self {
        // The speed limit is the one every trajectory is validated against (`plumbline_geo::ValidationLimits`).
        Self { max_acceleration: 8.0, max_speed: plumbline_geo::ValidationLimits::default().max_speed, max_gap: 5.0 }
    }
}

/// Why a fix was set aside.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case", tag = "test")]
pub enum Implausible {
    /// The fix lies `deviation` m off the line between its neighbours, where `allowed` m is possible.
    Spike {
        /// Horizontal distance from the interpolated position, m.
        deviation: f64,
        /// Acceleration and noise allowance, m.
        allowed: f64,
    },
    /// The fix implies `speed` m/s from the last fix kept.
    Speed {
        /// Implied horizontal speed, m/s.
        speed: f64,
    },
}

/// A fix set aside by [`screen_fixes`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct ScreenedFix {
    /// Index of the fix in the input.
    pub fix: usize,
    /// Its time, s.
    pub time: f64,
    /// The test it failed.
    pub reason: Implausible,
}

/// The fixes that pass, with their input indices, and those set aside.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Screened {
    /// The fixes kept, in input order.
    pub kept: Vec<GnssFix>,
    /// Input index of each kept fix.
    pub index: Vec<usize>,
    /// The fixes set aside, in input order.
    pub rejected: Vec<ScreenedFix>,
}

/// Most passes of the spike test.
const SPIKE_PASSES: usize = 5;

/// Screen `fixes` (in time order) with `limits` ([`Plausibility`]): first the speed test, a fix failing it
/// both from the last fix kept and to the next fix (so that one bad fix does not condemn the good ones after
/// it); then the spike test among the fixes left.
pub fn screen_fixes(fixes: &[GnssFix], limits: &Plausibility) -> Screened {
    let speed = |a: &GnssFix, b: &GnssFix| {
        let (dt, d) = (b.time - a.time, horizontal(a, b));
        if d == 0.0 {
            0.0
        } else if dt > 0.0 {
            d / dt
        } else {
            f64::INFINITY
        }
    };
    let mut rejected = Vec::new();
    let mut fast: Vec<usize> = Vec::with_capacity(fixes.len());
    for (k, fix) in fixes.iter().enumerate() {
        let from = fast.last().map_or(0.0, |&j| speed(&fixes[j], fix));
        let to = fixes.get(k + 1).map_or(f64::INFINITY, |next| speed(fix, next));
        if from > limits.max_speed && to > limits.max_speed {
            rejected.push(ScreenedFix { fix: k, time: fix.time, reason: Implausible::Speed { speed: from } });
        } else {
            fast.push(k);
        }
    }
    // Spikes, pass after pass among the fixes left: two outliers side by side hide each other until one is out.
    let mut left: Vec<usize> = fast;
    for _ in 0..SPIKE_PASSES {
        let fixes_left: Vec<GnssFix> = left.iter().map(|&k| fixes[k]).collect();
        let ratio: Vec<Option<(f64, f64)>> = (0..left.len()).map(|k| spike(&fixes_left, k, limits)).collect();
        let score = |k: usize| ratio[k].map_or(0.0, |(d, a)| d / a);
        let before = rejected.len();
        let mut next = Vec::with_capacity(left.len());
        for (k, &input) in left.iter().enumerate() {
            let local_max = (k == 0 || score(k) >= score(k - 1)) && (k + 1 == left.len() || score(k) >= score(k + 1));
            match ratio[k] {
                Some((deviation, allowed)) if deviation > allowed && local_max => {
                    let reason = Implausible::Spike { deviation, allowed };
                    rejected.push(ScreenedFix { fix: input, time: fixes[input].time, reason });
                }
                _ => next.push(input),
            }
        }
        left = next;
        if rejected.len() == before {
            break;
        }
    }
    rejected.sort_by_key(|r| r.fix);
    Screened { kept: left.iter().map(|&k| fixes[k]).collect(), index: left, rejected }
}

/// Horizontal distance between two fixes, m.
fn horizontal(a: &GnssFix, b: &GnssFix) -> f64 {
    (a.position.x() - b.position.x()).hypot(a.position.y() - b.position.y())
}

/// (deviation, allowance) of fix `k` against the line between its neighbours; `None` at the ends or across
/// gaps.
fn spike(fixes: &[GnssFix], k: usize, limits: &Plausibility) -> Option<(f64, f64)> {
    let (before, fix, after) = (fixes.get(k.checked_sub(1)?)?, &fixes[k], fixes.get(k + 1)?);
    let (d1, d2) = (fix.time - before.time, after.time - fix.time);
    if !(d1 > 0.0 && d2 > 0.0 && d1 <= limits.max_gap && d2 <= limits.max_gap) {
        return None;
    }
    let w = d1 / (d1 + d2);
    let at = |f: fn(&GnssFix) -> f64| f(before) + w * (f(after) - f(before));
    let (e, n) = (at(|f| f.position.x()), at(|f| f.position.y()));
    let deviation = (fix.position.x() - e).hypot(fix.position.y() - n);
    let var = |f: &GnssFix| f.std[0].powi(2).max(f.std[1].powi(2));
    let noise = (var(fix) + (1.0 - w).powi(2) * var(before) + w * w * var(after)).sqrt();
    let allowed = 0.5 * limits.max_acceleration * d1 * d2 + 3.0 * noise;
    Some((deviation, allowed))
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::Point3;

    /// A drive at 12 m/s braking at 7 m/s² and turning, 1 Hz fixes with 0.5 m noise-free σ: nothing is set
    /// aside; a 10 m outlier is (alone, not its neighbours), and so are two side by side; an 800 m one after a 7 s gap fails the speed test
    /// without taking the next fix with it; a 4 m step lasting 20 s (multipath) is left to the filter.
    #[test]
    fn outliers_are_set_aside_and_real_motion_and_steps_are_not() {
        // Speed 12 m/s, braking at 7 m/s² to 5 m/s at 20 s and back up at 1 m/s²; a 0.15 rad/s turn from 30 to
        // 40 s; integrated at 100 Hz and sampled every second.
        let mut track = vec![[0.0f64; 2]];
        let (mut e, mut n, mut heading, mut speed) = (0.0f64, 0.0f64, 0.3f64, 12.0f64);
        for step in 1..=6000 {
            let t = f64::from(step) * 0.01;
            let accel = if (20.0..21.0).contains(&t) {
                -7.0
            } else if speed < 12.0 && t >= 21.0 {
                1.0
            } else {
                0.0
            };
            speed += accel * 0.01;
            heading += if (30.0..40.0).contains(&t) { 0.15 * 0.01 } else { 0.0 };
            e += speed * heading.cos() * 0.01;
            n += speed * heading.sin() * 0.01;
            if step % 100 == 0 {
                track.push([e, n]);
            }
        }
        let track = |t: f64| track[t as usize];
        let fixes = |edit: &dyn Fn(usize, [f64; 2]) -> [f64; 2]| -> Vec<GnssFix> {
            (0..60)
                .map(|k| {
                    let t = k as f64;
                    let [e, n] = edit(k, track(t));
                    GnssFix { time: t, position: Point3::new(e, n, 50.0), std: [0.5, 0.5, 1.0] }
                })
                .collect()
        };
        let limits = Plausibility::default();
        let clean = screen_fixes(&fixes(&|_, p| p), &limits);
        assert!(clean.rejected.is_empty(), "{:?}", clean.rejected);
        let outlier = screen_fixes(&fixes(&|k, p| if k == 25 { [p[0] + 6.0, p[1] - 8.0] } else { p }), &limits);
        assert_eq!(outlier.rejected.len(), 1, "{:?}", outlier.rejected);
        assert_eq!(outlier.rejected[0].fix, 25);
        assert!(matches!(outlier.rejected[0].reason, Implausible::Spike { deviation, .. } if deviation > 9.0));
        assert_eq!(outlier.index.len(), 59);
        assert!(!outlier.index.contains(&25));
        // Side by side, the second is judged across a 2 s span once the first is out: ½·8·1·2 = 8 m of braking
        // is plausible there, so these are 12 and 14 m off.
        let pair = |k: usize, p: [f64; 2]| match k {
            25 => [p[0] + 7.2, p[1] - 9.6],
            26 => [p[0] - 14.0, p[1]],
            _ => p,
        };
        let both = screen_fixes(&fixes(&pair), &limits);
        assert_eq!(both.rejected.iter().map(|r| r.fix).collect::<Vec<_>>(), [25, 26], "{:?}", both.rejected);
        let step = screen_fixes(&fixes(&|k, p| if (10..30).contains(&k) { [p[0], p[1] + 4.0] } else { p }), &limits);
        assert!(step.rejected.is_empty(), "{:?}", step.rejected);
        // A fix 100 m off right after a gap (no neighbour within 5 s): only the speed test can see it.
        let mut far = fixes(&|_, p| p);
        far.retain(|f| !(40.0..46.0).contains(&f.time));
        let k = far.iter().position(|f| f.time == 46.0).unwrap();
        far[k].position.p.x += 800.0;
        let screened = screen_fixes(&far, &limits);
        assert_eq!(screened.rejected.len(), 1, "{:?}", screened.rejected);
        assert!(
            matches!(screened.rejected[0].reason, Implausible::Speed { speed } if speed > 70.0),
            "{:?}",
            screened.rejected
        );
    }
}
