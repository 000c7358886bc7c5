//! Coordinate updates (CUPTs, Meyer et al. 2023 §3.4.2): per matched detection, the cadastre position minus the
//! position observed with the DG pose, weighted with err = √(err_cam² + err_pole²) (Meyer et al. 2023 eq. (1)):
//! err_cam from the detection's covariance (range error model), err_pole from the cadastre's class accuracy.

use plumbline_adjustment::PoleUpdate;
use plumbline_campaign::{CadastreFeature, CadastreFeatureId};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::matching::{MatchInput, MatchedFrame};

/// Which matches become updates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CuptConfig {
    /// Fewest tracks supporting the frame's offset.
    pub min_support: usize,
}

impl Default for CuptConfig {
    fn default() -> Self {
        Self { min_support: 1 }
    }
}

/// Why a match gave no update.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum NoUpdate {
    /// The detection lies where the sensor's range cut-off biases its points.
    RangeLimit,
    /// The frame's offset has too little support.
    WeakOffset,
}

/// The id of a cadastre feature in updates and reports: `layer:fid` (`layer:fid:part` for multipoint parts).
pub fn feature_key(id: &CadastreFeatureId) -> String {
    if id.part == 0 { format!("{}:{}", id.layer, id.fid) } else { format!("{}:{}:{}", id.layer, id.fid, id.part) }
}

/// Whether a match of `frame` gives an update, and if not why.
pub fn update_blocker(input: &MatchInput, frame: &MatchedFrame, detection: usize, c: &CuptConfig) -> Option<NoUpdate> {
    let reliable = input.detections.detections.get(detection).is_some_and(|d| d.reliable);
    if !reliable {
        Some(NoUpdate::RangeLimit)
    } else if frame.support < c.min_support {
        Some(NoUpdate::WeakOffset)
    } else {
        None
    }
}

/// The updates of all frames, in frame order.
pub fn coordinate_updates(
    inputs: &[MatchInput],
    matched: &[MatchedFrame],
    cadastre: &[CadastreFeature],
    c: &CuptConfig,
) -> Vec<PoleUpdate> {
    let mut out = Vec::new();
    for (input, frame) in inputs.iter().zip(matched) {
        for m in &frame.matches {
            let (Some(d), Some(f)) = (input.detections.detections.get(m.detection), cadastre.get(m.cadastre)) else {
                continue;
            };
            if update_blocker(input, frame, m.detection, c).is_some() {
                continue;
            }
            // Meyer et al. 2023 eq. (1): err = √(err_cam² + err_pole²); `PoleUpdate::sigma` adds them.
            out.push(PoleUpdate {
                cadastre_id: feature_key(&f.id),
                time: input.time,
                cadastre: [f.easting, f.northing],
                observed: d.centre,
                sigma_camera: d.sigma(),
                sigma_pole: f.accuracy_m,
            });
        }
    }
    out
}
