//! The adjuster service (`plumbline serve adjuster`): consumes the results stream through the durable
//! `adjuster` consumer, following the protocol of [`plumbline_scheduler::bus`]:
//!
//! - each [`TileDone`]/[`TileFailed`] is recorded once per campaign run in the tally bucket
//!   [`TALLY_BUCKET`] (key `<agency>.<campaign>.<run>`: the tiles done and failed, revision-checked), and the
//!   campaign's KV state takes its counters from the tally — so a redelivered result changes nothing;
//!   `queued` becomes `running`, failed tiles are listed in `dead_lettered`;
//! - when done + failed == total the state becomes `adjusting`, every done tile's output is read from the
//!   store, [`finish`] writes the outputs, and the state becomes `done` with the report's URL (or `failed`
//!   with the error);
//! - dead-lettered tiles do not hold a campaign back: it is adjusted from the tiles it has and ends `done`,
//!   with the tiles listed in the state's `dead_lettered` (the job API and `plumbline status` show them with
//!   their errors) and in the report's skipped inputs (stage `tiles`, reason `dead-lettered`). Only a
//!   campaign without any processed tile ends `failed`;
//! - a store failure while adjusting (S3 or NATS unreachable: a [`plumbline_runtime::ErrorKind::Transient`] error) leaves the campaign
//!   `adjusting` and naks the result with a growing delay, so the adjustment runs again once the store is
//!   back (up to [`MAX_FINISH_DELIVERIES`] deliveries); any other error marks the campaign `failed`;
//! - the message is acked after the state is written (a failure to write it naks it for redelivery).
//!
//! Restart-safe: everything lives in KV; on start, campaigns found `adjusting` are finished again.
//!
//! With an ops listener the adjuster answers `/healthz`, `/readyz` and `/metrics` (families
//! [`ADJUSTER_FAMILIES`]).

use std::future::Future;
use std::time::Duration;

use async_nats::jetstream::{self, AckKind, consumer::PullConsumer, kv};
use futures::StreamExt as _;
use plumbline_campaign::progress::NoProgress;
use plumbline_campaign::{SkipReason, SkippedInput, Stage};
use plumbline_geo::tiling::TileId;
use plumbline_runtime::ops::{Ops, Probe, Registry, reply, serve_ops, with_heartbeat};
use plumbline_runtime::{Error, Files};
use plumbline_scheduler::bus::{ADJUSTER_CONSUMER, Bus, RESULTS_STREAM};
use plumbline_scheduler::messages::{Agency, CampaignState, CampaignStatus, DeadLetter, TileDone, TileFailed};
use plumbline_scheduler::service::{Layout, load_agency_campaign};
use plumbline_worker::{TileOutput, TileOutputV1, tile_key};
use serde::{Deserialize, Serialize};

use crate::{AdjusterConfig, finish};

mod probe;

pub use probe::ADJUSTER_FAMILIES;

pub use plumbline_scheduler::bus::TALLY_BUCKET;
/// Interval of the in-progress acks while a result (or the adjustment it triggers) is handled.
const HEARTBEAT: Duration = Duration::from_secs(30);
/// Delay asked for when a result is nakked the first time (doubling with each delivery, up to a minute).
const RETRY_DELAY: Duration = Duration::from_secs(2);
/// Deliveries of the result that completes a campaign before a store failure while adjusting is given up.
pub const MAX_FINISH_DELIVERIES: i64 = 30;

/// The delay before delivery `delivered + 1`.
fn retry_delay(delivered: i64) -> Duration {
    let doublings = u32::try_from(delivered.clamp(1, 6) - 1).unwrap_or(0);
    (RETRY_DELAY * 2u32.pow(doublings)).min(Duration::from_secs(60))
}

/// Whether `error` may pass (the store or the broker unreachable or erring), so the campaign waits.
fn store_unavailable(error: &Error) -> bool {
    error.is_transient()
}

/// The tiles of one campaign run that have been counted.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Tally {
    /// Tiles whose output is written.
    pub done: Vec<TileId>,
    /// Tiles given up on, with their error.
    pub failed: Vec<DeadLetter>,
}

impl Tally {
    /// Record a result; `false` when the tile was already counted.
    fn record(&mut self, result: &Outcome) -> bool {
        let tile = result.tile();
        if self.done.contains(&tile) || self.failed.iter().any(|f| f.tile == tile) {
            return false;
        }
        match result {
            Outcome::Done(_) => self.done.push(tile),
            Outcome::Failed(f) => self.failed.push(DeadLetter { tile, error: f.error.clone() }),
        }
        true
    }
}

/// A message of the results stream.
#[derive(Debug)]
enum Outcome {
    Done(TileDone),
    Failed(TileFailed),
}

