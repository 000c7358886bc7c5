//! Progress of long work, reported from synchronous code without knowing who listens: a terminal with bars,
//! a log, JSON lines, a distributed job's status, or nobody. Workflow code calls the trait; the services
//! implement it (`plumbline_runtime::progress`).

/// The stages of a campaign, in the order a run meets them: what progress is reported for and what a
/// skipped input names. Written in files and messages by [`Stage::name`].
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// `plumbline simulate` writing a synthetic campaign.
    Simulate,
    /// Reading the manifest, the trajectory and the tables.
    Load,
    /// Planning the tiles.
    Plan,
    /// The tiles, one item each.
    Tiles,
    /// Registering panoramas with the aerial images, one item per owned panorama.
    Registration,
    /// Depth images and point clouds searched for poles, one item per depth image.
    Poles,
    /// Reading the cadastres.
    Cadastre,
    /// Image motions checked against the DG trajectory.
    Consistency,
    /// The global adjustment, one item per iteration.
    Adjustment,
}

impl Stage {
    /// Every stage, in order.
    pub const ALL: [Self; 9] = [
        Self::Simulate,
        Self::Load,
        Self::Plan,
        Self::Tiles,
        Self::Registration,
        Self::Poles,
        Self::Cadastre,
        Self::Consistency,
        Self::Adjustment,
    ];

    /// The stage's stable name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Simulate => "simulate",
            Self::Load => "load",
            Self::Plan => "plan",
            Self::Tiles => "tiles",
            Self::Registration => "registration",
            Self::Poles => "poles",
            Self::Cadastre => "cadastre",
            Self::Consistency => "consistency",
            Self::Adjustment => "adjustment",
        }
    }
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Stage {
    type Err = String;

    fn from_str(name: &str) -> Result<Self, Self::Err> {
        Self::ALL.into_iter().find(|s| s.name() == name).ok_or_else(|| format!("unknown stage `{name}`"))
    }
}

/// Receives progress of the campaign's [`Stage`]s (e.g. registration in panoramas, adjustment in iterations).
///
/// Implementations are cheap to call from many threads at once; they throttle their own output.
pub trait Progress: Send + Sync {
    /// A stage begins with `total` items when known.
    fn begin(&self, stage: Stage, total: Option<u64>);
    /// `n` more items of `stage` are done.
    fn advance(&self, stage: Stage, n: u64);
    /// `n` items of `stage` were skipped (they count as handled for the rate and ETA).
    fn skip(&self, stage: Stage, n: u64);
    /// A short status line for the stage (e.g. `iteration 4: σ0 1.08`).
    fn note(&self, stage: Stage, text: &str);
    /// The stage is over.
    fn end(&self, stage: Stage);
}

/// A [`Progress`] that discards everything.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn begin(&self, _: Stage, _: Option<u64>) {}
    fn advance(&self, _: Stage, _: u64) {}
    fn skip(&self, _: Stage, _: u64) {}
    fn note(&self, _: Stage, _: &str) {}
    fn end(&self, _: Stage) {}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stage_names_are_stable_and_read_back() {
        for stage in Stage::ALL {
            assert_eq!(stage.name().parse::<Stage>(), Ok(stage));
            assert_eq!(serde_json::to_value(stage).ok(), Some(serde_json::Value::from(stage.name())));
        }
        assert!("adjust".parse::<Stage>().is_err());
    }
}
