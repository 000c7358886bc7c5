//! A mobile-laser-scanning cloud as pole control: the cloud is georeferenced with the DG trajectory, so the
//! stems it shows carry the DG error of the time they were scanned. Points are streamed in GPS-time order and
//! cut into time slices; each slice's stems are found by [`StemDetector`] in a window reaching `margin_s`
//! beyond the slice (a stem scanned across a slice border is whole in both windows, and belongs to the slice
//! its band points' mean time falls in). A slice with its stems becomes one [`MatchInput`] at the mean time
//! of its stems, seen from the scanner position then: the same input the depth path makes per image, so
//! matching and coordinate updates are the depth path's.
//!
//! Memory holds the points of one window (slice plus two margins), whatever the cloud's size. Points that
//! arrive after their window was processed (a cloud not in time order, e.g. a tiled product) are counted,
//! not used.

use std::ops::Range;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::detect::{Detection, FrameDetections, ViewSector};
use crate::las::LasPoint;
use crate::matching::MatchInput;
use crate::stems::{Stem, StemConfig, StemDetector, StemFit, THIN_DIAMETER_M, THIN_SPAN_M};

/// How a cloud is cut and searched.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct CloudConfig {
    /// Length of a slice (one matching frame), seconds of GPS time.
    pub slice_s: f64,
    /// Points this long before and after a slice join its search window, seconds: long enough for the
    /// scanner to sweep a stem whole (a profile scanner across the drive sweeps a stem in a few hundredths of
    /// a second; one tilted forward sees it over longer).
    pub margin_s: f64,
    /// Stems farther from the scanner than this give no coordinate update, metres (detection only).
    pub reliable_range_m: f64,
    /// A slice covers the cadastre objects within this of the scanner's position: those no slice matched
    /// are listed as not seen (`cadastre_changes` in the run's observations), metres.
    pub cover_m: f64,
    /// The stem detector. Its defaults here differ from an inventory's ([`StemConfig::default`]) where a
    /// moving scanner sees less than a static survey: a band of 1.05–1.55 m (a stem 10 m away is crossed by
    /// few profiles, each measuring it every 7 cm of height at 0.4°), a base hidden up to 1.2 m (a parked
    /// car between the scanner and the stem), a top from 1.7 m (a crown hanging low). Control needs the
    /// stem's centre, not its full height.
    pub stems: StemConfig,
}

impl Default for CloudConfig {
    fn default() -> Self {
        let stems = StemConfig {
            band_half_m: 0.25,
            max_base_m: 1.2,
            min_top_m: 1.7,
            thin_stems: true,
            ..StemConfig::default()
        };
        Self { slice_s: 1.0, margin_s: 0.5, reliable_range_m: 25.0, cover_m: 10.0, stems }
    }
}

impl CloudConfig {
    /// Check every parameter; the error names the first bad one.
    pub fn check(&self) -> Result<(), String> {
        let fields = [
            ("slice_s", self.slice_s),
            ("margin_s", self.margin_s),
            ("reliable_range_m", self.reliable_range_m),
            ("cover_m", self.cover_m),
        ];
        for (field, value) in fields {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!("clouds.{field} = {value}: expected a finite number > 0"));
            }
        }
        self.stems.check()
    }
}

/// Where the scanner was and how uncertain the DG position is at a time: `None` where the trajectory does not
/// reach (the slice is skipped and counted).
pub trait ScannerTrack {
    /// Scanner centre through the DG pose (mapping frame) and the DG horizontal σ per axis at `time`.
    fn at(&self, time: f64) -> Option<(Vector3<f64>, f64)>;
}

impl<F: Fn(f64) -> Option<(Vector3<f64>, f64)>> ScannerTrack for F {
    fn at(&self, time: f64) -> Option<(Vector3<f64>, f64)> {
        self(time)
    }
}

/// How the frames (time slices) of the manifest's point cloud `i` are named: this prefix and the slice's
/// middle time.
pub fn frame_prefix(i: usize) -> String {
    format!("point_clouds[{i}]@")
}