impl Outcome {
    fn parse(bytes: &[u8]) -> Option<Self> {
        TileDone::from_json(bytes).map(Self::Done).or_else(|_| TileFailed::from_json(bytes).map(Self::Failed)).ok()
    }

    fn tile(&self) -> TileId {
        match self {
            Self::Done(d) => d.tile,
            Self::Failed(f) => f.tile,
        }
    }

    fn campaign_run(&self) -> (&Agency, &plumbline_campaign::CampaignId, u32) {
        match self {
            Self::Done(d) => (&d.agency, &d.campaign, d.run),
            Self::Failed(f) => (&f.agency, &f.campaign, f.run),
        }
    }
}

/// The tally key of a campaign run: `<agency>.<campaign>.<run>`.
fn tally_key(agency: &Agency, id: &plumbline_campaign::CampaignId, run: u32) -> String {
    format!("{agency}.{id}.{run}")
}

/// The adjuster's state.
struct Adjuster {
    bus: Bus,
    files: Files,
    /// The store root the adjuster was started with: manifests from the bus must lie where it stores them.
    layout: Layout,
    tallies: kv::Store,
    metrics: Registry,
    consumer: PullConsumer,
    store_probe: Option<String>,
}

/// Handle results until `shutdown` completes (the result in hand is finished first); answer probes and
/// scrapes on `ops` when given.
pub async fn serve(
    bus: Bus,
    files: Files,
    layout: Layout,
    ops: Option<Ops>,
    shutdown: impl Future<Output = ()>,
) -> plumbline_runtime::Result<()> {
    let stream = bus
        .js
        .get_stream(RESULTS_STREAM)
        .await
        .map_err(|e| Error::transient(format!("stream {RESULTS_STREAM}: {e}")))?;
    let consumer: PullConsumer = stream
        .get_consumer(ADJUSTER_CONSUMER)
        .await
        .map_err(|e| Error::transient(format!("consumer {ADJUSTER_CONSUMER}: {e}")))?;
    let tallies = bus
        .js
        .get_key_value(TALLY_BUCKET)
        .await
        .map_err(|e| Error::transient(format!("KV bucket {TALLY_BUCKET}: {e}")))?;
    let (listener, store_probe) = ops.map(|o| (o.listener, o.store_probe)).unzip();
    let metrics = Registry::new(&ADJUSTER_FAMILIES);
    let adjuster =
        std::sync::Arc::new(Adjuster { bus, files, layout, tallies, metrics, consumer: consumer.clone(), store_probe });
    let (stop_ops, ops_stopped) = tokio::sync::oneshot::channel::<()>();
    if let Some(listener) = listener {
        let probe: std::sync::Arc<dyn Probe> = adjuster.clone();
        tokio::spawn(serve_ops(listener, probe, async {
            let _ = ops_stopped.await;
        }));
    }
    adjuster.resume().await?;
    tracing::info!("adjuster ready");
    tokio::pin!(shutdown);
    loop {
        let batch = tokio::select! {
            () = &mut shutdown => break,
            batch = consumer.batch().max_messages(16).expires(Duration::from_secs(2)).messages() => batch,
        };
        let mut messages = match batch {
            Ok(messages) => messages,
            Err(e) => {
                tracing::warn!(error = %e, "fetching results failed; retrying");
                tokio::time::sleep(Duration::from_secs(1)).await;
                continue;
            }
        };
        while let Some(message) = messages.next().await {
            match message {
                Ok(message) => adjuster.handle(&message).await,
                Err(e) => tracing::warn!(error = %e, "receiving a result failed"),
            }
        }
    }
    let _ = stop_ops.send(());
    tracing::info!("adjuster stopped");
    Ok(())
}

impl Adjuster {
    /// Finish the campaigns a previous adjuster left `adjusting`.
    async fn resume(&self) -> plumbline_runtime::Result<()> {
        for state in self.bus.campaigns.list().await? {
            if state.status == CampaignStatus::Adjusting {
                tracing::info!(campaign = state.id.as_str(), run = state.run, "finishing an interrupted adjustment");
                if let Err(e) = self.finish_campaign(&state, 1).await {
                    // The result that completed it is not acked yet: its redelivery tries again.
                    tracing::warn!(campaign = state.id.as_str(), error = %format!("{e:#}"), "adjustment deferred");
                }
            }
        }
        Ok(())
    }

    /// Record one result and answer it.
    async fn handle(&self, message: &jetstream::Message) {
        let Some(outcome) = Outcome::parse(&message.payload) else {
            tracing::error!("unreadable result dropped");
            reply(message, AckKind::Term).await;
            return;
        };
        let delivered = message.info().map_or(1, |i| i.delivered);
        match with_heartbeat(message, HEARTBEAT, self.record(&outcome, delivered)).await {
            Ok(()) => reply(message, AckKind::Ack).await,
            Err(e) => {
                let delay = retry_delay(delivered);
                self.metrics.add("plumbline_adjuster_retries_total", &[("kind", e.kind().name())], 1.0);
                tracing::warn!(error = %format!("{e:#}"), delivered, ?delay, "recording a result failed; retrying later");
                reply(message, AckKind::Nak(Some(delay))).await;
            }
        }
    }

