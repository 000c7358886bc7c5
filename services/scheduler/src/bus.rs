//! The JetStream resources of the distributed path, created or bound idempotently by [`ensure`].
//!
//! | resource | name | settings | used by |
//! |---|---|---|---|
//! | work queue | stream `PLUMBLINE_TASKS`, subjects `plumbline.tasks.<agency>.<campaign>` | work-queue retention (a task is gone once acked), file storage, `Nats-Msg-Id` de-duplication over [`DUPLICATE_WINDOW`] (1 h) | scheduler publishes [`TileTask`]s, one per tile, id `<agency>.<campaign>.<run>.<tile>` |
//! | workers' consumer | durable pull consumer `workers` on `PLUMBLINE_TASKS` | explicit ack, `ack_wait` [`ACK_WAIT`] (60 s; workers send in-progress acks every [`HEARTBEAT`] while a tile runs), `max_deliver` [`MAX_DELIVER`] (5), redelivery backoff [`BACKOFF`] after ack timeouts (its first step equals `ack_wait`), `max_ack_pending` [`MAX_ACK_PENDING`] | workers: ack after the tile's output is written; nak with a delay on retryable errors; `term` + dead letter on permanent ones or on the last delivery |
//! | results | stream `PLUMBLINE_RESULTS`, subjects `plumbline.results.<agency>.<campaign>` | limits retention, [`RESULTS_MAX_AGE`] (7 days), file storage | workers publish [`TileDone`]/[`TileFailed`] |
//! | adjuster's consumer | durable pull consumer `adjuster` on `PLUMBLINE_RESULTS` | explicit ack, deliver all (a restarted adjuster replays what it has not acked), `ack_wait` [`ADJUSTER_ACK_WAIT`] | adjuster |
//! | dead letters | stream `PLUMBLINE_DEAD`, subjects `plumbline.dead.<agency>.<campaign>` | limits retention, [`DEAD_MAX_AGE`] (30 days) | workers publish a [`TileFailed`] for every task given up on |
//! | campaign state | KV bucket `plumbline-campaigns`, key `<agency>.<campaign>` ([`campaign_key`]; ids are per agency) | history 5, file storage; writers use [`CampaignStore::modify`] (read, change, `update` with the read revision, retry on a lost race); a state whose agency or id is not its key's is refused | everyone |
//! | adjuster's tallies | KV bucket `plumbline-adjuster`, key `<agency>.<campaign>.<run>` | history 1, file storage; the tiles done and failed of a run, revision-checked, so a redelivered result is counted once | adjuster |
//!
//! The roles' loops on top of these resources:
//! - **scheduler** (this crate's [`crate::service`]): stores the manifest and `plan.json`, creates the state
//!   (`queued`, run n) and only then publishes the run's tasks — a window of them per agency at a time
//!   ([`crate::service::dispatch`]), raising the state's `dispatched` after publishing — each with
//!   `Nats-Msg-Id` `<agency>.<campaign>.<run>.<tile>` ([`task_message_id`]), so publishing again within the
//!   window adds nothing.
//! - **worker**: fetch from `workers`; read the state: a task whose campaign is `cancelled`/`failed`, or
//!   whose run is not the state's run, is acked and dropped. Otherwise set `running` (if `queued`), process
//!   the tile (off the async runtime) sending `AckKind::Progress` every [`HEARTBEAT`], write the output to
//!   `{output}{tile_key}` (deterministic key: a redelivery rewrites the same object), publish [`TileDone`],
//!   then ack (`double_ack`). A retryable error with deliveries left: `AckKind::Nak(Some(delay))`. A
//!   permanent error, or a retryable one on delivery [`MAX_DELIVER`]: publish [`TileFailed`] to results and
//!   dead letters ([`Bus::publish_dead`]), then `AckKind::Term`.
//! - **adjuster**: fetch from `adjuster`; count each tile once per run (a redelivered [`TileDone`] of a tile
//!   already counted changes nothing) into the state with [`CampaignStore::modify`] (`tiles_done`,
//!   `tiles_failed`, `dead_lettered`); when `tiles_done + tiles_failed == tiles_total`, set `adjusting`, run
//!   the global adjustment from the output objects, write the outputs and set `done` with `report`, or
//!   `failed` with `error`. Ack after the state is written; a restart replays the unacked results.
//!
//! [`TileTask`]: crate::messages::TileTask
//! [`TileDone`]: crate::messages::TileDone
//! [`TileFailed`]: crate::messages::TileFailed