/// What a [`CloudSlicer`] saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct CloudCounts {
    /// Points received.
    pub points: u64,
    /// Points in a wanted time span's windows (the others were passed over).
    pub used: u64,
    /// Points that arrived after their window was processed (not in time order).
    pub late: u64,
    /// Slices searched.
    pub slices: u64,
    /// Slices off the trajectory.
    pub off_trajectory: u64,
    /// Stems found (each once, in the slice of its scan time).
    pub stems: u64,
    /// Stems of a cloud without GPS time that two passes of the drive came near: not used (their scan time,
    /// so their DG error, is unknown). Counted by every tile that finds them.
    pub ambiguous: u64,
}

/// Cuts a stream of points into slices and finds each slice's stems (see the module).
#[derive(Debug)]
pub struct CloudSlicer<T> {
    config: CloudConfig,
    prefix: String,
    track: T,
    /// Time spans whose slices are searched (sorted, trajectory time scale).
    wanted: Vec<Range<f64>>,
    /// Points of the windows not yet processed.
    window: Vec<LasPoint>,
    /// The next slice to process.
    next: Option<i64>,
    inputs: Vec<MatchInput>,
    counts: CloudCounts,
}

impl<T: ScannerTrack> CloudSlicer<T> {
    /// A slicer searching the slices whose middle lies in one of `wanted` (e.g. a tile's share of the
    /// drive); frames are named `{prefix}{slice middle time}`.
    pub fn new(config: CloudConfig, prefix: &str, track: T, mut wanted: Vec<Range<f64>>) -> Self {
        wanted.sort_by(|a, b| a.start.total_cmp(&b.start));
        Self {
            config,
            prefix: prefix.to_owned(),
            track,
            wanted,
            window: Vec::new(),
            next: None,
            inputs: Vec::new(),
            counts: CloudCounts::default(),
        }
    }

    fn slice_of(&self, t: f64) -> i64 {
        (t / self.config.slice_s).floor() as i64
    }

    fn slice_span(&self, k: i64) -> Range<f64> {
        let s = self.config.slice_s;
        k as f64 * s..(k + 1) as f64 * s
    }

    fn is_wanted(&self, k: i64) -> bool {
        let mid = (k as f64 + 0.5) * self.config.slice_s;
        self.wanted.iter().any(|w| w.contains(&mid))
    }

    /// Whether a point's time is inside the window of a wanted slice (a caller gathering points out of time
    /// order, e.g. from a COPC file's nodes, keeps only these before sorting them).
    pub fn needs(&self, t: f64) -> bool {
        let m = self.config.margin_s + self.config.slice_s;
        self.wanted.iter().any(|w| t >= w.start - m && t < w.end + m)
    }

    /// A batch of points, in time order (within a margin).
    pub fn push(&mut self, batch: &[LasPoint]) {
        for p in batch {
            self.counts.points += 1;
            if !self.needs(p.gps_time) {
                continue;
            }
            let k = self.slice_of(p.gps_time);
            if let Some(next) = self.next
                && self.slice_span(next).start - self.config.margin_s > p.gps_time
            {
                self.counts.late += 1;
                continue;
            }
            self.counts.used += 1;
            let next = *self.next.get_or_insert(k);
            // Every slice whose window ends before this point is complete.
            let mut pending = next;
            while self.slice_span(pending).end + self.config.margin_s <= p.gps_time {
                pending += 1;
            }
            if pending > next {
                self.process_until(pending);
            }
            self.window.push(*p);
        }
    }

    /// Process the slices before `end` that hold points, and drop the points no later window needs.
    fn process_until(&mut self, end: i64) {
        let Some(mut k) = self.next else { return };
        while k < end {
            // Skip over slices without points.
            let first = self.window.iter().map(|p| p.gps_time).fold(f64::INFINITY, f64::min);
            if first.is_finite() {
                k = k.max(self.slice_of(first - self.config.margin_s));
            } else {
                k = end;
                break;
            }
            if k >= end {
                break;
            }
            if self.is_wanted(k) {
                self.process(k);
            }
            k += 1;
            let keep_from = self.slice_span(k).start - self.config.margin_s;
            self.window.retain(|p| p.gps_time >= keep_from);
        }
        self.next = Some(end.max(k));
    }

