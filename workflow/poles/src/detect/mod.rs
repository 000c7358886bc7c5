//! Vertical-structure detection (future work in Meyer et al. 2023, done automatically): height slices above the local
//! ground, per slice a polar range profile around the sensor in which a pole is a narrow dip in front of its
//! background, slices stacked into vertical structures, then per structure the shaft's points, a verticality
//! test, the diameter from the angular width and the centre with its covariance from the range error model
//! (Meyer et al. 2023 §3.1.2). Facades and cars are wide, kerbs low: none of them is a narrow dip over ≥ 4 slices.

mod ground;
mod profile;
mod refine;
mod stack;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::points::FramePoints;

/// Parameters of the detector.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DetectConfig {
    /// Thickness of a height slice, metres.
    pub slice_m: f64,
    /// Heights above the local ground searched for shafts: [from, to], metres (above kerbs; up to 4.1 m so
    /// that a shaft seen only above a parked car, ~1.5 m, still spans enough slices; not higher, where
    /// leaning trunks move away from their base and crowns begin).
    pub band_m: [f64; 2],
    /// Slices a structure must span (with `slice_m` = 0.2: 0.8 m of shaft in front of its background; thin
    /// slices let a shaft seen over ~1 m between a car roof and its top fill whole slices). The centre uses
    /// only these slices' points (below them a car or wall may stand in front of the shaft).
    pub min_slices: usize,
    /// Widest object taken for a pole, metres.
    pub max_diameter_m: f64,
    /// Smallest range gap between a shaft and its background, metres.
    pub min_gap_m: f64,
    /// The gap must also exceed this many standard deviations of the profile's noise.
    pub gap_sigmas: f64,
    /// Profile bins on each side that make the background.
    pub background_bins: usize,
    /// Largest lean from the vertical, metres per metre (trees lean a few degrees).
    pub max_lean: f64,
    /// Fewest shaft points of a detection.
    pub min_points: usize,
    /// Farthest horizontal range searched, metres; a detection whose centre lies beyond it is dropped (only
    /// the near tail of its range noise was kept, so its centre is biased towards the sensor).
    pub max_range_m: f64,
    /// Standard deviation added to each centre coordinate for unmodelled effects, metres.
    pub floor_sigma_m: f64,
}

impl Default for DetectConfig {
    fn default() -> Self {
        Self {
            slice_m: 0.2,
            band_m: [0.3, 4.1],
            min_slices: 4,
            max_diameter_m: 0.8,
            min_gap_m: 0.6,
            gap_sigmas: 3.0,
            background_bins: 4,
            max_lean: 0.12,
            min_points: 12,
            max_range_m: 10.0,
            floor_sigma_m: 0.01,
        }
    }
}

/// One detected pole-like object, in the mapping frame of the pose the points were georeferenced with.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Detection {
    /// Centre of the cross-section (easting, northing), metres.
    pub centre: [f64; 2],
    /// Covariance of the centre from the range error model, m² (row-major, symmetric).
    pub covariance: [[f64; 2]; 2],
    /// Diameter from the angular width, metres.
    pub diameter_m: f64,
    /// Standard deviation of the diameter, metres.
    pub diameter_sigma_m: f64,
    /// Lowest and highest shaft point above the local ground, metres.
    pub height_extent_m: [f64; 2],
    /// Height of the local ground, metres.
    pub ground_height_m: f64,
    /// Shaft points in the search band the centre is estimated from.
    pub points: usize,
    /// Horizontal range from the sensor to the centre, metres.
    pub range_m: f64,
    /// Estimated lean, metres per metre.
    pub lean: f64,
    /// Height slices the structure spans.
    pub slices: usize,
    /// False when the range lies where the sensor's range cut-off biases the points (no CUPT from it).
    pub reliable: bool,
}

impl Detection {
    /// √(trace / 2): the per-coordinate standard deviation of the centre (err_cam of Meyer et al. 2023 eq. (1)).
    pub fn sigma(&self) -> f64 {
        (0.5 * (self.covariance[0][0] + self.covariance[1][1])).max(0.0).sqrt()
    }
}

/// The horizontal sector a frame saw: bearings counter-clockwise from east (atan2(north, east)), radians.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ViewSector {
    /// Sensor position (easting, northing), metres.
    pub origin: [f64; 2],
    /// Bearing of the sector's first edge, radians.
    pub from_rad: f64,
    /// Angular width of the sector, radians (counter-clockwise from `from_rad`).
    pub width_rad: f64,
    /// Range searched, metres.
    pub max_range_m: f64,
}

impl ViewSector {
    /// Whether a point lies in the sector, `margin_rad` inside its edges (a full circle has none).
    pub fn contains(&self, p: [f64; 2], margin_rad: f64) -> bool {
        let (dx, dy) = (p[0] - self.origin[0], p[1] - self.origin[1]);
        let off = (dy.atan2(dx) - self.from_rad).rem_euclid(std::f64::consts::TAU);
        let full = self.width_rad >= std::f64::consts::TAU;
        dx.hypot(dy) <= self.max_range_m && (full || (off >= margin_rad && off <= self.width_rad - margin_rad))
    }
}

/// What the detector found in one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameDetections {
    /// Height of the local ground, metres.
    pub ground_height_m: f64,
    /// The sector searched.
    pub view: ViewSector,
    /// The detections.
    pub detections: Vec<Detection>,
}

