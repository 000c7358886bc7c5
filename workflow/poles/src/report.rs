//! The versioned per-frame diagnostics of pole processing: what was detected, matched (with or without an
//! update), left unmatched and why, and which cadastre poles in view were not seen. Schema:
//! `schemas/pole-frames.v1.schema.json`.

use plumbline_campaign::CadastreFeature;
use plumbline_campaign::manifest::PoleClass;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::cupt::{CuptConfig, NoUpdate, feature_key, update_blocker};
use crate::detect::{Detection, ViewSector};
use crate::matching::{MatchInput, MatchedFrame, Unmatched};

/// A versioned frame report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
pub enum FrameReport {
    /// Version 1.
    #[serde(rename = "1")]
    V1(FrameReportV1),
}

/// Version 1 of a frame report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FrameReportV1 {
    /// Frame (image) id.
    pub frame: String,
    /// Epoch, seconds.
    pub time: f64,
    /// Why the frame could not be processed (decoding, no ground); then everything else is empty.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub problem: Option<String>,
    /// Local ground height, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground_height_m: Option<f64>,
    /// The sector searched.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub view: Option<ViewSector>,
    /// The frame's common offset (cadastre minus DG-observed), metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<[f64; 2]>,
    /// Tracks supporting the offset.
    pub support: usize,
    /// The detections (indices below refer to this list).
    pub detections: Vec<Detection>,
    /// The matches.
    pub matches: Vec<MatchReport>,
    /// Detections not matched, with the reason.
    pub unmatched: Vec<Unmatched>,
    /// Cadastre poles in view at the searched range that were not matched.
    pub unseen: Vec<UnseenPole>,
}

/// One match.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MatchReport {
    /// Index into `detections`.
    pub detection: usize,
    /// Track of the detection.
    pub track: usize,
    /// Cadastre id (`layer:fid`).
    pub cadastre_id: String,
    /// Its class.
    pub class: PoleClass,
    /// Cadastre minus (detection + offset), metres.
    pub residual: [f64; 2],
    /// Why no coordinate update was made from it, if none was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub no_update: Option<NoUpdate>,
}

/// A cadastre pole that was in view but not matched.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct UnseenPole {
    /// Cadastre id (`layer:fid`).
    pub cadastre_id: String,
    /// Its class.
    pub class: PoleClass,
    /// Cadastre position (easting, northing), metres.
    pub position: [f64; 2],
}

/// The report of a frame that could not be processed.
pub fn failed_frame(frame: &str, time: f64, problem: String) -> FrameReport {
    FrameReport::V1(FrameReportV1 {
        frame: frame.to_owned(),
        time,
        problem: Some(problem),
        ground_height_m: None,
        view: None,
        offset: None,
        support: 0,
        detections: Vec::new(),
        matches: Vec::new(),
        unmatched: Vec::new(),
        unseen: Vec::new(),
    })
}

/// The reports of matched frames.
pub fn frame_reports(
    inputs: &[MatchInput],
    matched: &[MatchedFrame],
    cadastre: &[CadastreFeature],
    c: &CuptConfig,
) -> Vec<FrameReport> {
    inputs.iter().zip(matched).map(|(input, frame)| report(input, frame, cadastre, c)).collect()
}

fn report(input: &MatchInput, frame: &MatchedFrame, cadastre: &[CadastreFeature], c: &CuptConfig) -> FrameReport {
    let matches = frame
        .matches
        .iter()
        .filter_map(|m| {
            let f = cadastre.get(m.cadastre)?;
            Some(MatchReport {
                detection: m.detection,
                track: m.track,
                cadastre_id: feature_key(&f.id),
                class: f.class,
                residual: m.residual,
                no_update: update_blocker(input, frame, m.detection, c),
            })
        })
        .collect();
    let unseen = frame
        .unseen
        .iter()
        .filter_map(|&i| cadastre.get(i))
        .map(|f| UnseenPole { cadastre_id: feature_key(&f.id), class: f.class, position: [f.easting, f.northing] })
        .collect();
    FrameReport::V1(FrameReportV1 {
        frame: input.frame.clone(),
        time: input.time,
        problem: None,
        ground_height_m: Some(input.detections.ground_height_m),
        view: Some(input.detections.view),
        offset: frame.offset,
        support: frame.support,
        detections: input.detections.detections.clone(),
        matches,
        unmatched: frame.unmatched.clone(),
        unseen,
    })
}