    /// Find the stems of slice `k` in its window.
    fn process(&mut self, k: i64) {
        let span = self.slice_span(k);
        let m = self.config.margin_s;
        let points: Vec<&LasPoint> =
            self.window.iter().filter(|p| p.gps_time >= span.start - m && p.gps_time < span.end + m).collect();
        if points.is_empty() {
            return;
        }
        self.counts.slices += 1;
        let xyz: Vec<[f64; 3]> = points.iter().map(|p| p.position).collect();
        let mut detector = StemDetector::new(self.config.stems);
        detector.ground(&xyz);
        detector.collect(&xyz);
        detector.surroundings(&xyz);
        let stems: Vec<(Stem, f64)> = detector
            .finish()
            .into_iter()
            .filter_map(|s| scan_time(&s, &points, &self.config.stems).map(|t| (s, t)))
            .filter(|(_, t)| span.contains(t))
            .filter(|(s, t)| s.fit != StemFit::Front || in_front(s, *t, &points, &self.track, &self.config))
            .map(|(s, t)| (thin_centre(s, &self.track, t), t))
            .collect();
        let time = if stems.is_empty() {
            0.5 * (span.start + span.end)
        } else {
            stems.iter().map(|(_, t)| t).sum::<f64>() / stems.len() as f64
        };
        let frame = format!("{}{:.1}", self.prefix, 0.5 * (span.start + span.end));
        let stems: Vec<&Stem> = stems.iter().map(|(s, _)| s).collect();
        match slice_input(frame, time, &stems, &self.track, &self.config) {
            Some(input) => {
                self.counts.stems += stems.len() as u64;
                self.inputs.push(input);
            }
            None => self.counts.off_trajectory += 1,
        }
    }

    /// Process what is left; the frames (in time order) and the counts.
    pub fn finish(mut self) -> (Vec<MatchInput>, CloudCounts) {
        self.process_until(i64::MAX);
        (self.inputs, self.counts)
    }
}

/// Epochs of a drive by position: the time the DG trajectory passed nearest to a point, for clouds without
/// GPS time. Positions are kept every `spacing_m` of driving, in a grid of 10 m cells.
#[derive(Debug)]
pub struct PassIndex {
    cells: std::collections::HashMap<(i64, i64), Vec<Position>>,
}

/// A kept drive position: time, (east, north).
type Position = (f64, [f64; 2]);

/// Cell of a [`PassIndex`], metres.
const PASS_CELL_M: f64 = 10.0;
/// Positions this far apart in time belong to different passes, seconds.
pub const PASS_GAP_S: f64 = 5.0;
/// Another pass this much farther than the nearest still makes the nearest ambiguous, metres.
pub const PASS_MARGIN_M: f64 = 5.0;

/// When the drive passed a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pass {
    /// Never within reach.
    None,
    /// Nearest at this time, no other pass nearly as close.
    At(f64),
    /// Two passes nearly as close: the time is unknown.
    Ambiguous,
}

impl PassIndex {
    /// The positions `(time, [east, north])` (in time order), one kept every `spacing_m`.
    pub fn new(positions: impl IntoIterator<Item = (f64, [f64; 2])>, spacing_m: f64) -> Self {
        let mut cells: std::collections::HashMap<(i64, i64), Vec<Position>> = Default::default();
        let mut last: Option<[f64; 2]> = None;
        for (t, p) in positions {
            if last.is_some_and(|l| (l[0] - p[0]).hypot(l[1] - p[1]) < spacing_m) {
                continue;
            }
            last = Some(p);
            cells.entry(Self::cell(p)).or_default().push((t, p));
        }
        Self { cells }
    }

    fn cell(p: [f64; 2]) -> (i64, i64) {
        ((p[0] / PASS_CELL_M).floor() as i64, (p[1] / PASS_CELL_M).floor() as i64)
    }

