//! The worker service (`plumbline serve worker`): pulls [`TileTask`]s from the durable `workers` consumer
//! and processes them with [`crate::run_tile`], following the protocol of [`plumbline_scheduler::bus`]:
//!
//! - a task of a cancelled or failed campaign, of a run other than the state's, of an unknown campaign, or
//!   naming another manifest than the state's is acked and dropped;
//! - otherwise the campaign is loaded (cached per campaign and run) through `load_agency_campaign`: nothing
//!   read from the bus is trusted as a location — the manifest must be the agency's stored one and name only
//!   locations under the agency's prefix, or the tile fails as invalid input — set `running` if still `queued`, and
//!   the tile is processed while an in-progress ack goes out every [`ServiceConfig::heartbeat`]; the output
//!   is written at its deterministic key (a redelivered, already finished tile is read back, not
//!   recomputed), [`TileDone`] is published to the results stream, and the task is acked;
//! - invalid input ([`plumbline_runtime::is_invalid`]), or any error on the last delivery
//!   ([`MAX_DELIVER`]): [`TileFailed`] to results and dead letters, then `AckKind::Term`;
//! - other errors (store, NATS): `AckKind::Nak` with [`ServiceConfig::retry_delay`]. Inputs the store failed
//!   to deliver (skipped with reason `read`) count as such an error, so a store outage delays a tile, and one
//!   longer than the deliveries dead-letters it naming the unread input, instead of leaving holes in it (see
//!   `attempt`). Inputs the store refuses for good (unsupported scheme, permissions: reason `refused`) are
//!   skipped and reported at once like missing ones.
//!
//! [`ServiceConfig::concurrency`] slots each fetch one task at a time, so a worker never holds tasks it
//! is not working on. With an [`Ops`] listener the worker answers `/healthz`, `/readyz` and `/metrics`
//! ([`plumbline_runtime::ops`], the families in `probe.rs`).

use std::collections::HashMap;
use std::future::Future;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use async_nats::jetstream::{self, AckKind, consumer::PullConsumer};
use futures::StreamExt as _;
use futures::future::BoxFuture;
use plumbline_campaign::Campaign;
use plumbline_campaign::CampaignId;
use plumbline_runtime::{Error, Files};
use plumbline_scheduler::bus::{self, Bus, BusError, MAX_DELIVER, RESULTS_STREAM, TASKS_STREAM, WORKERS_CONSUMER};
use plumbline_scheduler::messages::{Agency, CampaignStatus, FailureKind, TileDone, TileFailed, TileTask};
use plumbline_scheduler::service::{Layout, load_agency_campaign};
use tracing::Instrument as _;

use crate::{WorkerConfig, tile_key};

mod attempt;
mod probe;

use plumbline_runtime::ops::{Ops, Probe, Registry, reply, serve_ops, with_heartbeat};
use probe::WORKER_FAMILIES;

/// How the worker service runs.
#[derive(Clone, Copy, Debug)]
pub struct ServiceConfig {
    /// Tasks in flight at once.
    pub concurrency: usize,
    /// Interval of the in-progress acks while a tile runs (must stay below the consumer's `ack_wait`).
    pub heartbeat: Duration,
    /// Delay asked for when a task is nakked after a retryable error.
    pub retry_delay: Duration,
}

impl Default for ServiceConfig {
    fn default() -> Self {
        Self { concurrency: 1, heartbeat: bus::HEARTBEAT, retry_delay: Duration::from_secs(10) }
    }
}

/// Campaigns loaded so far, by campaign and run.
type Cache = Mutex<HashMap<(Agency, CampaignId, u32), Arc<Campaign>>>;

/// The shared state of the slots.
struct Worker {
    bus: Bus,
    files: Files,
    /// The store root the worker was started with: manifests from the bus must lie where it stores them.
    layout: Layout,
    config: ServiceConfig,
    campaigns: Cache,
    metrics: Registry,
    consumer: PullConsumer,
    store_probe: Option<String>,
}

