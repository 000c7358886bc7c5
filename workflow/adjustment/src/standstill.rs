//! Standstill (zero-velocity) detection from the DG trajectory itself, robust to the DG jumps that happen
//! while the vehicle stands still (Meyer et al. 2023 §4.2.3, Fig. 7: standstills of up to ~40 s at traffic lights).
//!
//! The trajectory is sampled every `sample_step`; each sample gets a speed from the displacement over
//! `baseline` seconds (long enough that the DG's millimetre white noise does not look like motion); a sample
//! is still when the MEDIAN of those speeds over a centred `window` lies below `speed_threshold`. A jump
//! rises within about a second, so it spoils only a minority of the window's speeds and the median ignores
//! it; slow creeping above the threshold keeps every speed above it. Runs of still samples lasting at least
//! `min_duration` are the standstills.

use plumbline_geo::Trajectory;
use plumbline_geo::metrics::median;
use serde::{Deserialize, Serialize};

use crate::config::StandstillConfig;

/// A detected standstill: the vehicle is at rest over [start, end].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Standstill {
    /// First still instant, seconds.
    pub start: f64,
    /// Last still instant, seconds.
    pub end: f64,
}

/// The standstills of `trajectory` (time-sorted, disjoint); empty when the settings are not positive.
pub fn detect_standstills(trajectory: &Trajectory, config: &StandstillConfig) -> Vec<Standstill> {
    let c = config;
    if !(c.sample_step > 0.0 && c.baseline > 0.0 && c.window > 0.0 && c.speed_threshold > 0.0) {
        return Vec::new();
    }
    let (times, speeds) = speed_samples(trajectory, c);
    let half = ((0.5 * c.window / c.sample_step).round() as usize).max(1);
    let mut scratch = Vec::with_capacity(2 * half + 1);
    let still: Vec<bool> = (0..speeds.len())
        .map(|j| {
            scratch.clear();
            scratch.extend_from_slice(&speeds[j.saturating_sub(half)..(j + half + 1).min(speeds.len())]);
            median(&mut scratch).is_some_and(|m| m < c.speed_threshold)
        })
        .collect();
    runs(&times, &still, c.min_duration)
}

/// Sample times (mid-baseline) and speeds over `baseline`, from records at least `sample_step` apart.
fn speed_samples(trajectory: &Trajectory, c: &StandstillConfig) -> (Vec<f64>, Vec<f64>) {
    let mut picked = Vec::new();
    for r in trajectory.records() {
        if picked.last().is_none_or(|(t, _)| r.time - t >= c.sample_step - 1e-9) {
            picked.push((r.time, r.position.p));
        }
    }
    let lag = ((c.baseline / c.sample_step).round() as usize).max(1);
    picked
        .iter()
        .zip(picked.iter().skip(lag))
        .map(|((ta, pa), (tb, pb))| (0.5 * (ta + tb), (pb - pa).norm() / (tb - ta)))
        .unzip()
}

/// Runs of `still` samples lasting at least `min_duration`.
fn runs(times: &[f64], still: &[bool], min_duration: f64) -> Vec<Standstill> {
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    for j in 0..=still.len() {
        match (start, still.get(j).copied().unwrap_or(false)) {
            (None, true) => start = Some(j),
            (Some(s), false) => {
                let (a, b) = (times[s], times[j - 1]);
                if b - a >= min_duration {
                    out.push(Standstill { start: a, end: b });
                }
                start = None;
            }
            _ => {}
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::{Attitude, Point3, TrajectoryRecord, ValidationLimits};

    /// 50 Hz drive along north: `position(t)` in metres; ±0.5 mm seeded-free deterministic "noise".
    fn drive(duration: f64, position: impl Fn(f64) -> f64) -> Trajectory {
        let records = (0..(duration * 50.0) as usize)
            .map(|i| {
                let t = i as f64 / 50.0;
                let noise = 5e-4 * ((i * 7919 % 13) as f64 / 6.0 - 1.0);
                let p = Point3::new(1000.0 + noise, 2000.0 + position(t), 50.0);
                TrajectoryRecord { time: t, position: p, attitude: Attitude::new(0.0, 0.0, 0.0), std: None }
            })
            .collect();
        Trajectory::new(records, &ValidationLimits::default()).unwrap()
    }

    fn smoothstep(x: f64) -> f64 {
        let x = x.clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    }

    /// 10 m/s, braking at 2 m/s² to rest at 30 s, still for 20 s, then accelerating again.
    fn stop_and_go(t: f64) -> f64 {
        let (brake, stop, go) = (25.0, 30.0, 50.0);
        if t < brake {
            10.0 * t
        } else if t < stop {
            10.0 * brake + 10.0 * (t - brake) - (t - brake).powi(2)
        } else if t < go {
            10.0 * brake + 25.0
        } else {
            10.0 * brake + 25.0 + (t - go).powi(2)
        }
    }

    #[test]
    fn a_standstill_with_a_half_metre_jump_is_one_standstill() {
        // The DG jumps 0.5 m north within 1 s at 38 s, in the middle of the stop.
        let trajectory = drive(70.0, |t| stop_and_go(t) + 0.5 * smoothstep(t - 38.0));
        let found = detect_standstills(&trajectory, &StandstillConfig::default());
        assert_eq!(found.len(), 1, "{found:?}");
        // The speed falls below 2 cm/s 10 ms before the stop and rises above it 10 ms after the go.
        assert!((found[0].start - 30.0).abs() < 0.3, "{found:?}");
        assert!((found[0].end - 50.0).abs() < 0.3, "{found:?}");
    }

    #[test]
    fn without_the_jump_the_same_stop_is_found_and_a_moving_drive_has_none() {
        let found = detect_standstills(&drive(70.0, stop_and_go), &StandstillConfig::default());
        assert_eq!(found.len(), 1);
        assert!(detect_standstills(&drive(60.0, |t| 10.0 * t), &StandstillConfig::default()).is_empty());
    }

    #[test]
    fn slow_creeping_is_not_a_standstill() {
        // 40 s creeping at 0.1 m/s (4 m), and at 0.03 m/s (1.2 m): neither is still.
        for speed in [0.1, 0.03] {
            let found = detect_standstills(&drive(40.0, |t| speed * t), &StandstillConfig::default());
            assert!(found.is_empty(), "{speed} m/s: {found:?}");
        }
    }

    #[test]
    fn short_stops_are_ignored() {
        // Still for 2 s only (below the 3 s minimum).
        let p = |t: f64| {
            if t < 10.0 {
                10.0 * t
            } else if t < 12.0 {
                100.0
            } else {
                100.0 + 10.0 * (t - 12.0)
            }
        };
        assert!(detect_standstills(&drive(20.0, p), &StandstillConfig::default()).is_empty());
    }
}