    /// The time the drive passed nearest to `p` within `reach_m`: `Pass::None` when it never came that close,
    /// `Pass::Ambiguous` when another pass (more than [`PASS_GAP_S`] apart) came within [`PASS_MARGIN_M`] of
    /// that distance too — the point may have been scanned from either, with either pass's DG error.
    pub fn nearest(&self, p: [f64; 2], reach_m: f64) -> Pass {
        let (ci, cj) = Self::cell(p);
        let r = ((reach_m + PASS_MARGIN_M) / PASS_CELL_M).ceil() as i64;
        let near: Vec<(f64, f64)> = (-r..=r)
            .flat_map(|di| (-r..=r).map(move |dj| (ci + di, cj + dj)))
            .filter_map(|k| self.cells.get(&k))
            .flatten()
            .map(|(t, q)| ((q[0] - p[0]).hypot(q[1] - p[1]), *t))
            .collect();
        let Some(&(d, t)) = near.iter().filter(|(d, _)| *d <= reach_m).min_by(|a, b| a.0.total_cmp(&b.0)) else {
            return Pass::None;
        };
        if near.iter().any(|&(e, u)| e <= d + PASS_MARGIN_M && (u - t).abs() > PASS_GAP_S) {
            Pass::Ambiguous
        } else {
            Pass::At(t)
        }
    }
}

/// Stems of a cloud without GPS time (a merged or tiled product) as matching frames: each stem takes the time
/// the drive passed nearest to it (within `reach_m`), and is kept when that time lies in one of `wanted` and
/// no other pass came nearly as close ([`PassIndex::nearest`]) — weaker than GPS time all the same: a stem
/// scanned from farther away on another pass carries that pass's DG error. Stems are then grouped into slices of `config.slice_s` like timed ones.
pub fn untimed_inputs(
    stems: &[Stem],
    passes: &PassIndex,
    reach_m: f64,
    wanted: &[Range<f64>],
    prefix: &str,
    track: &impl ScannerTrack,
    config: &CloudConfig,
) -> (Vec<MatchInput>, CloudCounts) {
    let mut counts = CloudCounts::default();
    let mut timed: Vec<(f64, Stem)> = Vec::new();
    for s in stems {
        match passes.nearest(s.centre, reach_m) {
            Pass::At(t) if wanted.iter().any(|w| w.contains(&t)) => timed.push((t, thin_centre(s.clone(), track, t))),
            Pass::Ambiguous => counts.ambiguous += 1,
            _ => {}
        }
    }
    timed.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut inputs = Vec::new();
    for group in timed.chunk_by(|a, b| (a.0 / config.slice_s).floor() == (b.0 / config.slice_s).floor()) {
        counts.slices += 1;
        let time = group.iter().map(|(t, _)| t).sum::<f64>() / group.len() as f64;
        let frame = format!("{prefix}{:.1}", ((time / config.slice_s).floor() + 0.5) * config.slice_s);
        let stems: Vec<&Stem> = group.iter().map(|(_, s)| s).collect();
        match slice_input(frame, time, &stems, track, config) {
            Some(input) => {
                counts.stems += stems.len() as u64;
                inputs.push(input);
            }
            None => counts.off_trajectory += 1,
        }
    }
    (inputs, counts)
}

/// A slice's stems as the matcher's frame at `time`, seen from the scanner's DG position then (`None` off the
/// trajectory). Its view is the circle of `cover_m` around that position: the cadastre poles in it the slice
/// did not match are its unseen ones (a pole stays in view of two or three slices and is matched in one;
/// whoever reads the reports takes the unseen that no slice matched).
fn slice_input(
    frame: String,
    time: f64,
    stems: &[&Stem],
    track: &impl ScannerTrack,
    config: &CloudConfig,
) -> Option<MatchInput> {
    let reliable_range_m = config.reliable_range_m;
    let (origin, dg_sigma_m) = track.at(time)?;
    let ground =
        plumbline_geo::metrics::median(&mut stems.iter().map(|s| s.ground_m).collect::<Vec<_>>()).unwrap_or(origin.z);
    let detections = stems.iter().map(|s| detection(s, &origin, reliable_range_m)).collect();
    let view = ViewSector {
        origin: [origin.x, origin.y],
        from_rad: 0.0,
        width_rad: std::f64::consts::TAU,
        max_range_m: config.cover_m,
    };
    Some(MatchInput {
        frame,
        time,
        dg_sigma_m,
        detections: FrameDetections { ground_height_m: ground, view, detections },
    })
}