/// Why a frame gave no detections.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DetectError {
    /// Too few points below the sensor to find the ground.
    #[error("no ground found: {points} points below the sensor (need 30)")]
    NoGround {
        /// Points below the sensor.
        points: usize,
    },
    /// A parameter is out of its domain.
    #[error("detector parameter `{field}` = {value}: {expected}")]
    Config {
        /// The parameter.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What is expected.
        expected: &'static str,
    },
}

/// The local ground height of a frame: the lowest clear peak of the heights of the points below the sensor.
pub fn estimate_ground(frame: &FramePoints, config: &DetectConfig) -> Result<f64, DetectError> {
    ground::estimate(frame, config.max_range_m)
}

/// Detect pole-like objects in one frame's points, on its own ground estimate.
pub fn detect(frame: &FramePoints, config: &DetectConfig) -> Result<FrameDetections, DetectError> {
    check(frame, config)?;
    let ground = ground::estimate(frame, config.max_range_m)?;
    detect_on_ground(frame, config, ground)
}

/// Detect pole-like objects in one frame's points above a given ground height (see
/// [`ground_from_neighbours`] for frames whose ground is hidden, e.g. by a parked car).
pub fn detect_on_ground(
    frame: &FramePoints,
    config: &DetectConfig,
    ground: f64,
) -> Result<FrameDetections, DetectError> {
    check(frame, config)?;
    let polar = profile::Polar::new(frame, config.max_range_m);
    let slices = profile::slice_profiles(frame, &polar, ground, config);
    let runs = slices.iter().enumerate().flat_map(|(s, p)| profile::dips(p, s, &polar, config)).collect::<Vec<_>>();
    let stacks = stack::stack(runs, config);
    let detections = distinct(stacks.iter().filter_map(|s| refine::refine(frame, &polar, ground, s, config)).collect());
    Ok(FrameDetections { ground_height_m: ground, view: polar.sector(frame, config.max_range_m), detections })
}

/// Frames on each side whose sensor heights above ground vote on a frame's ground.
pub const GROUND_WINDOW: usize = 10;
/// A frame's own ground is kept when its sensor height is within this of the neighbours' median, metres.
const GROUND_TOLERANCE_M: f64 = 0.3;

/// Ground heights for a sequence of frames: each frame's own estimate, unless the sensor's height above it
/// differs from the median of the surrounding frames by more than 0.3 m (a car roof or a wall taken for the
/// ground, or no ground visible); then the sensor height minus that median. `None` only when no frame of
/// the window has a ground.
pub fn ground_from_neighbours(origins_z: &[f64], own: &[Option<f64>]) -> Vec<Option<f64>> {
    (0..own.len()).map(|k| ground_among_neighbours(k, origins_z, own)).collect()
}

/// Frame `k`'s entry of [`ground_from_neighbours`]: it reads frames `k - 10 ..= k + 10` only, so a stream of
/// frames can settle frame `k` once frame `k + 10` has arrived (or the stream ended).
pub fn ground_among_neighbours(k: usize, origins_z: &[f64], own: &[Option<f64>]) -> Option<f64> {
    let height = |j: usize| own.get(j).copied().flatten().map(|g| origins_z[j] - g);
    let lo = k.saturating_sub(GROUND_WINDOW);
    let hi = (k + GROUND_WINDOW + 1).min(own.len());
    let mut window: Vec<f64> = (lo..hi).filter_map(height).collect();
    window.sort_by(f64::total_cmp);
    let median = window.get(window.len() / 2).copied();
    match (height(k), median) {
        (Some(h), Some(m)) if (h - m).abs() <= GROUND_TOLERANCE_M => own[k],
        (_, Some(m)) => Some(origins_z[k] - m),
        (_, None) => None,
    }
}

/// Closest two detections of one frame may be, metres (the synthetic and real minimum spacing is 1.5 m).
const MIN_SEPARATION_M: f64 = 0.5;

/// One detection per structure: of detections closer than `MIN_SEPARATION_M` (a shaft split into two
/// stacks), the one with the most points.
fn distinct(mut found: Vec<Detection>) -> Vec<Detection> {
    found.sort_by_key(|d| std::cmp::Reverse(d.points));
    let mut kept: Vec<Detection> = Vec::with_capacity(found.len());
    for d in found {
        let near = |k: &Detection| (k.centre[0] - d.centre[0]).hypot(k.centre[1] - d.centre[1]) < MIN_SEPARATION_M;
        if !kept.iter().any(near) {
            kept.push(d);
        }
    }
    kept
}

fn check(frame: &FramePoints, c: &DetectConfig) -> Result<(), DetectError> {
    let bad = |field, value, expected| Err(DetectError::Config { field, value, expected });
    let positive = [
        ("slice_m", c.slice_m),
        ("max_diameter_m", c.max_diameter_m),
        ("max_range_m", c.max_range_m),
        ("angular_step", frame.angular_step),
    ];
    for (field, value) in positive {
        if !(value.is_finite() && value > 0.0) {
            return bad(field, value, "must be positive and finite");
        }
    }
    if !(c.band_m[1] > c.band_m[0] && c.band_m.iter().all(|v| v.is_finite())) {
        return bad("band_m", c.band_m[1], "must be finite with band_m[1] > band_m[0]");
    }
    if frame.angular_step < 1e-5 {
        return bad("angular_step", frame.angular_step, "must be ≥ 1e-5 rad");
    }
    if c.min_slices == 0 {
        return bad("min_slices", 0.0, "must be ≥ 1");
    }
    Ok(())
}