/// What became of one task.
enum Handled {
    /// Dropped: stale run, cancelled/failed or unknown campaign.
    Skipped(&'static str),
    /// The output is written at this URL; read back from an earlier delivery when `resumed`.
    Done { result: String, resumed: bool },
}

/// Process tasks of campaigns stored under `layout`'s root until `shutdown` completes (tasks in flight are
/// finished first); answer probes and scrapes on `ops` when given.
pub async fn serve(
    bus: Bus,
    files: Files,
    layout: Layout,
    config: ServiceConfig,
    ops: Option<Ops>,
    shutdown: impl Future<Output = ()> + Send,
) -> plumbline_runtime::Result<()> {
    let stream =
        bus.js.get_stream(TASKS_STREAM).await.map_err(|e| Error::transient(format!("stream {TASKS_STREAM}: {e}")))?;
    let consumer: PullConsumer = stream
        .get_consumer(WORKERS_CONSUMER)
        .await
        .map_err(|e| Error::transient(format!("consumer {WORKERS_CONSUMER}: {e}")))?;
    let (listener, store_probe) = ops.map(|o| (o.listener, o.store_probe)).unzip();
    let metrics = Registry::new(&WORKER_FAMILIES);
    let worker = Arc::new(Worker {
        bus,
        files,
        layout,
        config,
        campaigns: Mutex::new(HashMap::new()),
        metrics,
        consumer: consumer.clone(),
        store_probe,
    });
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    if let Some(listener) = listener {
        let mut stop = stop_rx.clone();
        let probe: Arc<dyn Probe> = worker.clone();
        tokio::spawn(serve_ops(listener, probe, async move {
            let _ = stop.wait_for(|s| *s).await;
        }));
    }
    let slots: Vec<_> = (0..config.concurrency.max(1))
        .map(|slot| tokio::spawn(run_slot(worker.clone(), consumer.clone(), slot, stop_rx.clone())))
        .collect();
    tracing::info!(concurrency = slots.len(), "worker ready");
    shutdown.await;
    let _ = stop_tx.send(true);
    for slot in slots {
        slot.await?;
    }
    tracing::info!("worker stopped");
    Ok(())
}

/// One task at a time until stopped.
async fn run_slot(worker: Arc<Worker>, consumer: PullConsumer, slot: usize, stop: tokio::sync::watch::Receiver<bool>) {
    while !*stop.borrow() {
        let batch = fetch_one(&consumer).await;
        let mut messages = match batch {
            Ok(messages) => messages,
            Err(e) => {
                tracing::warn!(slot, error = %e, "fetching tasks failed; retrying");
                tokio::time::sleep(Duration::from_secs(1)).await;
                continue;
            }
        };
        while let Some(message) = messages.next().await {
            match message {
                Ok(message) => worker.handle(message).await,
                Err(e) => tracing::warn!(slot, error = %e, "receiving a task failed"),
            }
        }
    }
}

impl Worker {
    /// Handle one delivered task to its ack, nak or term.
    async fn handle(&self, message: jetstream::Message) {
        let delivered = message.info().map_or(1, |i| i.delivered);
        let task = match TileTask::from_json(&message.payload) {
            Ok(task) => task,
            Err(e) => {
                tracing::error!(error = %e, "unreadable task dropped");
                reply(&message, AckKind::Term).await;
                return;
            }
        };
        let span = tracing::info_span!("task", campaign = task.campaign.as_str(), run = task.run, tile = %task.tile);
        self.finish_task(&message, &task, delivered).instrument(span).await;
    }

    /// Process a parsed task and answer it.
    async fn finish_task(&self, message: &jetstream::Message, task: &TileTask, delivered: i64) {
        const IN_FLIGHT: &str = "plumbline_worker_tasks_in_flight";
        self.metrics.add(IN_FLIGHT, &[], 1.0);
        let outcome = with_heartbeat(message, self.config.heartbeat, self.process(task)).await;
        let attempts = u32::try_from(delivered).unwrap_or(u32::MAX);
        match outcome {
            Ok(Handled::Skipped(why)) => {
                tracing::info!(why, "task dropped");
                reply(message, AckKind::Ack).await;
                self.count("dropped");
            }
            Ok(Handled::Done { result, resumed }) => {
                let done = TileDone {
                    agency: task.agency.clone(),
                    campaign: task.campaign.clone(),
                    run: task.run,
                    tile: task.tile,
                    result,
                    attempts,
                };
                match self.publish_result(task, done.to_json()).await {
                    Ok(()) => {
                        self.count(if resumed { "resumed" } else { "done" });
                        if let Err(e) = message.double_ack().await {
                            tracing::warn!(error = %e, "ack lost; the task will be redelivered and read back");
                        }
                    }
                    Err(e) => self.retry_or_give_up(message, task, delivered, attempts, e).await,
                }
            }
            Err(e) => self.retry_or_give_up(message, task, delivered, attempts, e).await,
        }
        self.metrics.add(IN_FLIGHT, &[], -1.0);
    }

    fn count(&self, outcome: &str) {
        self.metrics.add("plumbline_worker_tasks_total", &[("outcome", outcome)], 1.0);
    }

    fn count_error(&self, error: &Error, action: &str) {
        let kind = error.kind().name();
        self.metrics.add("plumbline_worker_task_errors_total", &[("kind", kind), ("action", action)], 1.0);
        self.count(action);
    }