/// Scan lines within this time of a thin stem's are its neighbours, s (±6 profiles at 200 Hz, ±0.3 m of
/// driving at 10 m/s).
const NEIGHBOUR_S: f64 = 0.03;
/// A neighbour's beam within this horizontal bearing of a thin stem's, seen from the scanner, points at it,
/// rad (3°)…
const NEIGHBOUR_BEARING_RAD: f64 = 0.052;
/// …when its elevation angle lies within those of the stem's band points widened by this, rad (0.5°, about a
/// profile scanner's angular step: a parked car's roof below the beam to a post does not count).
const NEIGHBOUR_ELEVATION_RAD: f64 = 0.0087;
/// A neighbour's point this much nearer to the scanner than a thin stem lies in front of it, m.
const NEARER_M: f64 = 0.15;
/// Points in front of a thin stem spanning this much height stand upright: a wall, m. (Flat ones — the roof of
/// a car parked by a post, met by the beams just beside it — lie at one height.)
const UPRIGHT_M: f64 = 0.2;

/// Whether a thin stem ([`StemFit::Front`]) lies within `reliable_range_m` of the scanner and stands in front
/// of what the neighbouring scan lines hit: along the
/// beams that met its band, the profiles beside it meet no upright surface nearer to the scanner (three points
/// or more spanning `UPRIGHT_M` of height). A post crossed by one or two profiles is a foreground object — the
/// beams beside it reach past it — while a wall grazed by single profiles looks like a post in each, and the
/// profiles on one side hit it nearer, all up the band. (A parked car in front of a post is met by steeper
/// beams and does not count; the flat roof of one beside it may be met by the same beams, at one height.)
/// The end of a free-standing wall grazed this way passes: nothing stands in front of its first scan line.
fn in_front(stem: &Stem, time: f64, points: &[&LasPoint], track: &impl ScannerTrack, config: &CloudConfig) -> bool {
    let Some((s, _)) = track.at(time) else { return false };
    let c = &config.stems;
    let near: Vec<&LasPoint> = points.iter().copied().filter(|p| (p.gps_time - time).abs() <= NEIGHBOUR_S).collect();
    // The horizontal angle between the beams to `p` and to the stem's centre.
    let (ux, uy) = (stem.centre[0] - s.x, stem.centre[1] - s.y);
    let off_beam = |p: &[f64; 3]| {
        let (vx, vy) = (p[0] - s.x, p[1] - s.y);
        (ux * vy - uy * vx).atan2(ux * vx + uy * vy).abs()
    };
    let range = |p: &[f64; 3]| (p[0] - s.x).hypot(p[1] - s.y);
    let elevation = |p: &[f64; 3]| (p[2] - s.z).atan2(range(p));
    let rho = range(&[stem.centre[0], stem.centre[1], 0.0]);
    if rho > config.reliable_range_m {
        return false;
    }
    let band = stem.ground_m + c.breast_height_m - c.band_half_m..stem.ground_m + c.breast_height_m + c.band_half_m;
    let reach = 0.5 * THIN_SPAN_M + 0.03;
    let on_stem = |p: &[f64; 3]| (p[0] - stem.centre[0]).hypot(p[1] - stem.centre[1]) <= reach;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in near.iter().filter(|p| on_stem(&p.position) && band.contains(&p.position[2])) {
        let e = elevation(&p.position);
        (lo, hi) = (lo.min(e), hi.max(e));
    }
    if lo > hi {
        return false;
    }
    let beams = lo - NEIGHBOUR_ELEVATION_RAD..hi + NEIGHBOUR_ELEVATION_RAD;
    let (mut nearer, mut low, mut high) = (0usize, f64::INFINITY, f64::NEG_INFINITY);
    for p in near.iter().map(|p| &p.position) {
        if !on_stem(p)
            && beams.contains(&elevation(p))
            && off_beam(p) <= NEIGHBOUR_BEARING_RAD
            && range(p) < rho - NEARER_M
        {
            nearer += 1;
            (low, high) = (low.min(p[2]), high.max(p[2]));
        }
    }
    nearer < 3 || high - low < UPRIGHT_M
}

