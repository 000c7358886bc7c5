//! The versioned result of one tile (`tiles/{col}_{row}.json`, schema `schemas/tile-output.v1.schema.json`).
//! Also the pole results a tile gathers on the way to it (`PoleResults`, filled by modules `poles` and
//! `clouds`).

use plumbline_adjustment::PoleUpdate;
use plumbline_campaign::SkippedInput;
use plumbline_geo::tiling::TileId;
use plumbline_poles::FrameReport;
use plumbline_registration::TileResultV1;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// One tile's result, versioned on the wire (`"version": "1"`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
pub enum TileOutput {
    /// Version 1.
    #[serde(rename = "1")]
    V1(TileOutputV1),
}

impl TileOutput {
    /// The newest version's content.
    pub fn into_latest(self) -> TileOutputV1 {
        match self {
            Self::V1(v) => v,
        }
    }
}

/// Version 1 of a tile's result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TileOutputV1 {
    /// The tile.
    pub tile: TileId,
    /// Registration of the tile's own panoramas (ties and one diagnostic per owned panorama); None when the
    /// campaign has no aerial reference.
    pub registration: Option<TileResultV1>,
    /// Pole coordinate updates from the tile's depth images.
    pub poles: Vec<PoleUpdate>,
    /// One report per depth frame of the tile.
    pub pole_frames: Vec<FrameReport>,
    /// Inputs skipped in this tile (decode errors, missing files, bad cadastre features).
    pub skipped: Vec<SkippedInput>,
    /// Seconds spent per stage (thread-seconds for parallel stages), by stage name.
    pub seconds: Vec<(String, f64)>,
    /// SHA-256 of the inputs and parameters the tile was computed from ([`crate::fingerprint`]): an output
    /// is reused only while it matches. Absent in outputs written before it existed (never reused).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fingerprint: Option<String>,
}

/// The pole results of a tile.
#[derive(Default)]
pub(crate) struct PoleResults {
    /// Coordinate updates.
    pub updates: Vec<PoleUpdate>,
    /// One report per depth frame and point-cloud slice.
    pub reports: Vec<FrameReport>,
    /// What was left out.
    pub skipped: Vec<SkippedInput>,
    /// Seconds reading depth images and cadastres.
    pub read_s: f64,
    /// Seconds in detection and matching.
    pub process_s: f64,
}

/// The finished output of `tile` at `url`, when it exists and was computed from the inputs and parameters
/// `fingerprint` stands for ([`crate::fingerprint`]); one of other inputs, one that does not parse or holds
/// another tile is logged and ignored (the caller processes the tile and overwrites it).
pub(crate) async fn read_finished(
    files: &plumbline_runtime::Files,
    url: &str,
    tile: &TileId,
    fingerprint: &str,
) -> plumbline_runtime::Result<Option<TileOutputV1>> {
    if !files.exists(url).await? {
        return Ok(None);
    }
    let bytes = files.read(url).await?;
    match serde_json::from_slice::<TileOutput>(&bytes).map(TileOutput::into_latest) {
        Ok(done) if done.tile == *tile && done.fingerprint.as_deref() == Some(fingerprint) => Ok(Some(done)),
        Ok(done) if done.tile == *tile => {
            tracing::info!(file = %url, "tile output of other inputs or parameters; reprocessing");
            Ok(None)
        }
        Ok(other) => {
            tracing::warn!(file = %url, found = ?other.tile, "tile output holds another tile; reprocessing");
            Ok(None)
        }
        Err(e) => {
            tracing::warn!(file = %url, error = %e, "tile output does not parse; reprocessing");
            Ok(None)
        }
    }
}

/// The object key of a tile's output under the campaign's output prefix.
pub fn tile_key(tile: &TileId) -> String {
    format!("tiles/{}_{}.json", tile.col, tile.row)
}
