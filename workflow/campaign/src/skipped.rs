//! Input items left out of a run, and why: what the report lists, what decides whether a tile is retried.
//! Reasons are typed; files and messages carry them by their stable names ([`SkipReason::name`]).

use std::borrow::Cow;
use std::fmt;

use schemars::{JsonSchema, Schema, SchemaGenerator, json_schema};
use serde::{Deserialize, Serialize};

use crate::cadastre_features::DiagnosticKind;
use crate::progress::Stage;
use crate::tables::RowProblem;

/// An input item left out while loading or processing, and why (the report lists them).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SkippedInput {
    /// The stage that skipped it.
    pub stage: Stage,
    /// The item: file, record or feature.
    pub item: String,
    /// Why, for counting.
    pub reason: SkipReason,
    /// The full message, naming file, record and field.
    pub detail: String,
}

impl SkippedInput {
    /// An item of `stage` skipped for `reason`.
    pub fn new(stage: Stage, item: impl Into<String>, reason: SkipReason, detail: impl Into<String>) -> Self {
        Self { stage, item: item.into(), reason, detail: detail.into() }
    }

    /// A skipped table row.
    pub fn row(stage: Stage, problem: &RowProblem) -> Self {
        let reason = problem.field.as_ref().map_or(SkipReason::Row, |f| SkipReason::BadField(f.clone()));
        Self::new(stage, format!("{} line {}", problem.file, problem.line), reason, problem.to_string())
    }
}

/// Why an input item was left out.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum SkipReason {
    /// The store says the file is not there.
    Missing,
    /// The store failed to deliver it; a later attempt may succeed.
    Read,
    /// The store will refuse it again (a bad scheme or URL, permissions).
    Refused,
    /// Its bytes cannot be decoded.
    Decode,
    /// Its header claims another size than expected, or more pixels than the budget.
    Size,
    /// Its location cannot be resolved (outside its prefix, malformed).
    Url,
    /// Its time lies outside the trajectory.
    Time,
    /// A depth frame that yields no points.
    Frame,
    /// The camera model cannot be built for it.
    Camera,
    /// The file opens as nothing usable.
    Open,
    /// It covers nothing the tile needs.
    Outside,
    /// A table row that cannot be read.
    Row,
    /// A table row with a bad field, named.
    BadField(String),
    /// The reference trajectory cannot be used.
    Reference,
    /// An index row whose time lies outside the trajectory.
    OutsideTrajectory,
    /// A registration the registration discarded, by the discard's key (e.g. `no_aerial_match`).
    Discarded(String),
    /// A tie point delivered twice.
    DuplicateTie,
    /// A tile dead-lettered after its deliveries.
    DeadLettered,
    /// A tile that failed in a one-process run (the run goes on without it).
    Failed,
    /// An image pair the consistency check against the DG trajectory could not test.
    Untestable,
    /// A cadastre feature or layer dropped, by its diagnostic.
    Cadastre(DiagnosticKind),
}

impl SkipReason {
    /// The reasons without a payload.
    const PLAIN: [Self; 18] = [
        Self::Missing,
        Self::Read,
        Self::Refused,
        Self::Decode,
        Self::Size,
        Self::Url,
        Self::Time,
        Self::Frame,
        Self::Camera,
        Self::Open,
        Self::Outside,
        Self::Row,
        Self::Reference,
        Self::OutsideTrajectory,
        Self::DuplicateTie,
        Self::DeadLettered,
        Self::Failed,
        Self::Untestable,
    ];

    /// The stable name in files: a word, `bad <field>`, `discard.<key>`, or a cadastre diagnostic's kind.
    pub fn name(&self) -> Cow<'static, str> {
        Cow::Borrowed(match self {
            Self::Missing => "missing",
            Self::Read => "read",
            Self::Refused => "refused",
            Self::Decode => "decode",
            Self::Size => "size",
            Self::Url => "url",
            Self::Time => "time",
            Self::Frame => "frame",
            Self::Camera => "camera",
            Self::Open => "open",
            Self::Outside => "outside",
            Self::Row => "row",
            Self::Reference => "reference",
            Self::OutsideTrajectory => "outside_trajectory",
            Self::DuplicateTie => "duplicate_tie",
            Self::DeadLettered => "dead-lettered",
            Self::Failed => "failed",
            Self::Untestable => "untestable",
            Self::BadField(field) => return Cow::Owned(format!("bad {field}")),
            Self::Discarded(key) => return Cow::Owned(format!("discard.{key}")),
            Self::Cadastre(kind) => kind.name(),
        })
    }

    /// Whether a later attempt may succeed: the store failed to deliver, the input itself may be fine.
    pub fn retryable(&self) -> bool {
        *self == Self::Read
    }
}

impl fmt::Display for SkipReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

impl std::str::FromStr for SkipReason {
    type Err = String;

    fn from_str(name: &str) -> Result<Self, Self::Err> {
        if let Some(plain) = Self::PLAIN.into_iter().find(|r| r.name() == name) {
            return Ok(plain);
        }
        if let Some(field) = name.strip_prefix("bad ") {
            return Ok(Self::BadField(field.to_owned()));
        }
        if let Some(key) = name.strip_prefix("discard.") {
            return Ok(Self::Discarded(key.to_owned()));
        }
        DiagnosticKind::ALL
            .into_iter()
            .find(|k| k.name() == name)
            .map(Self::Cadastre)
            .ok_or_else(|| format!("unknown skip reason `{name}`"))
    }
}

impl Serialize for SkipReason {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.name())
    }
}

impl<'de> Deserialize<'de> for SkipReason {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = Cow::<str>::deserialize(deserializer)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

impl JsonSchema for SkipReason {
    fn schema_name() -> Cow<'static, str> {
        "SkipReason".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "description": "Why an item was skipped: missing, read, refused, decode, size, url, time, frame, camera, \
                            open, outside, row, reference, outside_trajectory, duplicate_tie, dead-lettered, failed, untestable, \
                            `bad <field>`, `discard.<key>`, or a cadastre diagnostic's kind.",
            "type": "string",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_reason_reads_back_from_its_name() {
        let mut all: Vec<SkipReason> = SkipReason::PLAIN.to_vec();
        all.extend([SkipReason::BadField("time".into()), SkipReason::Discarded("no_aerial_match".into())]);
        all.extend(DiagnosticKind::ALL.into_iter().map(SkipReason::Cadastre));
        for reason in all {
            let json = serde_json::to_string(&reason).unwrap_or_default();
            assert_eq!(serde_json::from_str::<SkipReason>(&json).ok(), Some(reason.clone()), "{json}");
        }
        assert!(serde_json::from_str::<SkipReason>("\"gone\"").is_err());
    }
}