    /// Nak an error with deliveries left unless the input is at fault (invalid, missing, forbidden: it would
    /// fail again); give up on the rest.
    async fn retry_or_give_up(
        &self,
        message: &jetstream::Message,
        task: &TileTask,
        delivered: i64,
        attempts: u32,
        error: Error,
    ) {
        let permanent = error.is_input();
        if !permanent && delivered < MAX_DELIVER {
            tracing::warn!(error = %format!("{error:#}"), delivered, kind = %error.kind(), "tile failed; retrying later");
            reply(message, AckKind::Nak(Some(self.config.retry_delay))).await;
            self.count_error(&error, "retried");
            return;
        }
        let kind = if permanent { FailureKind::Permanent } else { FailureKind::Retryable };
        tracing::error!(error = %format!("{error:#}"), delivered, ?kind, "tile given up");
        let failed = TileFailed {
            agency: task.agency.clone(),
            campaign: task.campaign.clone(),
            run: task.run,
            tile: task.tile,
            kind,
            error: format!("{error:#}"),
            attempts,
        };
        let published = match self.publish_result(task, failed.to_json()).await {
            Ok(()) => self.bus.publish_dead(&failed).await.map_err(Error::from),
            Err(e) => Err(e),
        };
        match published {
            Ok(()) => {
                reply(message, AckKind::Term).await;
                self.count_error(&error, "dead_lettered");
            }
            Err(e) => {
                tracing::warn!(error = %format!("{e:#}"), "reporting the failure failed; retrying later");
                reply(message, AckKind::Nak(Some(self.config.retry_delay))).await;
            }
        }
    }

    /// Check the state, load the campaign, process (or read back) the tile.
    async fn process(&self, task: &TileTask) -> plumbline_runtime::Result<Handled> {
        let Some((mut state, revision)) = self.bus.campaigns.get(&task.agency, &task.campaign).await? else {
            return Ok(Handled::Skipped("unknown campaign"));
        };
        if state.run != task.run {
            return Ok(Handled::Skipped("stale run"));
        }
        if matches!(state.status, CampaignStatus::Cancelled | CampaignStatus::Failed) {
            return Ok(Handled::Skipped("campaign cancelled or failed"));
        }
        if state.status == CampaignStatus::Queued {
            // One try: a lost race means another writer (worker or adjuster) moved the state on.
            state.status = CampaignStatus::Running;
            state.updated = bus::unix_now();
            self.bus.campaigns.update(&state, revision).await?;
        }
        if task.manifest != state.manifest {
            return Ok(Handled::Skipped("the task names another manifest than its campaign's state"));
        }
        let campaign = self.campaign(task).await?;
        tracing::info!("tile started");
        let config = WorkerConfig::from_manifest(&campaign.manifest);
        let (files, owned, tile) = (self.files.clone(), campaign.clone(), task.tile);
        // `process_tile`'s future is not `Send` for every lifetime (closures over references inside), so it
        // is driven on a blocking thread of its own; its CPU work goes to rayon as before.
        // The current span goes along, so the tile's spans stay children of this task's span.
        let (runtime, span) = (tokio::runtime::Handle::current(), tracing::Span::current());
        let done = tokio::task::spawn_blocking(move || {
            span.in_scope(|| runtime.block_on(attempt::attempt(&files, &owned, &tile, &config)))
        })
        .await
        .map_err(|e| Error::internal(format!("tile task: {e}")))??;
        tracing::info!(resumed = done.resumed, "tile written");
        if !done.resumed {
            self.observe_stages(&done);
        }
        Ok(Handled::Done { result: format!("{}{}", campaign.output, tile_key(&task.tile)), resumed: done.resumed })
    }

    /// Stage durations of a processed tile: fetch (reading and decoding every input), registration, poles,
    /// write, total.
    fn observe_stages(&self, done: &attempt::Attempt) {
        for (stage, s) in done.stage_seconds() {
            self.metrics.observe("plumbline_worker_stage_seconds", &[("stage", stage)], s);
        }
    }

    /// The task's campaign, loaded once per campaign and run.
    async fn campaign(&self, task: &TileTask) -> plumbline_runtime::Result<Arc<Campaign>> {
        let key = (task.agency.clone(), task.campaign.clone(), task.run);
        if let Some(found) = self.campaigns.lock().ok().and_then(|c| c.get(&key).cloned()) {
            return Ok(found);
        }
        let loaded =
            load_agency_campaign(&self.files, &self.layout, &task.manifest, &task.agency, &task.campaign).await?;
        let campaign = Arc::new(loaded);
        if let Ok(mut cache) = self.campaigns.lock() {
            cache.retain(|(agency, id, _), _| (agency, id) != (&task.agency, &task.campaign));
            cache.insert(key, campaign.clone());
        }
        Ok(campaign)
    }

    /// Publish a result of `task` and wait for the stream's ack.
    async fn publish_result(&self, task: &TileTask, payload: Vec<u8>) -> plumbline_runtime::Result<()> {
        let subject = bus::result_subject(&task.agency, &task.campaign);
        let failed = |e: String| BusError::Publish { subject: format!("{subject} ({RESULTS_STREAM})"), detail: e };
        let ack = self.bus.js.publish(subject.clone(), payload.into()).await.map_err(|e| failed(e.to_string()))?;
        ack.await.map_err(|e| failed(e.to_string()))?;
        Ok(())
    }
}

/// Fetch at most one task, waiting up to 2 s for it.
fn fetch_one(
    consumer: &PullConsumer,
) -> BoxFuture<'_, Result<jetstream::consumer::pull::Batch, jetstream::consumer::pull::BatchError>> {
    Box::pin(consumer.batch().max_messages(1).expires(Duration::from_secs(2)).messages())
}