use std::time::Duration;

use async_nats::jetstream::{self, consumer, kv, stream};
use plumbline_campaign::CampaignId;
use plumbline_geo::tiling::TileId;

use crate::messages::{Agency, CampaignState, MessageError, TileFailed, TileTask};

/// The work-queue stream.
pub const TASKS_STREAM: &str = "PLUMBLINE_TASKS";
/// The results stream.
pub const RESULTS_STREAM: &str = "PLUMBLINE_RESULTS";
/// The dead-letter stream.
pub const DEAD_STREAM: &str = "PLUMBLINE_DEAD";
/// The campaign-state KV bucket.
pub const CAMPAIGNS_BUCKET: &str = "plumbline-campaigns";
/// The adjuster's KV bucket of the tiles counted per campaign run.
pub const TALLY_BUCKET: &str = "plumbline-adjuster";
/// The workers' durable consumer.
pub const WORKERS_CONSUMER: &str = "workers";
/// The adjuster's durable consumer.
pub const ADJUSTER_CONSUMER: &str = "adjuster";
/// Window within which a task published again with the same `Nats-Msg-Id` is dropped.
pub const DUPLICATE_WINDOW: Duration = Duration::from_secs(3600);
/// Time a worker has to ack (or heartbeat) a delivered task before it is redelivered.
pub const ACK_WAIT: Duration = Duration::from_secs(60);
/// How often a worker sends an in-progress ack while it processes a tile.
pub const HEARTBEAT: Duration = Duration::from_secs(20);
/// Deliveries of one task before it is given up.
pub const MAX_DELIVER: i64 = 5;
/// Redelivery delays after ack timeouts (deliveries 2, 3, 4, 5).
pub const BACKOFF: [Duration; 4] =
    [Duration::from_secs(60), Duration::from_secs(120), Duration::from_secs(300), Duration::from_secs(600)];
/// Unacked tasks handed out at once over all workers.
pub const MAX_ACK_PENDING: i64 = 1024;
/// Age after which results are dropped.
pub const RESULTS_MAX_AGE: Duration = Duration::from_secs(7 * 24 * 3600);
/// Age after which dead letters are dropped.
pub const DEAD_MAX_AGE: Duration = Duration::from_secs(30 * 24 * 3600);
/// Time the adjuster has to ack a result.
pub const ADJUSTER_ACK_WAIT: Duration = Duration::from_secs(300);

/// The KV key of a campaign's state: `<agency>.<campaign>` (neither holds a dot).
pub fn campaign_key(agency: &Agency, campaign: &CampaignId) -> String {
    format!("{agency}.{campaign}")
}

/// The subject of a campaign's tasks.
pub fn task_subject(agency: &Agency, campaign: &CampaignId) -> String {
    format!("plumbline.tasks.{agency}.{campaign}")
}

/// The subject of a campaign's results.
pub fn result_subject(agency: &Agency, campaign: &CampaignId) -> String {
    format!("plumbline.results.{agency}.{campaign}")
}

/// The subject of a campaign's dead letters.
pub fn dead_subject(agency: &Agency, campaign: &CampaignId) -> String {
    format!("plumbline.dead.{agency}.{campaign}")
}

/// The `Nats-Msg-Id` of a task: the same tile of the same run is published once within the window.
pub fn task_message_id(agency: &Agency, campaign: &CampaignId, run: u32, tile: &TileId) -> String {
    format!("{agency}.{campaign}.{run}.{tile}")
}

/// The work-queue stream's config.
pub fn tasks_stream() -> stream::Config {
    stream::Config {
        name: TASKS_STREAM.into(),
        description: Some("plumbline tile tasks (work queue)".into()),
        subjects: vec!["plumbline.tasks.>".into()],
        retention: stream::RetentionPolicy::WorkQueue,
        storage: stream::StorageType::File,
        duplicate_window: DUPLICATE_WINDOW,
        ..Default::default()
    }
}

/// The results stream's config.
pub fn results_stream() -> stream::Config {
    stream::Config {
        name: RESULTS_STREAM.into(),
        description: Some("plumbline tile results (done/failed), keys of objects in the store".into()),
        subjects: vec!["plumbline.results.>".into()],
        retention: stream::RetentionPolicy::Limits,
        storage: stream::StorageType::File,
        max_age: RESULTS_MAX_AGE,
        ..Default::default()
    }
}