/// A thin stem's centre ([`StemFit::Front`]: the mean of its near face) moved away from the scanner's position
/// at `time` by 2/π of the reported radius — where the axis of a cylinder lies behind the mean of its
/// evenly swept near half — with the covariance that leaves: `THIN_ALONG_BEAM_SIGMA_M` along the beam (the
/// radius is not measured) and `THIN_ACROSS_BEAM_SIGMA_M` across it (where the scan line crossed the stem).
/// A circle-fitted stem, or one scanned off the trajectory, is returned as it is.
fn thin_centre(mut stem: Stem, track: &impl ScannerTrack, time: f64) -> Stem {
    if stem.fit != StemFit::Front {
        return stem;
    }
    if let Some((scanner, _)) = track.at(time) {
        let (dx, dy) = (stem.centre[0] - scanner.x, stem.centre[1] - scanner.y);
        let d = dx.hypot(dy);
        if d > 0.5 {
            let (ux, uy) = (dx / d, dy / d);
            let back = THIN_DIAMETER_M / std::f64::consts::PI;
            stem.centre = [stem.centre[0] + back * ux, stem.centre[1] + back * uy];
            let (along, across) = (THIN_ALONG_BEAM_SIGMA_M.powi(2), THIN_ACROSS_BEAM_SIGMA_M.powi(2));
            stem.covariance = [
                [along * ux * ux + across * uy * uy, (along - across) * ux * uy],
                [(along - across) * ux * uy, along * uy * uy + across * ux * ux],
            ];
        }
    }
    stem
}

/// σ along the beam of a thin stem's centre moved back from its face, m: 2/π of a radius of 2–6 cm against
/// the 4 cm assumed, with the face's range noise.
const THIN_ALONG_BEAM_SIGMA_M: f64 = 0.01;
/// σ across the beam of a thin stem's centre, m: one or two scan lines cross a stem of 2–6 cm radius
/// anywhere within it (a uniform spread over ±4 cm has σ 2.3 cm).
const THIN_ACROSS_BEAM_SIGMA_M: f64 = 0.02;

