//! The JetStream resources against a real nats-server: `ensure` is idempotent and sets what the module doc
//! promises; revision-checked state updates lose no count under concurrent writers; task de-duplication.
#![allow(clippy::unwrap_used)]

use std::time::Duration;

use async_nats::jetstream::{self, consumer, stream};
use plumbline_geo::tiling::TileId;
use plumbline_scheduler::bus::{self, ensure};
use plumbline_scheduler::messages::{Agency, CampaignState, CampaignStatus, FailureKind, TileFailed, TileTask};
use plumbline_testkit::NatsServer;

fn state(id: &str) -> CampaignState {
    CampaignState {
        id: id.parse().unwrap(),
        agency: Agency::parse("hamburg").unwrap(),
        run: 1,
        manifest: "file:///m.toml".into(),
        output: "file:///out/".into(),
        status: CampaignStatus::Queued,
        tiles_total: 80,
        dispatched: 0,
        tiles_done: 0,
        tiles_failed: 0,
        dead_lettered: Vec::new(),
        panoramas: 0,
        skipped: 0,
        created: 0,
        updated: 0,
        report: None,
        error: None,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ensure_is_idempotent_and_sets_the_documented_settings() {
    let server = NatsServer::start();
    let js = jetstream::new(async_nats::connect(server.url()).await.unwrap());
    ensure(js.clone()).await.unwrap();
    let b = ensure(js.clone()).await.unwrap();

    let mut tasks = js.get_stream(bus::TASKS_STREAM).await.unwrap();
    let info = tasks.info().await.unwrap().config.clone();
    assert_eq!(info.retention, stream::RetentionPolicy::WorkQueue);
    assert_eq!(info.duplicate_window, bus::DUPLICATE_WINDOW);
    assert_eq!(info.subjects, ["plumbline.tasks.>"]);
    let mut workers: consumer::PullConsumer = tasks.get_consumer(bus::WORKERS_CONSUMER).await.unwrap();
    let c = workers.info().await.unwrap().config.clone();
    assert_eq!(c.ack_policy, consumer::AckPolicy::Explicit);
    assert_eq!(
        (c.ack_wait, c.max_deliver, c.backoff.clone()),
        (bus::ACK_WAIT, bus::MAX_DELIVER, bus::BACKOFF.to_vec())
    );
    let mut results = js.get_stream(bus::RESULTS_STREAM).await.unwrap();
    assert_eq!(results.info().await.unwrap().config.retention, stream::RetentionPolicy::Limits);
    let mut dead = js.get_stream(bus::DEAD_STREAM).await.unwrap();
    assert_eq!(dead.info().await.unwrap().config.subjects, ["plumbline.dead.>"]);

    // A task published twice with its id is stored once; a dead letter lands in its stream.
    let task = TileTask {
        agency: Agency::parse("hamburg").unwrap(),
        campaign: "c1".parse().unwrap(),
        run: 1,
        manifest: "file:///m.toml".into(),
        tile: TileId { col: 1, row: 2 },
        output: "file:///out/".into(),
    };
    assert!(b.publish_task(&task).await.unwrap());
    assert!(!b.publish_task(&task).await.unwrap());
    assert!(b.publish_task(&TileTask { run: 2, ..task.clone() }).await.unwrap());
    assert_eq!(b.queued_tasks().await.unwrap(), 2);
    let failed = TileFailed {
        agency: task.agency.clone(),
        campaign: task.campaign.clone(),
        run: 1,
        tile: task.tile,
        kind: FailureKind::Permanent,
        error: "bad".into(),
        attempts: 1,
    };
    b.publish_dead(&failed).await.unwrap();
    let m = dead.get_last_raw_message_by_subject("plumbline.dead.hamburg.c1").await.unwrap();
    assert_eq!(TileFailed::from_json(&m.payload).unwrap(), failed);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn concurrent_state_updates_lose_no_count() {
    let server = NatsServer::start();
    let js = jetstream::new(async_nats::connect(server.url()).await.unwrap());
    let b = ensure(js).await.unwrap();
    let s = state("counted");
    assert!(b.campaigns.create(&s).await.unwrap().is_some());
    assert!(b.campaigns.create(&s).await.unwrap().is_none(), "create refuses an existing key");

    let writers: Vec<_> = (0..8)
        .map(|_| {
            let store = b.campaigns.clone();
            let (agency, id) = (s.agency.clone(), s.id.clone());
            tokio::spawn(async move {
                for _ in 0..10 {
                    store
                        .modify(&agency, &id, |c| {
                            c.tiles_done += 1;
                            c.status = CampaignStatus::Running;
                            true
                        })
                        .await
                        .unwrap();
                }
            })
        })
        .collect();
    for w in writers {
        tokio::time::timeout(Duration::from_secs(60), w).await.unwrap().unwrap();
    }
    let (after, revision) = b.campaigns.get(&s.agency, &s.id).await.unwrap().unwrap();
    assert_eq!(after.tiles_done, 80);
    // A write against an old revision is refused.
    assert!(b.campaigns.update(&after, revision - 1).await.unwrap().is_none());
    assert!(b.campaigns.update(&after, revision).await.unwrap().is_some());
    assert_eq!(b.campaigns.list().await.unwrap().len(), 1);

    // Ids are per agency: another agency's campaign of the same id is another key.
    let bremen = Agency::parse("bremen").unwrap();
    assert!(b.campaigns.get(&bremen, &s.id).await.unwrap().is_none());
    let other = CampaignState { agency: bremen.clone(), ..state("counted") };
    assert!(b.campaigns.create(&other).await.unwrap().is_some());
    assert_eq!(b.campaigns.get(&bremen, &s.id).await.unwrap().unwrap().0.tiles_done, 0);
    assert_eq!(b.campaigns.list().await.unwrap().len(), 2);
    // A state written under one agency's key naming another (not by the roles) is refused, not served.
    let kv = jetstream::new(async_nats::connect(server.url()).await.unwrap());
    let kv = kv.get_key_value(bus::CAMPAIGNS_BUCKET).await.unwrap();
    kv.put(bus::campaign_key(&s.agency, &s.id), other.to_json().into()).await.unwrap();
    let refused = b.campaigns.get(&s.agency, &s.id).await.unwrap_err();
    assert!(matches!(refused, bus::BusError::Forged { .. }), "{refused}");
    assert!(refused.to_string().contains("names agency bremen"), "{refused}");
    assert_eq!(b.campaigns.list().await.unwrap().len(), 1, "the forged state is left out of the list");
}