/// The dead-letter stream's config.
pub fn dead_stream() -> stream::Config {
    stream::Config {
        name: DEAD_STREAM.into(),
        description: Some("plumbline tile tasks given up on".into()),
        subjects: vec!["plumbline.dead.>".into()],
        retention: stream::RetentionPolicy::Limits,
        storage: stream::StorageType::File,
        max_age: DEAD_MAX_AGE,
        ..Default::default()
    }
}

/// The workers' durable pull consumer.
pub fn workers_consumer() -> consumer::pull::Config {
    consumer::pull::Config {
        durable_name: Some(WORKERS_CONSUMER.into()),
        description: Some("plumbline workers".into()),
        ack_policy: consumer::AckPolicy::Explicit,
        ack_wait: ACK_WAIT,
        max_deliver: MAX_DELIVER,
        backoff: BACKOFF.to_vec(),
        max_ack_pending: MAX_ACK_PENDING,
        filter_subject: "plumbline.tasks.>".into(),
        ..Default::default()
    }
}

/// The adjuster's durable pull consumer.
pub fn adjuster_consumer() -> consumer::pull::Config {
    consumer::pull::Config {
        durable_name: Some(ADJUSTER_CONSUMER.into()),
        description: Some("plumbline adjuster".into()),
        ack_policy: consumer::AckPolicy::Explicit,
        ack_wait: ADJUSTER_ACK_WAIT,
        deliver_policy: consumer::DeliverPolicy::All,
        filter_subject: "plumbline.results.>".into(),
        ..Default::default()
    }
}

/// The campaign-state bucket's config.
pub fn campaigns_bucket() -> kv::Config {
    kv::Config {
        bucket: CAMPAIGNS_BUCKET.into(),
        description: "plumbline campaign states (CampaignState v1 JSON)".into(),
        history: 5,
        storage: stream::StorageType::File,
        ..Default::default()
    }
}

/// The adjuster's tally bucket's config.
pub fn tally_bucket() -> kv::Config {
    kv::Config {
        bucket: TALLY_BUCKET.into(),
        description: "plumbline adjuster: tiles counted per campaign run".into(),
        history: 1,
        storage: stream::StorageType::File,
        ..Default::default()
    }
}

/// A failure talking to JetStream, naming the resource.
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    /// Creating or binding a stream, consumer or bucket failed.
    #[error("JetStream {resource}: {detail}")]
    Setup {
        /// The resource's name.
        resource: &'static str,
        /// The server's or client's message.
        detail: String,
    },
    /// Publishing failed (after the client's retries).
    #[error("publishing to {subject}: {detail}")]
    Publish {
        /// The subject.
        subject: String,
        /// The message.
        detail: String,
    },
    /// Reading or writing the campaign state failed.
    #[error("campaign state {key}: {detail}")]
    State {
        /// The KV key.
        key: String,
        /// The message.
        detail: String,
    },
    /// A stored state names another agency or campaign than its key: written by someone other than the
    /// roles, never served or followed.
    #[error("campaign state {key}: {detail}")]
    Forged {
        /// The KV key.
        key: String,
        /// What does not match.
        detail: String,
    },
    /// A stored message could not be read.
    #[error(transparent)]
    Message(#[from] MessageError),
}

/// As a service error: the broker failing for now is transient; a forged state is refused; a stored
/// message that cannot be read will not read on retry either.
impl From<BusError> for plumbline_runtime::Error {
    fn from(e: BusError) -> Self {
        use plumbline_runtime::ErrorKind;
        let kind = match &e {
            BusError::Setup { .. } | BusError::Publish { .. } | BusError::State { .. } => ErrorKind::Transient,
            BusError::Forged { .. } => ErrorKind::Forbidden,
            BusError::Message(_) => ErrorKind::Internal,
        };
        Self::from_cause(kind, e)
    }
}

fn setup(resource: &'static str) -> impl FnOnce(String) -> BusError {
    move |detail| BusError::Setup { resource, detail }
}

/// The bound JetStream resources.
#[derive(Clone, Debug)]
pub struct Bus {
    /// The JetStream context.
    pub js: jetstream::Context,
    /// The campaign states.
    pub campaigns: CampaignStore,
}