    /// Count the result into the tally and the state; finish the campaign when every tile is handled.
    async fn record(&self, outcome: &Outcome, delivered: i64) -> plumbline_runtime::Result<()> {
        let (agency, id, run) = outcome.campaign_run();
        let Some((state, _)) = self.bus.campaigns.get(agency, id).await? else {
            tracing::warn!(campaign = id.as_str(), "result of an unknown campaign dropped");
            return Ok(());
        };
        if state.run != run || state.status.is_terminal() {
            return Ok(());
        }
        let (tally, counted_now) = self.add_to_tally(&tally_key(agency, id, run), outcome).await?;
        if counted_now {
            let kind = if matches!(outcome, Outcome::Done(_)) { "done" } else { "failed" };
            self.metrics.add("plumbline_adjuster_results_total", &[("outcome", kind)], 1.0);
        }
        let counted = tally.clone();
        let written = self
            .bus
            .campaigns
            .modify(agency, id, move |s| {
                if s.run != run || s.status.is_terminal() || s.status == CampaignStatus::Adjusting {
                    return false;
                }
                s.tiles_done = counted.done.len() as u64;
                s.tiles_failed = counted.failed.len() as u64;
                s.dead_lettered.clone_from(&counted.failed);
                s.status = if s.tiles_handled() >= s.tiles_total {
                    CampaignStatus::Adjusting
                } else {
                    CampaignStatus::Running
                };
                true
            })
            .await?;
        match written {
            Some(s) if s.status == CampaignStatus::Adjusting && s.run == run => {
                self.finish_campaign(&s, delivered).await
            }
            _ => Ok(()),
        }
    }

    /// Add the result to the run's tally (revision-checked, retried on a lost race); the tally as written
    /// and whether this call counted the tile.
    async fn add_to_tally(&self, key: &str, outcome: &Outcome) -> plumbline_runtime::Result<(Tally, bool)> {
        for _ in 0..64 {
            let entry = self.tallies.entry(key).await.map_err(|e| Error::transient(format!("tally {key}: {e}")))?;
            let (mut tally, revision) = match entry {
                Some(e) if e.operation == kv::Operation::Put => (
                    serde_json::from_slice::<Tally>(&e.value)
                        .map_err(|e| Error::internal(format!("tally {key}: {e}")))?,
                    e.revision,
                ),
                _ => (Tally::default(), 0),
            };
            if !tally.record(outcome) {
                return Ok((tally, false));
            }
            let bytes = serde_json::to_vec(&tally)?;
            let written = if revision == 0 {
                self.tallies.create(key, bytes.into()).await.map(|_| ()).map_err(|e| e.to_string())
            } else {
                self.tallies.update(key, bytes.into(), revision).await.map(|_| ()).map_err(|e| e.to_string())
            };
            match written {
                Ok(()) => return Ok((tally, true)),
                Err(e) => tracing::debug!(key, error = e, "tally write lost a race; reading again"),
            }
        }
        Err(Error::transient(format!("tally {key}: still contended after 64 rounds")))
    }

    /// Adjust the campaign from its done tiles and set `done` (or `failed`). A store failure on delivery
    /// `delivered` < [`MAX_FINISH_DELIVERIES`] is returned instead, leaving the campaign `adjusting`.
    #[tracing::instrument(skip_all, fields(campaign = state.id.as_str(), run = state.run, delivered))]
    async fn finish_campaign(&self, state: &CampaignState, delivered: i64) -> plumbline_runtime::Result<()> {
        tracing::info!(campaign = state.id.as_str(), run = state.run, delivered, "adjustment started");
        let started = std::time::Instant::now();
        let result = self.adjust(state).await;
        self.metrics.observe("plumbline_adjuster_adjustment_seconds", &[], started.elapsed().as_secs_f64());
        let run = state.run;
        let (status, report, error) = match result {
            Ok(report) => (CampaignStatus::Done, Some(report), None),
            Err(e) if store_unavailable(&e) && delivered < MAX_FINISH_DELIVERIES => {
                tracing::warn!(campaign = state.id.as_str(), delivered, error = %format!("{e:#}"),
                    "adjustment interrupted by the store; retrying later");
                return Err(e.context(format!("adjusting campaign {}", state.id.as_str())));
            }
            Err(e) => {
                tracing::error!(campaign = state.id.as_str(), error = %format!("{e:#}"), "adjustment failed");
                (CampaignStatus::Failed, None, Some(format!("adjustment: {e:#}")))
            }
        };
        self.bus
            .campaigns
            .modify(&state.agency, &state.id, move |s| {
                if s.run != run || s.status != CampaignStatus::Adjusting {
                    return false;
                }
                s.status = status;
                s.report.clone_from(&report);
                s.error.clone_from(&error);
                true
            })
            .await?;
        self.metrics.add("plumbline_adjuster_campaigns_total", &[("status", status.as_str())], 1.0);
        tracing::info!(campaign = state.id.as_str(), run, status = status.as_str(), "campaign finished");
        Ok(())
    }

