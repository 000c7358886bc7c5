//! The messages of the distributed path, versioned (`"version": "1"`) with JSON Schemas in `schemas/`:
//!
//! | message | subject / key | written by | read by |
//! |---|---|---|---|
//! | [`TileTask`] | `plumbline.tasks.<agency>.<campaign>` (work queue) | scheduler | workers |
//! | [`TileDone`] | `plumbline.results.<agency>.<campaign>` | worker, after the tile's output object is written | adjuster |
//! | [`TileFailed`] | `plumbline.results.<agency>.<campaign>` (and `plumbline.dead.…` when given up) | worker | adjuster, scheduler |
//! | [`CampaignState`] | KV `plumbline-campaigns`, key `<agency>.<campaign>` | scheduler, workers, adjuster (revision-checked) | everyone, the job API |
//!
//! A campaign is known by its agency and id together: two agencies may use the same id. Bulky payloads stay
//! in object storage; messages carry URLs and keys.

use std::borrow::Cow;

use plumbline_campaign::CampaignId;
use plumbline_geo::tiling::TileId;
use schemars::{JsonSchema, Schema, SchemaGenerator, json_schema};
use serde::{Deserialize, Serialize};

/// An agency's name, checked with the campaign-id rules (1 to 64 of `a`–`z`, `0`–`9`, `-`, `_`), so it is
/// safe in store prefixes, KV keys and subjects.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Agency(String);

impl Agency {
    /// The agency's name.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// A checked agency name.
    pub fn parse(name: &str) -> Result<Self, String> {
        name.parse::<CampaignId>()
            .map(|_| Self(name.to_owned()))
            .map_err(|e| e.to_string().replace("campaign id", "agency"))
    }
}

impl TryFrom<String> for Agency {
    type Error = String;

    fn try_from(name: String) -> Result<Self, Self::Error> {
        Self::parse(&name)
    }
}

impl From<Agency> for String {
    fn from(agency: Agency) -> Self {
        agency.0
    }
}

impl std::fmt::Display for Agency {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl JsonSchema for Agency {
    fn schema_name() -> Cow<'static, str> {
        "Agency".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "description": "Agency name: 1 to 64 characters out of a-z, 0-9, '-' and '_'.",
            "type": "string",
            "pattern": "^[a-z0-9_-]{1,64}$",
        })
    }
}

/// One tile to process. Idempotent: processing it again writes the same result object.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
pub enum TileTaskDoc {
    /// Version 1.
    #[serde(rename = "1")]
    V1(TileTask),
}

/// A tile task (version 1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TileTask {
    /// The agency the campaign belongs to.
    pub agency: Agency,
    /// The campaign (its id within the agency).
    pub campaign: CampaignId,
    /// The campaign's run: a resubmission after a terminal state starts run + 1; workers skip tasks of
    /// runs other than the state's current one.
    pub run: u32,
    /// The stored manifest's absolute URL (the plan lies beside the output as `plan.json`).
    pub manifest: String,
    /// The tile.
    pub tile: TileId,
    /// The output prefix (absolute URL ending in `/`); the tile's output goes to `{output}{tile_key}`.
    pub output: String,
}

/// A finished tile: its output object is durably written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
pub enum TileDoneDoc {
    /// Version 1.
    #[serde(rename = "1")]
    V1(TileDone),
}

/// A finished tile (version 1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TileDone {
    /// The agency the campaign belongs to.
    pub agency: Agency,
    /// The campaign (its id within the agency).
    pub campaign: CampaignId,
    /// The campaign's run the task belonged to.
    pub run: u32,
    /// The tile.
    pub tile: TileId,
    /// The absolute URL of the tile's output object (`TileOutput` v1).
    pub result: String,
    /// Deliveries it took (1 = first try).
    pub attempts: u32,
}

/// Whether a failed tile may succeed when tried again.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum FailureKind {
    /// Transient (store or network unavailable): nak with backoff, retried up to `max_deliver`.
    Retryable,
    /// The input is bad (invalid data): terminated at once and dead-lettered.
    Permanent,
}

