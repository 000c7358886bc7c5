//! From a stacked structure to a detection: the shaft's points (its bearing bins, within 3σ of its range),
//! the verticality test, the diameter from the angular width and the centre with its covariance.

use std::f64::consts::PI;

use nalgebra::{Matrix2, Vector2};
use plumbline_geo::angle::wrap;

use super::profile::Polar;
use super::stack::Stack;
use super::{DetectConfig, Detection};
use crate::points::FramePoints;

/// Range slack of the shaft window beyond 3σ of the range noise, metres (the shaft's own depth).
const WINDOW_SLACK_M: f64 = 0.3;
/// Re-centring passes of the range window.
const PASSES: usize = 3;

/// A shaft point: horizontal position, height above ground, range, bearing, horizontal error vector.
#[derive(Clone, Copy, Debug)]
struct Shaft {
    xy: Vector2<f64>,
    h: f64,
    range: f64,
    bearing: f64,
    error: Vector2<f64>,
}

/// The detection of a structure, or `None` when it fails the point-count or verticality tests.
pub(super) fn refine(
    frame: &FramePoints,
    polar: &Polar,
    ground: f64,
    stack: &Stack,
    c: &DetectConfig,
) -> Option<Detection> {
    let (lo, hi) = stack.bins();
    let (lo, hi) = (lo.saturating_sub(1), (hi + 1).min(polar.bins - 1));
    let mut ranges: Vec<f64> = stack.runs.iter().map(|r| r.range).collect();
    ranges.sort_by(f64::total_cmp);
    let mut centre_range = ranges[ranges.len() / 2];
    let slices: Vec<usize> = stack.runs.iter().map(|r| r.slice).collect();
    // The shaft's points: in the slices where it stood in front of its background (below, a parked car or a
    // wall may stand in front of it in the same bearing bins).
    let in_band = |h: f64| {
        let s = (h - c.band_m[0]) / c.slice_m;
        s >= 0.0 && slices.contains(&(s as usize))
    };
    let mut tube = Vec::new();
    for _ in 0..PASSES {
        tube = collect(frame, polar, ground, (lo, hi), centre_range);
        let band: Vec<&Shaft> = tube.iter().filter(|s| in_band(s.h)).collect();
        if band.is_empty() {
            return None;
        }
        centre_range = band.iter().map(|s| s.range).sum::<f64>() / band.len() as f64;
    }
    let band: Vec<Shaft> = tube.iter().copied().filter(|s| in_band(s.h)).collect();
    if band.len() < c.min_points {
        return None;
    }
    let lean = lean(&band, Vector2::new(polar.origin[0], polar.origin[1]))?;
    if lean.1 > c.max_lean {
        return None;
    }
    let extent = tube.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[a, b], s| [a.min(s.h), b.max(s.h)]);
    let detection = estimate(&band, polar, frame, ground, stack.slices(), lean.0, extent, c);
    // A centre beyond the range searched: a structure outside it, of which only the near tail of the range
    // noise was kept (its centre is biased towards the sensor).
    (detection.range_m <= c.max_range_m).then_some(detection)
}

/// The points in the bearing bins within 3σ (+ slack) of `range`, at any height above −0.5 m.
fn collect(frame: &FramePoints, polar: &Polar, ground: f64, (lo, hi): (usize, usize), range: f64) -> Vec<Shaft> {
    let o = Vector2::new(polar.origin[0], polar.origin[1]);
    let mut out = Vec::new();
    let mut relative = Vec::new();
    for p in &frame.points {
        let (r, bin) = polar.locate(p.position.x, p.position.y);
        if bin < lo || bin > hi || r < 1e-6 {
            continue;
        }
        let xy = Vector2::new(p.position.x, p.position.y);
        let error = Vector2::new(p.error.x, p.error.y);
        let bearing = (xy - o).y.atan2((xy - o).x);
        relative.push(error.norm() / r);
        out.push(Shaft { xy, h: p.position.z - ground, range: r, bearing, error });
    }
    relative.sort_by(f64::total_cmp);
    let share = relative.get(relative.len() / 2).copied().unwrap_or(0.0);
    let window = 3.0 * share * range + WINDOW_SLACK_M;
    out.retain(|s| (s.range - range).abs() <= window && s.h >= -0.5);
    out
}

