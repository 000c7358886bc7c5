//! The speed profile along a path: the fastest drive that keeps to the speed limits and the curve speed,
//! accelerates and brakes at bounded rates, and stands still at the start, the end and at stopping junctions.
//!
//! Computed on a grid in arc length (forward pass for acceleration, backward pass for braking), then timed:
//! between grid points the acceleration is constant, so `t`, `s` and `v` are exact at any time.

use super::DriveConfig;
use super::path::Path;
use super::rng::{Purpose, Stream};

/// Grid spacing of the speed profile, metres.
const DS: f64 = 0.25;
/// Junction waypoints closer than this along the path belong to the same junction, metres.
const JUNCTION_EXTENT: f64 = 30.0;

/// A standstill of the drive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop {
    /// Arc length where the vehicle stands, metres.
    pub s: f64,
    /// Time the standstill begins, seconds after the start of the drive.
    pub start: f64,
    /// How long it stands, seconds.
    pub duration: f64,
}

/// One piece of the timed profile: constant acceleration from (t0, s0, v0) for `dt` seconds.
#[derive(Clone, Copy, Debug)]
struct Knot {
    t0: f64,
    s0: f64,
    v0: f64,
    accel: f64,
    dt: f64,
}

/// The timed speed profile.
#[derive(Clone, Debug)]
pub(crate) struct Profile {
    knots: Vec<Knot>,
    stops: Vec<Stop>,
}

/// Longitudinal state at one time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Longitudinal {
    pub s: f64,
    pub speed: f64,
    pub accel: f64,
}

impl Profile {
    /// Plan the drive along `path`; which junctions stop and for how long is drawn from `seed`.
    pub(crate) fn plan(path: &Path, config: &DriveConfig, seed: u64) -> Self {
        let n = (path.length() / DS).ceil().max(1.0) as usize + 1;
        let ds = path.length() / (n - 1) as f64;
        let allowed: Vec<f64> = (0..n).map(|i| allowed_speed(path, i as f64 * ds, config)).collect();
        // Honour every limit within `reach`: `Drive` averages speeds over `jerk_window`, during which the
        // vehicle moves at most that far (and a grid interval at least one point).
        let top = allowed.iter().copied().filter(|v| v.is_finite()).fold(0.0, f64::max);
        let reach = 1 + (config.jerk_window * top / ds).ceil() as usize;
        let mut v: Vec<f64> = (0..n)
            .map(|i| {
                allowed[i.saturating_sub(reach)..(i + reach + 1).min(n)].iter().copied().fold(f64::INFINITY, f64::min)
            })
            .collect();
        let dwell = stops(path, config, seed, ds, &mut v);
        for i in 1..n {
            v[i] = v[i].min((v[i - 1].powi(2) + 2.0 * config.max_accel * ds).sqrt());
        }
        for i in (0..n - 1).rev() {
            v[i] = v[i].min((v[i + 1].powi(2) + 2.0 * config.max_decel * ds).sqrt());
        }
        time(&v, ds, &dwell)
    }

    /// Duration of the whole drive, seconds.
    pub(crate) fn duration(&self) -> f64 {
        self.knots.last().map_or(0.0, |k| k.t0 + k.dt)
    }

    /// The standstills, in time order.
    pub(crate) fn stops(&self) -> &[Stop] {
        &self.stops
    }

    /// Arc length, speed and acceleration at time `t` (seconds after the start, clamped to the drive).
    pub(crate) fn at(&self, t: f64) -> Longitudinal {
        let k = self.knots.partition_point(|k| k.t0 + k.dt < t).min(self.knots.len() - 1);
        let knot = &self.knots[k];
        let tau = (t - knot.t0).clamp(0.0, knot.dt);
        let speed = (knot.v0 + knot.accel * tau).max(0.0);
        Longitudinal { s: knot.s0 + knot.v0 * tau + 0.5 * knot.accel * tau * tau, speed, accel: knot.accel }
    }
}

/// The speed the driver wants at `s`: a share of the limit, and no more than the curve allows.
fn allowed_speed(path: &Path, s: f64, config: &DriveConfig) -> f64 {
    let p = path.at(s);
    let cruise = p.speed_limit * config.cruise_factor;
    let curve =
        if p.curvature.abs() > 0.0 { (config.max_lateral_accel / p.curvature.abs()).sqrt() } else { f64::INFINITY };
    cruise.min(curve.max(config.min_curve_speed))
}

/// Mark the standstills in the speed grid; returns (grid index, dwell seconds) in path order.
fn stops(path: &Path, config: &DriveConfig, seed: u64, ds: f64, v: &mut [f64]) -> Vec<(usize, f64)> {
    let mut rng = Stream::new(seed, Purpose::Stops);
    let last = v.len() - 1;
    let mut out = vec![(0, config.start_dwell)];
    let mut previous_junction = f64::NEG_INFINITY;
    for (j, w) in path.waypoints().iter().enumerate() {
        let junction_s = path.waypoint_s(j).unwrap_or(0.0);
        // The flagged waypoints of one junction (entry and exit of a crossing) are one stopping chance.
        if !w.junction || junction_s - std::mem::replace(&mut previous_junction, junction_s) < JUNCTION_EXTENT {
            continue;
        }
        if !rng.chance(config.stop_probability) {
            continue;
        }
        let duration = rng.uniform(config.standstill_min, config.standstill_max);
        let index = ((junction_s - config.stop_before_junction).max(0.0) / ds).round() as usize;
        if index > 0 && index < last {
            out.push((index, duration));
        }
    }
    out.push((last, config.end_dwell));
    out.sort_by_key(|&(i, _)| i);
    out.dedup_by_key(|&mut (i, _)| i);
    for &(i, _) in &out {
        v[i] = 0.0;
    }
    out
}

/// Time the grid profile: constant acceleration between grid points, dwell at the stops.
fn time(v: &[f64], ds: f64, dwell: &[(usize, f64)]) -> Profile {
    let mut knots = Vec::with_capacity(v.len() + dwell.len());
    let mut stops = Vec::new();
    let mut t = 0.0;
    let mut next_stop = dwell.iter().peekable();
    for i in 0..v.len() {
        let s = i as f64 * ds;
        if let Some(&&(k, duration)) = next_stop.peek()
            && k == i
        {
            next_stop.next();
            stops.push(Stop { s, start: t, duration });
            knots.push(Knot { t0: t, s0: s, v0: 0.0, accel: 0.0, dt: duration });
            t += duration;
        }
        if i + 1 < v.len() {
            let (v0, v1) = (v[i], v[i + 1]);
            let dt = 2.0 * ds / (v0 + v1).max(1e-9);
            knots.push(Knot { t0: t, s0: s, v0, accel: (v1 - v0) / dt, dt });
            t += dt;
        }
    }
    Profile { knots, stops }
}