/// A tile that failed for good (permanent, or retryable with its deliveries used up).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
pub enum TileFailedDoc {
    /// Version 1.
    #[serde(rename = "1")]
    V1(TileFailed),
}

/// A failed tile (version 1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TileFailed {
    /// The agency the campaign belongs to.
    pub agency: Agency,
    /// The campaign (its id within the agency).
    pub campaign: CampaignId,
    /// The campaign's run the task belonged to.
    pub run: u32,
    /// The tile.
    pub tile: TileId,
    /// The failure's kind.
    pub kind: FailureKind,
    /// The error chain, one line.
    pub error: String,
    /// Deliveries made.
    pub attempts: u32,
}

/// Where a campaign is in its life.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum CampaignStatus {
    /// Tasks published, no tile finished yet.
    Queued,
    /// Tiles being processed.
    Running,
    /// Every tile handled; the global adjustment runs.
    Adjusting,
    /// Outputs and report written.
    Done,
    /// Stopped by an error (see `error`).
    Failed,
    /// Cancelled by its agency; workers skip its tasks.
    Cancelled,
}

impl CampaignStatus {
    /// Every status, in life order.
    pub const ALL: [Self; 6] =
        [Self::Queued, Self::Running, Self::Adjusting, Self::Done, Self::Failed, Self::Cancelled];

    /// Whether nothing more happens to the campaign.
    pub fn is_terminal(self) -> bool {
        matches!(self, Self::Done | Self::Failed | Self::Cancelled)
    }

    /// The lowercase name.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Queued => "queued",
            Self::Running => "running",
            Self::Adjusting => "adjusting",
            Self::Done => "done",
            Self::Failed => "failed",
            Self::Cancelled => "cancelled",
        }
    }
}

/// A tile given up on, with why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DeadLetter {
    /// The tile.
    pub tile: TileId,
    /// The last error.
    pub error: String,
}

/// A campaign's state in the KV bucket.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
pub enum CampaignStateDoc {
    /// Version 1.
    #[serde(rename = "1")]
    V1(CampaignState),
}

/// A campaign's state (version 1). Counters are updated with revision-checked writes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CampaignState {
    /// The campaign id (the manifest's `campaign.id`), unique within its agency.
    pub id: CampaignId,
    /// The agency that owns it (with `id`, the state's key).
    pub agency: Agency,
    /// The current run (1 for the first submission).
    pub run: u32,
    /// The stored manifest's absolute URL.
    pub manifest: String,
    /// The output prefix (absolute URL ending in `/`).
    pub output: String,
    /// Where it is.
    pub status: CampaignStatus,
    /// Tiles planned.
    pub tiles_total: u64,
    /// Tiles whose task has been published, in plan order (the scheduler dispatches a few at a time per
    /// agency: `service::dispatch`).
    #[serde(default)]
    pub dispatched: u64,
    /// Tiles finished.
    pub tiles_done: u64,
    /// Tiles failed for good.
    pub tiles_failed: u64,
    /// The tiles given up on, with their last error.
    #[serde(default)]
    pub dead_lettered: Vec<DeadLetter>,
    /// Panoramas planned.
    pub panoramas: u64,
    /// Input items skipped while loading and planning.
    pub skipped: u64,
    /// Creation time, unix seconds.
    pub created: u64,
    /// Last update, unix seconds.
    pub updated: u64,
    /// The report's absolute URL, once done.
    pub report: Option<String>,
    /// Why it failed or was stopped.
    pub error: Option<String>,
}

impl CampaignState {
    /// Tiles handled (done or failed).
    pub fn tiles_handled(&self) -> u64 {
        self.tiles_done + self.tiles_failed
    }
}