/// The mean GPS time of a stem's band points (within 5 cm of its circle): when it was scanned.
fn scan_time(stem: &Stem, points: &[&LasPoint], c: &StemConfig) -> Option<f64> {
    let r = 0.5 * stem.diameter_m + 0.05;
    let band = stem.ground_m + c.breast_height_m - c.band_half_m..stem.ground_m + c.breast_height_m + c.band_half_m;
    let (mut sum, mut n) = (0.0, 0usize);
    for p in points {
        let [x, y, z] = p.position;
        if band.contains(&z) && (x - stem.centre[0]).hypot(y - stem.centre[1]) <= r {
            sum += p.gps_time;
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// A stem as the matcher's detection, its range from the scanner at the slice's time.
fn detection(s: &Stem, origin: &Vector3<f64>, reliable_range_m: f64) -> Detection {
    let range_m = (s.centre[0] - origin.x).hypot(s.centre[1] - origin.y);
    Detection {
        centre: s.centre,
        covariance: s.covariance,
        diameter_m: s.diameter_m,
        diameter_sigma_m: s.diameter_sigma_m,
        height_extent_m: s.extent_m,
        ground_height_m: s.ground_m,
        points: s.points,
        range_m,
        lean: s.lean,
        slices: ((s.extent_m[1] - s.extent_m[0]) / 0.2).round() as usize,
        reliable: range_m <= reliable_range_m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pole of 0.3 m at (5, 20) swept by 200 profiles/s across a drive along north at 10 m/s from t = 100 s.
    fn swept_pole() -> Vec<LasPoint> {
        let mut out = Vec::new();
        for i in 0..800 {
            let t = 100.0 + f64::from(i) * 0.005;
            let y = 10.0 * (t - 100.0);
            // Ground points across the street.
            for k in 0..60 {
                out.push(LasPoint { position: [-6.0 + 0.2 * f64::from(k), y, 0.0], gps_time: t });
            }
            // The pole's face toward the drive line (radius 0.15 m) where the profile crosses it.
            let dy = y - 20.0;
            if dy.abs() < 0.15 {
                let x = 5.0 - (0.0225 - dy * dy).sqrt();
                for h in 0..100 {
                    out.push(LasPoint { position: [x, y, 0.05 * f64::from(h)], gps_time: t });
                }
            }
        }
        out
    }

    #[test]
    fn a_swept_pole_is_one_detection_in_the_slice_of_its_scan_time() {
        let points = swept_pole();
        let track = |t: f64| Some((Vector3::new(0.0, 10.0 * (t - 100.0), 2.5), 0.3));
        let mut slicer = CloudSlicer::new(CloudConfig::default(), "c:", track, vec![0.0..1e9]);
        for batch in points.chunks(1000) {
            slicer.push(batch);
        }
        let (inputs, counts) = slicer.finish();
        assert_eq!(counts.late, 0);
        let found: Vec<(&MatchInput, &Detection)> =
            inputs.iter().flat_map(|i| i.detections.detections.iter().map(move |d| (i, d))).collect();
        assert_eq!(found.len(), 1, "{counts:?}");
        let (input, d) = found[0];
        assert!((input.time - 102.0).abs() < 0.02, "{}", input.time);
        assert!((d.centre[0] - 5.0).hypot(d.centre[1] - 20.0) < 0.02, "{d:?}");
        assert!((d.range_m - 5.0).abs() < 0.1, "{d:?}");
    }

    #[test]
    fn untimed_stems_take_the_time_the_drive_passed_nearest() {
        // The drive along north at 10 m/s from t = 100 s; the pole at (5, 20) is passed at t = 102 s.
        let passes = PassIndex::new((0..400).map(|i| (100.0 + f64::from(i) * 0.01, [0.0, 0.1 * f64::from(i)])), 0.5);
        assert_eq!(passes.nearest([5.0, 20.0], 15.0), Pass::At(102.0));
        assert_eq!(passes.nearest([50.0, 20.0], 15.0), Pass::None);
        // The drive back along x = 8 twenty seconds later: the pole between the two passes is ambiguous.
        let back = (0..400).map(|i| (120.0 + f64::from(i) * 0.01, [8.0, 40.0 - 0.1 * f64::from(i)]));
        let both =
            PassIndex::new((0..400).map(|i| (100.0 + f64::from(i) * 0.01, [0.0, 0.1 * f64::from(i)])).chain(back), 0.5);
        assert_eq!(both.nearest([5.0, 20.0], 15.0), Pass::Ambiguous);
        assert_eq!(both.nearest([-3.0, 20.0], 15.0), Pass::At(102.0));
        let mut detector = StemDetector::new(CloudConfig::default().stems);
        let xyz: Vec<[f64; 3]> = swept_pole().iter().map(|p| p.position).collect();
        detector.ground(&xyz);
        detector.collect(&xyz);
        detector.surroundings(&xyz);
        let stems = detector.finish();
        let track = |t: f64| Some((Vector3::new(0.0, 10.0 * (t - 100.0), 2.5), 0.3));
        let (inputs, counts) =
            untimed_inputs(&stems, &passes, 15.0, &[0.0..1e9], "c:", &track, &CloudConfig::default());
        assert_eq!((inputs.len(), counts.stems), (1, 1));
        assert_eq!(inputs[0].time, 102.0);
        assert!((inputs[0].detections.detections[0].range_m - 5.0).abs() < 0.1);
    }

    /// A profile scanner 2.5 m up, driving north along x = 0 at 10 m/s from t = 100 s, 200 profiles/s, its
    /// beams every 0.4° in the plane across the drive (right side): the ground, a sign post of 6 cm at
    /// (8, 20) that only the profile at y = 20 crosses, and a building from y = 30 on: its front along
    /// x = 6 from its corner (6, 30.5) north, and its side wall, facing the scanner as it comes, grazed at 3.6°
    /// from that corner to (14, 30): each profile meets the side wall at one place, 0.8 m from the next one's.
    fn thin_post_and_grazed_wall() -> Vec<LasPoint> {
        let (post, r) = ([8.0, 20.0], 0.03);
        let mut out = Vec::new();
        for i in 0..800 {
            let t = 100.0 + f64::from(i) * 0.005;
            let y = 0.05 * f64::from(i);
            let dy: f64 = y - post[1];
            let post_x = (dy.abs() < r).then(|| post[0] - (r * r - dy * dy).sqrt());
            let wall_x = (30.0..=30.5).contains(&y).then(|| 6.0 + (30.5 - y) / 0.0625);
            let front_x = (y >= 30.5).then_some(6.0);
            for k in 0..225 {
                let e = (-60.0 + 0.4 * f64::from(k)).to_radians();
                let z_at = |x: f64| 2.5 + x * e.tan();
                let mut hit: Option<f64> = (e < 0.0).then(|| -2.5 / e.tan()).filter(|&x| x <= 60.0);
                for (x, top) in [(post_x, 3.0), (wall_x, 5.0), (front_x, 5.0)] {
                    if let Some(x) = x.filter(|&x| (0.0..=top).contains(&z_at(x))) {
                        hit = Some(hit.map_or(x, |h| h.min(x)));
                    }
                }
                if let Some(x) = hit {
                    out.push(LasPoint { position: [x, y, z_at(x).max(0.0)], gps_time: t });
                }
            }
        }
        out
    }

    #[test]
    fn a_thin_post_crossed_by_one_profile_is_found_and_a_grazed_wall_is_not() {
        let points = thin_post_and_grazed_wall();
        let track = |t: f64| Some((Vector3::new(0.0, 10.0 * (t - 100.0), 2.5), 0.3));
        let detections = |config: CloudConfig| {
            let mut slicer = CloudSlicer::new(config, "c:", track, vec![0.0..1e9]);
            for batch in points.chunks(5000) {
                slicer.push(batch);
            }
            let (inputs, _) = slicer.finish();
            inputs.into_iter().flat_map(|i| i.detections.detections).collect::<Vec<Detection>>()
        };
        let found = detections(CloudConfig::default());
        assert_eq!(found.len(), 1, "{found:?}");
        let d = &found[0];
        // The face's mean lies 3 cm before the axis; moved back by 2/π of the reported 4 cm radius.
        assert!((d.centre[0] - 8.0).hypot(d.centre[1] - 20.0) < 0.01, "{d:?}");
        assert_eq!(d.diameter_m, THIN_DIAMETER_M);
        // Along the beam (east) the radius is not measured; across it (north) the crossing is not known.
        assert!((d.covariance[0][0] - THIN_ALONG_BEAM_SIGMA_M.powi(2)).abs() < 1e-9, "{d:?}");
        assert!((d.covariance[1][1] - THIN_ACROSS_BEAM_SIGMA_M.powi(2)).abs() < 1e-9, "{d:?}");
        // Without thin stems the post is not seen at all, and the wall never was.
        let circles = CloudConfig {
            stems: StemConfig { thin_stems: false, ..CloudConfig::default().stems },
            ..CloudConfig::default()
        };
        assert!(detections(circles).is_empty());
    }

    #[test]
    fn slices_outside_the_wanted_spans_are_passed_over() {
        let points = swept_pole();
        let track = |t: f64| Some((Vector3::new(0.0, 10.0 * (t - 100.0), 2.5), 0.3));
        let mut slicer = CloudSlicer::new(CloudConfig::default(), "c:", track, vec![104.0..105.0]);
        slicer.push(&points);
        let (inputs, counts) = slicer.finish();
        assert!(inputs.iter().all(|i| i.detections.detections.is_empty()));
        assert_eq!(counts.stems, 0);
        assert!(counts.used < counts.points);
    }
}
