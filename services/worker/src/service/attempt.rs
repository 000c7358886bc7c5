//! One attempt at a tile in the service: read back an output already written, else process the tile and
//! write its output — unless inputs were skipped because the store failed to deliver them, which is a
//! retryable error rather than a tile with holes: retried while deliveries are left, then the tile is
//! dead-lettered naming the first unread input. A tile is never written as complete while its reads fail.

use std::collections::HashMap;

use plumbline_campaign::Campaign;
use plumbline_geo::tiling::TileId;
use plumbline_runtime::Files;

use plumbline_campaign::SkippedInput;

use crate::output::read_finished;
use crate::stages::Timed;
use crate::{TileOutput, TileOutputV1, WorkerConfig, process_tile, tile_key};

/// Inputs of a tile the store failed to deliver: retry the tile rather than skip them (a
/// [`plumbline_runtime::ErrorKind::Transient`] error made from it).
#[derive(Debug)]
pub struct UnreadInputs {
    /// The tile.
    pub tile: TileId,
    /// How many inputs were not delivered.
    pub count: usize,
    /// The first one's error.
    pub first: String,
}

impl std::fmt::Display for UnreadInputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "tile {}: {} input(s) could not be read from the store (first: {}); retrying the tile rather than \
             skipping them",
            self.tile, self.count, self.first
        )
    }
}

impl std::error::Error for UnreadInputs {}

/// What an attempt produced.
#[derive(Debug)]
pub(crate) struct Attempt {
    /// The tile's output, as written.
    pub output: TileOutputV1,
    /// Whether it was read back from an earlier delivery's write.
    pub resumed: bool,
    /// Seconds spent writing the output (0 when resumed).
    pub write_s: f64,
}

impl Attempt {
    /// The worker's stage-duration metric of a processed tile, seconds per metric stage: fetch (reading and
    /// decoding every input), registration, poles, write, total. A name in the output's `seconds` that is no
    /// [`Timed`] stage is logged and left out.
    pub(crate) fn stage_seconds(&self) -> [(&'static str, f64); 5] {
        let mut by: HashMap<Timed, f64> = HashMap::new();
        for (name, t) in &self.output.seconds {
            match Timed::of(name) {
                Some(stage) => *by.entry(stage).or_default() += t,
                None => tracing::warn!(stage = %name, "tile output times an unknown stage"),
            }
        }
        let sum = |stages: &[Timed]| stages.iter().map(|s| by.get(s).copied().unwrap_or(0.0)).sum::<f64>();
        [
            ("fetch", sum(&[Timed::Read, Timed::Decode, Timed::PolesRead])),
            ("registration", sum(&[Timed::Registration])),
            ("poles", sum(&[Timed::Poles])),
            ("write", self.write_s),
            ("total", sum(&[Timed::Total]) + self.write_s),
        ]
    }
}

/// Read back, or process and write, the tile's output; inputs the store did not deliver fail the attempt
/// ([`UnreadInputs`]).
pub(crate) async fn attempt(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    config: &WorkerConfig,
) -> plumbline_runtime::Result<Attempt> {
    let url = format!("{}{}", campaign.output, tile_key(tile));
    let fingerprint = crate::fingerprint(campaign, tile, config);
    if let Some(output) = read_finished(files, &url, tile, &fingerprint).await? {
        return Ok(Attempt { output, resumed: true, write_s: 0.0 });
    }
    tracing::info!("tile inputs being read");
    let output = process_tile(files, campaign, tile, config).await?;
    let undelivered = unread(&output.skipped);
    if let Some(first) = undelivered.first() {
        let unread = UnreadInputs { tile: *tile, count: undelivered.len(), first: first.detail.clone() };
        return Err(plumbline_runtime::Error::from_cause(plumbline_runtime::ErrorKind::Transient, unread));
    }
    let started = std::time::Instant::now();
    let json = serde_json::to_vec_pretty(&TileOutput::V1(output.clone()))?;
    files.write(&url, json).await?;
    Ok(Attempt { output, resumed: false, write_s: started.elapsed().as_secs_f64() })
}

/// The items skipped because the store failed to deliver them (a retryable [`plumbline_campaign::SkipReason`]), as opposed to
/// missing or broken ones.
fn unread(skipped: &[SkippedInput]) -> Vec<&SkippedInput> {
    skipped.iter().filter(|s| s.reason.retryable()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fetch::skipped;
    use plumbline_campaign::{DiagnosticKind, SkipReason, Stage};

    /// Only what the store failed to deliver makes the attempt retryable; a missing, refused or broken input,
    /// or a reason of another crate's vocabulary, is skipped for good.
    #[test]
    fn only_undelivered_inputs_make_the_attempt_retryable() {
        let items = [
            skipped(Stage::Registration, "p1.jpg", SkipReason::Read, "p1.jpg: cannot be read: timeout".into()),
            skipped(Stage::Registration, "p2.jpg", SkipReason::Missing, "p2.jpg: not found".into()),
            skipped(Stage::Registration, "p3.jpg", SkipReason::Decode, "p3.jpg: not a readable image".into()),
            skipped(Stage::Registration, "gs://b/p4.jpg", SkipReason::Refused, "unsupported scheme `gs`".into()),
            skipped(Stage::Cadastre, "poles.gpkg", SkipReason::Read, "poles.gpkg: cannot be read: reset".into()),
            skipped(
                Stage::Cadastre,
                "poles.gpkg:7",
                SkipReason::Cadastre(DiagnosticKind::UnknownClass),
                "feature 7".into(),
            ),
        ];
        let found: Vec<&str> = unread(&items).iter().map(|s| s.item.as_str()).collect();
        assert_eq!(found, ["p1.jpg", "poles.gpkg"]);
    }

    /// Every timed stage of a tile output lands in its metric stage: each gets a distinct power of two, so
    /// a stage missing from a sum or counted twice changes it (a renamed stage would read 0 here).
    #[test]
    fn every_timed_stage_reaches_its_metric() {
        let seconds: Vec<(String, f64)> =
            Timed::ALL.iter().enumerate().map(|(k, t)| (t.name().to_owned(), f64::from(1u32 << k))).collect();
        let of = |t: Timed| f64::from(1u32 << Timed::ALL.iter().position(|x| *x == t).unwrap());
        let output = TileOutputV1 {
            tile: TileId { col: 0, row: 0 },
            registration: None,
            poles: Vec::new(),
            pole_frames: Vec::new(),
            skipped: Vec::new(),
            seconds,
            fingerprint: None,
        };
        let done = Attempt { output, resumed: false, write_s: 0.5 };
        let expected = [
            ("fetch", of(Timed::Read) + of(Timed::Decode) + of(Timed::PolesRead)),
            ("registration", of(Timed::Registration)),
            ("poles", of(Timed::Poles)),
            ("write", 0.5),
            ("total", of(Timed::Total) + 0.5),
        ];
        assert_eq!(done.stage_seconds(), expected);
        // The names are the tile output's JSON (and `plumbline run`'s report stages): pinned here.
        let names = Timed::ALL.map(Timed::name);
        let pinned = ["read", "decode", "ortho", "features", "prepare", "matching", "triangulation", "aerial"];
        assert_eq!(names[..8], pinned);
        assert_eq!(names[8..], ["lines", "registration", "poles_read", "poles", "total"]);
        for t in Timed::ALL {
            assert_eq!(Timed::of(t.name()), Some(t));
        }
    }
}