/// Create (or bind, when they exist with these settings; update them otherwise) every stream, consumer
/// and bucket of the table above.
pub async fn ensure(js: jetstream::Context) -> Result<Bus, BusError> {
    for config in [tasks_stream(), results_stream(), dead_stream()] {
        js.create_or_update_stream(config).await.map_err(|e| setup("stream")(e.to_string()))?;
    }
    let tasks = js.get_stream(TASKS_STREAM).await.map_err(|e| setup(TASKS_STREAM)(e.to_string()))?;
    ensure_consumer(&tasks, workers_consumer(), WORKERS_CONSUMER).await?;
    let results = js.get_stream(RESULTS_STREAM).await.map_err(|e| setup(RESULTS_STREAM)(e.to_string()))?;
    ensure_consumer(&results, adjuster_consumer(), ADJUSTER_CONSUMER).await?;
    js.create_or_update_key_value(tally_bucket()).await.map_err(|e| setup(TALLY_BUCKET)(e.to_string()))?;
    let kv =
        js.create_or_update_key_value(campaigns_bucket()).await.map_err(|e| setup(CAMPAIGNS_BUCKET)(e.to_string()))?;
    Ok(Bus { js, campaigns: CampaignStore { kv } })
}

/// Bind the resources [`ensure`] creates, changing nothing: the worker's and the adjuster's way, whose NATS
/// users may not create or change streams (deploy/nats.conf). Waits up to `wait` for a scheduler to have
/// created them.
pub async fn bind(js: jetstream::Context, wait: Duration) -> Result<Bus, BusError> {
    let started = std::time::Instant::now();
    loop {
        match try_bind(&js).await {
            Ok(bus) => return Ok(bus),
            Err(e) if started.elapsed() < wait => {
                tracing::warn!(error = %e, "JetStream resources not there yet (has the scheduler started?); retrying");
                tokio::time::sleep(Duration::from_secs(1)).await;
            }
            Err(e) => return Err(e),
        }
    }
}

async fn try_bind(js: &jetstream::Context) -> Result<Bus, BusError> {
    for name in [TASKS_STREAM, RESULTS_STREAM, DEAD_STREAM] {
        js.get_stream(name).await.map_err(|e| setup(name)(e.to_string()))?;
    }
    let kv = js.get_key_value(CAMPAIGNS_BUCKET).await.map_err(|e| setup(CAMPAIGNS_BUCKET)(e.to_string()))?;
    Ok(Bus { js: js.clone(), campaigns: CampaignStore { kv } })
}

async fn ensure_consumer(
    stream: &stream::Stream,
    config: consumer::pull::Config,
    name: &'static str,
) -> Result<(), BusError> {
    if stream.consumer_info(name).await.is_ok() {
        stream.update_consumer(config).await.map_err(|e| setup(name)(e.to_string()))?;
    } else {
        stream.create_consumer(config).await.map_err(|e| setup(name)(e.to_string()))?;
    }
    Ok(())
}

impl Bus {
    /// Publish one task with its de-duplication id; `Ok(true)` when the stream stored it, `Ok(false)` when
    /// it dropped it as a duplicate.
    pub async fn publish_task(&self, task: &TileTask) -> Result<bool, BusError> {
        let subject = task_subject(&task.agency, &task.campaign);
        let message = jetstream::message::PublishMessage::build()
            .payload(task.to_json().into())
            .message_id(task_message_id(&task.agency, &task.campaign, task.run, &task.tile));
        let publish_error = |e: String| BusError::Publish { subject: subject.clone(), detail: e };
        let ack = self.js.send_publish(subject.clone(), message).await.map_err(|e| publish_error(e.to_string()))?;
        let ack = ack.await.map_err(|e| publish_error(e.to_string()))?;
        Ok(!ack.duplicate)
    }

    /// Publish a failed task to the dead-letter stream.
    pub async fn publish_dead(&self, failed: &TileFailed) -> Result<(), BusError> {
        let subject = dead_subject(&failed.agency, &failed.campaign);
        let publish_error = |e: String| BusError::Publish { subject: subject.clone(), detail: e };
        let ack = self
            .js
            .publish(subject.clone(), failed.to_json().into())
            .await
            .map_err(|e| publish_error(e.to_string()))?;
        ack.await.map_err(|e| publish_error(e.to_string()))?;
        Ok(())
    }

    /// Tasks waiting in the work queue (not yet acked).
    pub async fn queued_tasks(&self) -> Result<u64, BusError> {
        let mut stream = self.js.get_stream(TASKS_STREAM).await.map_err(|e| setup(TASKS_STREAM)(e.to_string()))?;
        let info = stream.info().await.map_err(|e| setup(TASKS_STREAM)(e.to_string()))?;
        Ok(info.state.messages)
    }
}

