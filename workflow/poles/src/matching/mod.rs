//! Matching detections to the cadastre. All detections of a frame share one offset (the
//! DG position error), so the offset is estimated jointly: every detection–cadastre pair inside the DG gate
//! proposes a translation, and the translation supported by the most pole tracks of the surrounding frames
//! wins (RANSAC over the common translation, exhaustive since the candidates are few). A frame whose best
//! offset has an equally supported rival is ambiguous and gets no matches; a detection is matched only when
//! its nearest cadastre pole after the offset is an inlier and the second nearest is not (ratio test).
//! Unmatched detections and cadastre poles in view that were not seen are reported, never forced. Only
//! detections within the sensor's reliable range propose and vote on offsets (a range cut-off biases the
//! others); they are still assigned once the offset is known.

mod assign;
mod index;
mod track;

use plumbline_campaign::CadastreFeature;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::detect::FrameDetections;

/// One frame's detections with what the matcher needs to know about its pose.
#[derive(Clone, Debug, PartialEq)]
pub struct MatchInput {
    /// Frame (image) id.
    pub frame: String,
    /// Epoch, trajectory time scale, seconds.
    pub time: f64,
    /// Horizontal one-sigma uncertainty of the DG position (per axis), metres.
    pub dg_sigma_m: f64,
    /// The detections, georeferenced with the DG pose.
    pub detections: FrameDetections,
}

/// Parameters of the matcher.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MatchConfig {
    /// The gate is this many DG sigmas (per axis, radially), clamped to `min_gate_m`–`max_gate_m`, plus
    /// `inlier_sigmas` of the pair's own σ (the detection's and the cadastre object's accuracy together).
    pub gate_sigmas: f64,
    /// Smallest DG part of the gate radius, metres.
    pub min_gate_m: f64,
    /// Largest DG part of the gate radius, metres.
    pub max_gate_m: f64,
    /// Inlier tolerance in standard deviations of detection, cadastre and frame-to-frame DG change.
    pub inlier_sigmas: f64,
    /// Change of the DG error between neighbouring frames, one sigma per axis, metres.
    pub relative_sigma_m: f64,
    /// Frames on each side whose tracks vote on a frame's offset.
    pub window: usize,
    /// The second-nearest cadastre pole must be this many times farther than the nearest.
    pub ratio: f64,
    /// Detections of consecutive frames link into a track within this many sigmas …
    pub link_sigmas: f64,
    /// … plus this slack, metres.
    pub link_slack_m: f64,
    /// A detected diameter may differ from a listed one by this many sigmas (plus 5 cm).
    pub diameter_sigmas: f64,
}

impl Default for MatchConfig {
    fn default() -> Self {
        Self {
            gate_sigmas: 3.0,
            min_gate_m: 0.3,
            max_gate_m: 10.0,
            inlier_sigmas: 3.0,
            relative_sigma_m: 0.05,
            window: 2,
            ratio: 2.0,
            link_sigmas: 3.0,
            link_slack_m: 0.3,
            diameter_sigmas: 3.0,
        }
    }
}

/// A detection associated with a cadastre pole.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Match {
    /// Index of the detection in its frame.
    pub detection: usize,
    /// Index of the cadastre feature in the matcher's input.
    pub cadastre: usize,
    /// Track of the detection (the same pole over consecutive frames).
    pub track: usize,
    /// Cadastre minus (detection + frame offset), metres: what the offset does not explain.
    pub residual: [f64; 2],
}

/// Why a detection was not matched.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum UnmatchedReason {
    /// No cadastre pole inside the DG gate (or none of a compatible diameter).
    NoCandidate,
    /// The frame's offset is ambiguous: rival offsets are equally supported.
    AmbiguousOffset,
    /// Two cadastre poles are inliers after the offset, or the ratio test failed.
    AmbiguousPole,
    /// Candidates exist but none agrees with the frame's common offset.
    InconsistentWithOffset,
    /// Another detection of the frame matched the same cadastre pole more closely.
    Duplicate,
}

/// A detection that was not matched, and why.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Unmatched {
    /// Index of the detection in its frame.
    pub detection: usize,
    /// Track of the detection.
    pub track: usize,
    /// Why.
    pub reason: UnmatchedReason,
}

/// The matching of one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MatchedFrame {
    /// The frame's common offset (cadastre minus DG-observed), when one was found, metres.
    pub offset: Option<[f64; 2]>,
    /// Tracks supporting the offset.
    pub support: usize,
    /// The matches.
    pub matches: Vec<Match>,
    /// The detections not matched.
    pub unmatched: Vec<Unmatched>,
    /// Cadastre features (indices) in the frame's view at reliable range that were not matched.
    pub unseen: Vec<usize>,
}

/// Match every frame (in time order) against the cadastre.
pub fn match_frames(frames: &[MatchInput], cadastre: &[CadastreFeature], config: &MatchConfig) -> Vec<MatchedFrame> {
    let dets: Vec<&[crate::detect::Detection]> = frames.iter().map(|f| f.detections.detections.as_slice()).collect();
    let tracks = track::link(&dets, config.link_sigmas, config.link_slack_m);
    let grid = index::Grid::new(cadastre);
    (0..frames.len()).map(|k| assign::frame(k, frames, &tracks, cadastre, &grid, config)).collect()
}
