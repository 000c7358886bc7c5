//! What the tracking of strokes into pieces (`assemble`) and the classification of pieces into road lines
//! (`lines`) share: a [`Piece`] and the settings of both steps ([`AssembleConfig`]). At the bottom of both: it
//! imports neither.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Settings of the assembly.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct AssembleConfig {
    /// Spacing of the samples along each observation, metres.
    pub sample_m: f64,
    /// Two strokes are one element when samples lie within this across of each other, metres …
    pub link_across_m: f64,
    /// … or within this many combined σ, …
    pub link_sigmas: f64,
    /// … but never farther than this across, metres (the two lines of an arterial centre are 0.3 m apart).
    pub link_across_max_m: f64,
    /// … and within this along, metres …
    pub link_along_m: f64,
    /// … with directions within this angle, degrees.
    pub link_angle_deg: f64,
    /// Spacing of a piece's vertices along its centre line, metres.
    pub vertex_step_m: f64,
    /// An observation's end within this of a piece's end (along) belongs to that end, metres.
    pub end_m: f64,
    /// A wide piece more than this angle off the driving direction is a stop line, degrees.
    pub across_deg: f64,
    /// Pieces at least this wide are stop lines or zebra stripes, metres.
    pub wide_m: f64,
    /// Longest zebra stripe, metres.
    pub zebra_max_m: f64,
    /// Longest dash, metres.
    pub dash_max_m: f64,
    /// Shortest gap between consecutive dashes, metres.
    pub gap_min_m: f64,
    /// Longest gap between consecutive dashes (a missed dash included), metres.
    pub gap_max_m: f64,
    /// Largest lateral offset between consecutive dashes, metres.
    pub dash_offset_m: f64,
    /// Largest angle between a dash's end direction and the chord to the next dash, degrees. On a curve
    /// this is half the turn across the gap: 10° lets a 60 m radius keep a 15 m gap (a dash missed).
    pub dash_angle_deg: f64,
    /// Shortest solid line, metres.
    pub solid_min_m: f64,
}

impl Default for AssembleConfig {
    fn default() -> Self {
        Self {
            sample_m: 0.2,
            link_across_m: 0.08,
            link_sigmas: 3.0,
            link_across_max_m: 0.2,
            link_along_m: 0.3,
            link_angle_deg: 5.0,
            vertex_step_m: 0.5,
            end_m: 0.4,
            across_deg: 60.0,
            wide_m: 0.3,
            zebra_max_m: 5.0,
            dash_max_m: 6.0,
            gap_min_m: 1.0,
            gap_max_m: 15.0,
            dash_offset_m: 0.15,
            dash_angle_deg: 10.0,
            solid_min_m: 6.0,
        }
    }
}

/// One painted element observed in one or more panoramas: its centre line.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Piece {
    /// Centre-line vertices, easting/northing, metres, in order along the element.
    pub vertices: Vec<[f64; 2]>,
    /// 1σ across the line of each vertex, metres.
    pub sigma_m: Vec<f64>,
    /// Painted width (median over the observations), metres.
    pub width_m: f64,
    /// Number of strokes united in the piece.
    pub observations: usize,
    /// Number of distinct panoramas that saw it.
    pub panoramas: usize,
    /// Whether the start / end was seen as the element's true end by at least one observation.
    pub closed: [bool; 2],
}