/// Implements `to_json`/`from_json` for a versioned document and its latest version.
macro_rules! versioned {
    ($doc:ident, $latest:ident) => {
        impl $latest {
            /// The JSON of this message, tagged with its version.
            pub fn to_json(&self) -> Vec<u8> {
                serde_json::to_vec(&$doc::V1(self.clone())).unwrap_or_default()
            }

            /// Parse any supported version; the error names the message type and field.
            pub fn from_json(bytes: &[u8]) -> Result<Self, MessageError> {
                let error = |detail: String| MessageError { message: stringify!($latest), detail };
                let mut value: serde_json::Value = serde_json::from_slice(bytes).map_err(|e| error(e.to_string()))?;
                let version = value.as_object_mut().and_then(|o| o.remove("version"));
                match version.as_ref().and_then(serde_json::Value::as_str) {
                    Some("1") => serde_path_to_error::deserialize(value).map_err(|e| error(e.to_string())),
                    Some(other) => Err(error(format!("version: {other:?} is not supported (expected \"1\")"))),
                    None => Err(error("version: missing".to_owned())),
                }
            }
        }
    };
}

versioned!(TileTaskDoc, TileTask);
versioned!(TileDoneDoc, TileDone);
versioned!(TileFailedDoc, TileFailed);
versioned!(CampaignStateDoc, CampaignState);

/// A message that could not be read.
#[derive(Debug, thiserror::Error)]
#[error("{message}: {detail}")]
pub struct MessageError {
    /// The message type.
    pub message: &'static str,
    /// What is wrong, with the field path.
    pub detail: String,
}

/// The schema files of the messages, by file name in `schemas/`.
pub fn schemas() -> Vec<(&'static str, serde_json::Value)> {
    let json = |s: Schema| s.to_value();
    vec![
        ("tile-task.v1.schema.json", json(schemars::schema_for!(TileTaskDoc))),
        ("tile-done.v1.schema.json", json(schemars::schema_for!(TileDoneDoc))),
        ("tile-failed.v1.schema.json", json(schemars::schema_for!(TileFailedDoc))),
        ("campaign-state.v1.schema.json", json(schemars::schema_for!(CampaignStateDoc))),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state() -> CampaignState {
        CampaignState {
            id: "hh-2024".parse().unwrap(),
            agency: Agency::parse("hamburg").unwrap(),
            run: 1,
            manifest: "s3://b/agencies/hamburg/campaigns/hh-2024/manifest.toml".into(),
            output: "s3://b/agencies/hamburg/campaigns/hh-2024/results/".into(),
            status: CampaignStatus::Running,
            tiles_total: 4,
            dispatched: 4,
            tiles_done: 2,
            tiles_failed: 1,
            dead_lettered: vec![DeadLetter { tile: TileId { col: 1, row: -2 }, error: "bad".into() }],
            panoramas: 40,
            skipped: 0,
            created: 1_700_000_000,
            updated: 1_700_000_100,
            report: None,
            error: None,
        }
    }

    #[test]
    fn messages_round_trip_with_their_version_tag() {
        let s = state();
        let bytes = s.to_json();
        let value: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
        assert_eq!(value["version"], "1");
        assert_eq!(value["status"], "running");
        assert_eq!(CampaignState::from_json(&bytes).unwrap(), s);
        let task = TileTask {
            agency: s.agency.clone(),
            campaign: s.id.clone(),
            run: 1,
            manifest: s.manifest.clone(),
            tile: TileId { col: 3, row: 4 },
            output: s.output.clone(),
        };
        assert_eq!(TileTask::from_json(&task.to_json()).unwrap(), task);
    }

    #[test]
    fn bad_messages_name_the_type_and_field() {
        let err = TileTask::from_json(br#"{"version":"2"}"#).unwrap_err().to_string();
        assert!(err.starts_with("TileTask"), "{err}");
        let err = CampaignState::from_json(br#"{"version":"1","id":"UPPER"}"#).unwrap_err().to_string();
        assert!(err.contains("id"), "{err}");
        let mut v: serde_json::Value = serde_json::from_slice(&state().to_json()).unwrap();
        v["agency"] = "a.b".into();
        let err = CampaignState::from_json(v.to_string().as_bytes()).unwrap_err().to_string();
        assert!(err.contains("agency") && err.contains("'.'"), "{err}");
        let mut v: serde_json::Value = serde_json::from_slice(&state().to_json()).unwrap();
        v["status"] = "paused".into();
        let err = CampaignState::from_json(v.to_string().as_bytes()).unwrap_err().to_string();
        assert!(err.contains("status"), "{err}");
    }
}