/// Lean (metres per metre) from a straight-line fit of position against height, and the part of it that is
/// significant: per axis (along the mean ray, where the range noise lies, and across it) the slope minus 3σ
/// of that axis' own residuals, combined. A single pooled σ would understate the noise along the ray.
fn lean(band: &[Shaft], origin: Vector2<f64>) -> Option<(f64, f64)> {
    let n = band.len() as f64;
    let h_mean = band.iter().map(|s| s.h).sum::<f64>() / n;
    let xy_mean = band.iter().map(|s| s.xy).sum::<Vector2<f64>>() / n;
    let shh: f64 = band.iter().map(|s| (s.h - h_mean).powi(2)).sum();
    let along = (xy_mean - origin).try_normalize(1e-9)?;
    if shh < 1e-6 || band.len() < 4 {
        return None;
    }
    let axis = |e: Vector2<f64>| {
        let slope = band.iter().map(|s| (s.xy - xy_mean).dot(&e) * (s.h - h_mean)).sum::<f64>() / shh;
        let residual: f64 = band.iter().map(|s| ((s.xy - xy_mean).dot(&e) - slope * (s.h - h_mean)).powi(2)).sum();
        (slope, (residual / (n - 2.0) / shh).sqrt())
    };
    let (a, b) = (axis(along), axis(Vector2::new(-along.y, along.x)));
    let excess = |(slope, sigma): (f64, f64)| (slope.abs() - 3.0 * sigma).max(0.0);
    Some((a.0.hypot(b.0), excess(a).hypot(excess(b))))
}

#[allow(clippy::too_many_arguments)]
fn estimate(
    band: &[Shaft],
    polar: &Polar,
    frame: &FramePoints,
    ground: f64,
    slices: usize,
    lean: f64,
    extent: [f64; 2],
    c: &DetectConfig,
) -> Detection {
    let n = band.len() as f64;
    let surface = band.iter().map(|s| s.xy).sum::<Vector2<f64>>() / n;
    // Equal weights: the covariance of the mean is Σ e eᵀ / N² (each point moves along its own ray).
    let mut cov: Matrix2<f64> = band.iter().map(|s| s.error * s.error.transpose()).sum::<Matrix2<f64>>() / (n * n);
    let o = Vector2::new(polar.origin[0], polar.origin[1]);
    let to_surface = surface - o;
    let range = to_surface.norm().max(1e-6);
    let u = to_surface / range;
    let mid = u.y.atan2(u.x);
    let offsets: Vec<f64> = band.iter().map(|s| wrap(s.bearing - mid)).collect();
    let mean = offsets.iter().sum::<f64>() / n;
    let var = offsets.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / n;
    // Uniform across the angular width w: var = w²/12; one step of sampling added in quadrature.
    let diameter = (range * (12.0 * var + polar.step.powi(2)).sqrt()).min(c.max_diameter_m);
    let diameter_sigma = range * polar.step;
    // The visible half of a circle lies on average π r / 4 in front of its centre.
    let centre = surface + u * (PI / 8.0 * diameter);
    cov += u * u.transpose() * (PI / 8.0 * diameter_sigma).powi(2) + Matrix2::identity() * c.floor_sigma_m.powi(2);
    let range_m = (centre - o).norm();
    Detection {
        centre: [centre.x, centre.y],
        covariance: [[cov[(0, 0)], cov[(0, 1)]], [cov[(1, 0)], cov[(1, 1)]]],
        diameter_m: diameter,
        diameter_sigma_m: diameter_sigma,
        height_extent_m: extent,
        ground_height_m: ground,
        points: band.len(),
        range_m,
        lean,
        slices,
        reliable: range_m <= frame.reliable_range_m,
    }
}
