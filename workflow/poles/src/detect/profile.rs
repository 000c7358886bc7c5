//! Polar range profiles: per height slice and bearing bin (one bin per angular step of the sensor) the lower
//! quartile of the horizontal ranges, and the narrow dips in them (a shaft in front of its background).

use std::f64::consts::{PI, TAU};

use super::{DetectConfig, ViewSector};
use crate::points::FramePoints;

/// Standard deviation of a sample's lower quartile per σ/√n of a normal sample.
const QUARTILE_SE: f64 = 1.36;

/// Bearing bins around the sensor.
#[derive(Clone, Copy, Debug)]
pub(super) struct Polar {
    /// Sensor position.
    pub origin: [f64; 2],
    /// Bearing of the middle of bin 0's opposite side: bins cover reference − π … reference + π.
    pub reference: f64,
    /// Bin width, radians.
    pub step: f64,
    /// Number of bins.
    pub bins: usize,
}

impl Polar {
    /// Bins centred on the frame's mean viewing bearing.
    pub fn new(frame: &FramePoints, max_range_m: f64) -> Self {
        let origin = [frame.origin.x, frame.origin.y];
        let (mut sx, mut sy) = (0.0, 0.0);
        for p in &frame.points {
            let d = (p.position - frame.origin).xy();
            let n = d.norm();
            if n > 1e-6 && n <= max_range_m {
                (sx, sy) = (sx + d.x / n, sy + d.y / n);
            }
        }
        let bins = (TAU / frame.angular_step).ceil() as usize;
        Self { origin, reference: sy.atan2(sx), step: TAU / bins as f64, bins }
    }

    /// Horizontal range and bin of a point.
    pub fn locate(&self, x: f64, y: f64) -> (f64, usize) {
        let (dx, dy) = (x - self.origin[0], y - self.origin[1]);
        let off = (dy.atan2(dx) - self.reference + PI).rem_euclid(TAU);
        (dx.hypot(dy), ((off / self.step) as usize).min(self.bins - 1))
    }

    /// Bearing of a bin's centre.
    pub fn bearing(&self, bin: f64) -> f64 {
        self.reference - PI + (bin + 0.5) * self.step
    }

    /// The sector spanned by the bins that hold points.
    pub fn sector(&self, frame: &FramePoints, max_range_m: f64) -> ViewSector {
        let (mut lo, mut hi) = (usize::MAX, 0usize);
        for p in &frame.points {
            let (range, bin) = self.locate(p.position.x, p.position.y);
            if range <= max_range_m {
                (lo, hi) = (lo.min(bin), hi.max(bin));
            }
        }
        let (lo, hi) = if lo > hi { (0, 0) } else { (lo, hi) };
        ViewSector {
            origin: self.origin,
            from_rad: self.bearing(lo as f64) - 0.5 * self.step,
            width_rad: (hi - lo + 1) as f64 * self.step,
            max_range_m,
        }
    }
}

/// One height slice's profile.
#[derive(Clone, Debug)]
pub(super) struct SliceProfile {
    /// Lower quartile of the ranges per bin (∞ where the bin is empty).
    pub low: Vec<f64>,
    /// Points per bin.
    pub count: Vec<u32>,
    /// Mean horizontal range error (1σ) per bin.
    pub sigma: Vec<f64>,
    /// First and last bin with points in any slice (the edges of the view).
    pub span: (usize, usize),
}

/// The profiles of the slices of the search band.
pub(super) fn slice_profiles(frame: &FramePoints, polar: &Polar, ground: f64, c: &DetectConfig) -> Vec<SliceProfile> {
    // The small epsilon keeps (2.7 − 0.3) / 0.4 = 5.999… at 6 slices.
    let n_slices = ((c.band_m[1] - c.band_m[0]) / c.slice_m + 1e-9).floor().max(1.0) as usize;
    let mut cells: Vec<Vec<(f64, f64)>> = vec![Vec::new(); n_slices * polar.bins];
    let (mut lo, mut hi) = (usize::MAX, 0usize);
    for p in &frame.points {
        let (range, bin) = polar.locate(p.position.x, p.position.y);
        if range > c.max_range_m {
            continue;
        }
        (lo, hi) = (lo.min(bin), hi.max(bin));
        let h = p.position.z - ground - c.band_m[0];
        if h >= 0.0 && h < n_slices as f64 * c.slice_m {
            let s = (h / c.slice_m) as usize;
            cells[s * polar.bins + bin].push((range, p.error.xy().norm()));
        }
    }
    let span = if lo > hi { (0, 0) } else { (lo, hi) };
    cells
        .chunks_mut(polar.bins)
        .map(|slice| {
            let mut profile = SliceProfile {
                low: vec![f64::INFINITY; polar.bins],
                count: vec![0; polar.bins],
                sigma: vec![0.0; polar.bins],
                span,
            };
            for (b, cell) in slice.iter_mut().enumerate().filter(|(_, c)| !c.is_empty()) {
                cell.sort_by(|a, b| a.0.total_cmp(&b.0));
                profile.low[b] = cell[(cell.len() - 1) / 4].0;
                profile.count[b] = cell.len() as u32;
                profile.sigma[b] = cell.iter().map(|v| v.1).sum::<f64>() / cell.len() as f64;
            }
            profile
        })
        .collect()
}