/// The campaign states in the KV bucket, with revision-checked updates.
#[derive(Clone, Debug)]
pub struct CampaignStore {
    kv: kv::Store,
}

/// Rounds of read–change–write before a contended update gives up.
const MAX_UPDATE_ROUNDS: usize = 64;

impl CampaignStore {
    /// The state of `agency`'s campaign `id` and its revision, or `None` when it is unknown. A stored state
    /// naming another agency or id than its key is refused (an error), never returned.
    pub async fn get(&self, agency: &Agency, id: &CampaignId) -> Result<Option<(CampaignState, u64)>, BusError> {
        let key = campaign_key(agency, id);
        let entry = self.kv.entry(key.as_str()).await.map_err(|e| state_error(&key, e.to_string()))?;
        let Some(entry) = entry.filter(|e| e.operation == kv::Operation::Put) else { return Ok(None) };
        let state = CampaignState::from_json(&entry.value)?;
        if state.agency != *agency || state.id != *id {
            let found = format!("agency {} and id {}", state.agency, state.id);
            return Err(BusError::Forged { key, detail: format!("the stored state names {found}, not its key's") });
        }
        Ok(Some((state, entry.revision)))
    }

    /// Store a state only when the key is new (or deleted); `Ok(None)` when it already exists.
    pub async fn create(&self, state: &CampaignState) -> Result<Option<u64>, BusError> {
        let key = campaign_key(&state.agency, &state.id);
        match self.kv.create(key.as_str(), state.to_json().into()).await {
            Ok(revision) => Ok(Some(revision)),
            Err(e) if e.kind() == kv::CreateErrorKind::AlreadyExists => Ok(None),
            Err(e) => Err(state_error(&key, e.to_string())),
        }
    }

    /// Replace the state written at `revision`; `Ok(None)` when another writer came first.
    pub async fn update(&self, state: &CampaignState, revision: u64) -> Result<Option<u64>, BusError> {
        let key = campaign_key(&state.agency, &state.id);
        match self.kv.update(key.as_str(), state.to_json().into(), revision).await {
            Ok(revision) => Ok(Some(revision)),
            Err(e) if e.kind() == kv::UpdateErrorKind::WrongLastRevision => Ok(None),
            Err(e) => Err(state_error(&key, e.to_string())),
        }
    }

    /// Read, change and write back until no other writer intervenes. `change` returns `false` to leave
    /// the state as it is. Returns the state as written (or found), `None` for an unknown campaign.
    pub async fn modify(
        &self,
        agency: &Agency,
        id: &CampaignId,
        mut change: impl FnMut(&mut CampaignState) -> bool,
    ) -> Result<Option<CampaignState>, BusError> {
        for _ in 0..MAX_UPDATE_ROUNDS {
            let Some((mut state, revision)) = self.get(agency, id).await? else { return Ok(None) };
            if !change(&mut state) {
                return Ok(Some(state));
            }
            state.updated = unix_now();
            if self.update(&state, revision).await?.is_some() {
                return Ok(Some(state));
            }
        }
        Err(state_error(&campaign_key(agency, id), format!("still contended after {MAX_UPDATE_ROUNDS} rounds")))
    }

    /// Every campaign state of every agency (unreadable entries and keys of another shape are logged and
    /// left out).
    pub async fn list(&self) -> Result<Vec<CampaignState>, BusError> {
        use futures::TryStreamExt as _;
        let keys: Vec<String> = match self.kv.keys().await {
            Ok(keys) => keys.try_collect().await.map_err(|e| state_error("*", e.to_string()))?,
            Err(e) => return Err(state_error("*", e.to_string())),
        };
        let mut out = Vec::with_capacity(keys.len());
        for key in keys {
            let parsed = key.split_once('.').and_then(|(a, id)| Some((Agency::parse(a).ok()?, id.parse().ok()?)));
            let Some((agency, id)) = parsed else {
                tracing::warn!(key, "campaign state key is not <agency>.<campaign>; left out of the list");
                continue;
            };
            match self.get(&agency, &id).await {
                Ok(Some((state, _))) => out.push(state),
                Ok(None) => {}
                Err(e) => tracing::warn!(key, error = %e, "campaign state left out of the list"),
            }
        }
        Ok(out)
    }
}

fn state_error(key: &str, detail: String) -> BusError {
    BusError::State { key: key.to_owned(), detail }
}

/// Seconds since the Unix epoch.
pub fn unix_now() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs())
}