    /// Read the done tiles' outputs and run [`finish`]; the report's URL.
    async fn adjust(&self, state: &CampaignState) -> plumbline_runtime::Result<String> {
        let key = tally_key(&state.agency, &state.id, state.run);
        let entry =
            self.tallies.entry(key.as_str()).await.map_err(|e| Error::transient(format!("tally {key}: {e}")))?;
        let tally: Tally = match entry {
            Some(e) => serde_json::from_slice(&e.value)?,
            None => Tally::default(),
        };
        let mut campaign =
            load_agency_campaign(&self.files, &self.layout, &state.manifest, &state.agency, &state.id).await?;
        let mut outputs = Vec::with_capacity(tally.done.len());
        for tile in &tally.done {
            outputs.push(read_output(&self.files, &format!("{}{}", campaign.output, tile_key(tile))).await?);
        }
        outputs.sort_by_key(|o| o.tile);
        if outputs.is_empty() {
            return Err(Error::internal(format!(
                "no tile of {} could be processed ({} failed)",
                state.id.as_str(),
                tally.failed.len()
            )));
        }
        campaign.skipped.extend(tally.failed.iter().map(|f| {
            SkippedInput::new(Stage::Tiles, format!("tile {}", f.tile), SkipReason::DeadLettered, f.error.clone())
        }));
        let config = AdjusterConfig::from_manifest(&campaign.manifest);
        finish(&self.files, &campaign, &outputs, &config, &NoProgress).await?;
        Ok(format!("{}report.json", campaign.output))
    }
}

/// One tile's output object.
async fn read_output(files: &Files, url: &str) -> plumbline_runtime::Result<TileOutputV1> {
    let bytes = files.read(url).await?;
    let doc: TileOutput =
        serde_json::from_slice(&bytes).map_err(|e| Error::internal(format!("tile output {url}: {e}")))?;
    Ok(doc.into_latest())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn done(col: i64) -> Outcome {
        Outcome::Done(TileDone {
            agency: Agency::parse("hamburg").unwrap(),
            campaign: "hh-2024".parse().unwrap(),
            run: 1,
            tile: TileId { col, row: 0 },
            result: format!("s3://b/results/tiles/{col}_0.json"),
            attempts: 1,
        })
    }

    #[test]
    fn the_retry_delay_doubles_per_delivery_up_to_a_minute_and_only_store_errors_wait() {
        let delays: Vec<u64> = (1..=8).map(|d| retry_delay(d).as_secs()).collect();
        assert_eq!(delays, [2, 4, 8, 16, 32, 60, 60, 60]);
        assert_eq!(retry_delay(0).as_secs(), 2);
        assert!(!store_unavailable(&plumbline_runtime::invalid("manifest: bad")));
        assert!(!store_unavailable(&Error::internal("adjustment: singular normal matrix")));
        assert!(store_unavailable(&Error::transient("s3://b/results/tiles/1_0.json: connection reset")));
    }

    #[test]
    fn a_tile_is_counted_once_whatever_arrives_again() {
        let mut tally = Tally::default();
        assert!(tally.record(&done(1)));
        assert!(!tally.record(&done(1)), "a redelivered TileDone counts again");
        let failed = Outcome::Failed(TileFailed {
            agency: Agency::parse("hamburg").unwrap(),
            campaign: "hh-2024".parse().unwrap(),
            run: 1,
            tile: TileId { col: 2, row: 0 },
            kind: plumbline_scheduler::messages::FailureKind::Permanent,
            error: "bad panoramas".into(),
            attempts: 1,
        });
        assert!(tally.record(&failed));
        assert!(!tally.record(&failed));
        assert!(!tally.record(&done(2)), "a failed tile may not also count as done");
        assert_eq!(tally.done, vec![TileId { col: 1, row: 0 }]);
        assert_eq!(tally.failed, vec![DeadLetter { tile: TileId { col: 2, row: 0 }, error: "bad panoramas".into() }]);
        let back: Tally = serde_json::from_slice(&serde_json::to_vec(&tally).unwrap()).unwrap();
        assert_eq!(back, tally);
    }
}
