//! The job API's response bodies, shared by the scheduler service and its client ([`crate::client`]).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::messages::{CampaignState, CampaignStatus};

/// A campaign as the API shows it: its state and the progress of each stage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CampaignView {
    /// The state as kept in the KV bucket.
    pub campaign: CampaignState,
    /// Progress by stage: `plan`, `tiles`, `adjust`.
    pub stages: Vec<StageProgress>,
}

/// Progress of one stage.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct StageProgress {
    /// The stage.
    pub stage: String,
    /// Items done.
    pub done: u64,
    /// Items given up on.
    pub failed: u64,
    /// Items in all.
    pub total: u64,
}

/// The agency's campaigns.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CampaignList {
    /// Newest first.
    pub campaigns: Vec<CampaignState>,
}

/// An error body.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct ErrorBody {
    /// One line for people.
    pub error: String,
    /// Problems by field, when the request body is at fault.
    #[serde(default)]
    pub problems: Vec<ProblemBody>,
}

/// A problem naming its field.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct ProblemBody {
    /// The field (a manifest path such as `trajectory[0].url`), empty for the request as a whole.
    pub field: String,
    /// What was found.
    pub found: String,
    /// What is expected.
    pub expected: String,
}

impl CampaignView {
    /// The view of a state.
    pub fn of(campaign: CampaignState) -> Self {
        let s = &campaign;
        let adjusted = u64::from(s.status == CampaignStatus::Done);
        let adjust_failed = u64::from(s.status == CampaignStatus::Failed && s.tiles_handled() == s.tiles_total);
        let stages = vec![
            StageProgress { stage: "plan".into(), done: 1, failed: 0, total: 1 },
            StageProgress { stage: "tiles".into(), done: s.tiles_done, failed: s.tiles_failed, total: s.tiles_total },
            StageProgress { stage: "adjust".into(), done: adjusted, failed: adjust_failed, total: 1 },
        ];
        Self { campaign, stages }
    }
}