/// A run of neighbouring bins of one slice that stand in front of their background.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Run {
    /// Height slice.
    pub slice: usize,
    /// First and last bin.
    pub bins: (usize, usize),
    /// Range of the run (median of its bins' quartiles), metres.
    pub range: f64,
    /// Standard deviation of `range`, metres.
    pub sigma: f64,
}

/// Widest bearing window searched for a background, radians (keeps very near poles within the view).
const MAX_REACH_RAD: f64 = 0.25;

/// The narrow dips of a slice's profile: bins in front of the background at a pole's width on both sides,
/// grouped into runs that are no wider than a pole and end in a step on both sides (a building corner is
/// the nearest point of a continuous surface, not a step).
pub(super) fn dips(p: &SliceProfile, slice: usize, polar: &Polar, c: &DetectConfig) -> Vec<Run> {
    let (first, last) = p.span;
    let mut runs = Vec::new();
    let mut i = first;
    while i <= last {
        if !candidate(p, i, polar, c) {
            i += 1;
            continue;
        }
        let start = i;
        while i < last && candidate(p, i + 1, polar, c) {
            i += 1;
        }
        if let Some(run) = run(p, slice, (start, i), polar, c) {
            runs.push(run);
        }
        i += 1;
    }
    runs
}

/// The gap a range must keep to its background: the larger of the minimum and `gap_sigmas` × the noise.
fn gap(p: &SliceProfile, i: usize, c: &DetectConfig) -> f64 {
    let noise = QUARTILE_SE * p.sigma[i] / f64::from(p.count[i].max(1)).sqrt();
    c.min_gap_m.max(c.gap_sigmas * noise)
}

fn candidate(p: &SliceProfile, i: usize, polar: &Polar, c: &DetectConfig) -> bool {
    let (k, (first, last)) = (c.background_bins, p.span);
    let r = p.low[i];
    if !r.is_finite() {
        return false;
    }
    let reach = ((c.max_diameter_m / r).min(MAX_REACH_RAD) / polar.step).ceil() as usize;
    // The background on each side that lies in the view (at least one side must), at a pole's width or at
    // half of it, whichever lies farther: a shaft 0.4–0.8 m beside another object is still in front of its
    // background, while inside a facade both lie on the facade.
    let left = |reach: usize| i.checked_sub(reach + k).filter(|&a| a >= first).map(|a| median(&p.low[a..a + k]));
    let right = |reach: usize| Some(i + reach + k).filter(|&b| b <= last).map(|b| median(&p.low[b + 1 - k..=b]));
    let half = reach.div_ceil(2);
    let farther = |a: Option<f64>, b: Option<f64>| a.zip(b).map(|(a, b)| a.max(b)).or(a).or(b);
    let sides = [farther(left(reach), left(half)), farther(right(reach), right(half))];
    let gap = gap(p, i, c);
    sides.iter().any(Option::is_some) && sides.into_iter().flatten().all(|background| r + gap < background)
}

fn run(p: &SliceProfile, slice: usize, (a, b): (usize, usize), polar: &Polar, c: &DetectConfig) -> Option<Run> {
    let k = c.background_bins;
    let range = median(&p.low[a..=b]);
    let width = (b - a) as f64 * polar.step * range;
    if width > c.max_diameter_m || a < p.span.0 + k + 1 || b + k + 1 > p.span.1 {
        return None;
    }
    // A step on both sides: the bins just beyond the run (one skipped for a partly covered bin) lie behind.
    let n: u32 = p.count[a..=b].iter().sum();
    let sigma = QUARTILE_SE * p.sigma[a..=b].iter().sum::<f64>() / (b - a + 1) as f64 / f64::from(n.max(1)).sqrt();
    let step = range + c.min_gap_m.max(c.gap_sigmas * sigma);
    if median(&p.low[a - k - 1..a - 1]) < step || median(&p.low[b + 2..b + 2 + k]) < step {
        return None;
    }
    Some(Run { slice, bins: (a, b), range, sigma })
}

/// Median of finite-or-infinite values (∞ sorts last).
fn median(values: &[f64]) -> f64 {
    plumbline_geo::metrics::median(&mut values.to_vec()).unwrap_or(f64::INFINITY)
}
