//! The job API against a real nats-server and a real S3 server (moto): submission publishes one task per
//! planned tile (de-duplicated on resubmission), state in the KV bucket, agency isolation, cancellation,
//! rejected manifests naming their fields, and publishing after a nats-server restart.
#![allow(clippy::unwrap_used)]

use crate::support;

use std::time::{Duration, Instant};

use async_nats::jetstream;
use plumbline_campaign::plan::PlanDoc;
use plumbline_scheduler::bus::TASKS_STREAM;
use plumbline_scheduler::messages::{CampaignStatus, TileTask};
use reqwest::StatusCode;
use support::{BREMEN, HAMBURG, Harness, TINY_TILES, manifest};

/// Every task of agency hamburg in the work queue (read without consuming: the stream's messages by
/// sequence).
async fn tasks(h: &Harness) -> Vec<TileTask> {
    let mut all = all_tasks(h).await;
    all.retain(|t| t.agency.as_str() == "hamburg");
    all
}

/// Every task in the work queue, in queue order.
async fn all_tasks(h: &Harness) -> Vec<TileTask> {
    let js = jetstream::new(async_nats::connect(h.nats.url()).await.unwrap());
    let stream = js.get_stream(TASKS_STREAM).await.unwrap();
    let mut stream_info = stream.clone();
    let info = stream_info.info().await.unwrap();
    let mut out = Vec::new();
    for seq in info.state.first_sequence..=info.state.last_sequence {
        if let Ok(m) = stream.get_raw_message(seq).await {
            out.push(TileTask::from_json(&m.payload).unwrap());
        }
    }
    assert_eq!(out.len() as u64, info.state.messages);
    out
}

fn status_of(e: &plumbline_scheduler::client::ClientError) -> StatusCode {
    e.status().unwrap_or_else(|| panic!("no HTTP answer: {e}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn submit_status_cancel_and_isolation_on_s3() {
    let h = Harness::s3().await;
    h.upload_inputs("hamburg", "tiny-1").await;
    let hh = h.client(HAMBURG);
    let text = manifest("tiny-1", "nav/dg.csv", "results/");

    let view = hh.submit(text.clone().into_bytes(), false).await.unwrap();
    let state = &view.campaign;
    assert_eq!((state.status, state.run, state.agency.as_str()), (CampaignStatus::Queued, 1, "hamburg"));
    assert_eq!(state.tiles_total, TINY_TILES);
    assert_eq!(state.panoramas, 30);
    assert_eq!(state.manifest, format!("{}manifest.toml", h.campaign_dir("hamburg", "tiny-1")));
    assert_eq!(state.output, format!("{}results/", h.campaign_dir("hamburg", "tiny-1")));

    // One task per planned tile, the plan beside the outputs, the state in the KV bucket.
    let plan = match serde_json::from_slice(&h.files.read(&format!("{}plan.json", state.output)).await.unwrap()) {
        Ok(PlanDoc::V1(plan)) => plan,
        Err(e) => panic!("plan.json: {e}"),
    };
    let planned: Vec<_> = plan.tiles.tiles().iter().map(|t| t.id).collect();
    let queued = tasks(&h).await;
    let mut queued_tiles: Vec<_> = queued.iter().map(|t| t.tile).collect();
    queued_tiles.sort_by_key(|t| (t.row, t.col));
    assert_eq!(queued_tiles, planned);
    assert_eq!(planned.iter().map(|t| t.col).collect::<Vec<_>>(), (5000..5006).collect::<Vec<_>>());
    assert!(queued.iter().all(|t| t.run == 1 && t.manifest == state.manifest && t.output == state.output));
    let (kv, _) = h.scheduler.bus().campaigns.get(&state.agency, &state.id).await.unwrap().unwrap();
    assert_eq!(kv, view.campaign);

    // Resubmitting the same manifest publishes nothing new.
    let again = hh.submit(text.clone().into_bytes(), false).await.unwrap();
    assert_eq!(again.campaign.run, 1);
    assert_eq!(tasks(&h).await.len() as u64, TINY_TILES);
    // A different manifest for the active campaign is refused.
    let changed = text.replace("tiny test drive", "changed");
    assert_eq!(status_of(&hh.submit(changed.into_bytes(), false).await.unwrap_err()), StatusCode::CONFLICT);

    // Status for its agency; 404 for another agency; 401 without a token.
    let shown = hh.status("tiny-1").await.unwrap();
    assert_eq!(shown.campaign, view.campaign);
    assert_eq!(shown.stages[1].total, TINY_TILES);
    let hb = h.client(BREMEN);
    assert_eq!(status_of(&hb.status("tiny-1").await.unwrap_err()), StatusCode::NOT_FOUND);
    assert_eq!(status_of(&hb.cancel("tiny-1").await.unwrap_err()), StatusCode::NOT_FOUND);
    assert!(hb.list().await.unwrap().campaigns.is_empty());
    assert_eq!(hh.list().await.unwrap().campaigns.len(), 1);
    let anonymous = reqwest::get(format!("{}/v1/campaigns/tiny-1", h.server)).await.unwrap();
    assert_eq!(anonymous.status(), StatusCode::UNAUTHORIZED);
    assert_eq!(status_of(&h.client("not-a-known-token-000").list().await.unwrap_err()), StatusCode::UNAUTHORIZED);
    // Ids are per agency: bremen's campaign tiny-1 is its own, under its own prefix, and learns nothing of
    // hamburg's; hamburg's is untouched.
    h.upload_inputs("bremen", "tiny-1").await;
    let theirs = hb.submit(text.clone().into_bytes(), false).await.unwrap();
    assert_eq!((theirs.campaign.agency.as_str(), theirs.campaign.run), ("bremen", 1));
    assert_eq!(theirs.campaign.manifest, format!("{}manifest.toml", h.campaign_dir("bremen", "tiny-1")));
    assert_eq!(hh.status("tiny-1").await.unwrap().campaign, view.campaign);
    assert_eq!(hb.cancel("tiny-1").await.unwrap().campaign.status, CampaignStatus::Cancelled);
    assert_eq!(hh.status("tiny-1").await.unwrap().campaign.status, CampaignStatus::Queued);
    assert_eq!(status_of(&hh.report("tiny-1").await.unwrap_err()), StatusCode::CONFLICT);

    // Cancel: the KV state says so; cancelling again is a conflict; a new submission starts run 2.
    let cancelled = hh.cancel("tiny-1").await.unwrap();
    assert_eq!(cancelled.campaign.status, CampaignStatus::Cancelled);
    let (kv, _) = h.scheduler.bus().campaigns.get(&state.agency, &state.id).await.unwrap().unwrap();
    assert_eq!(kv.status, CampaignStatus::Cancelled);
    assert_eq!(status_of(&hh.cancel("tiny-1").await.unwrap_err()), StatusCode::CONFLICT);
    let rerun = hh.submit(text.into_bytes(), false).await.unwrap();
    assert_eq!((rerun.campaign.run, rerun.campaign.status), (2, CampaignStatus::Queued));
    let all = tasks(&h).await;
    assert_eq!(all.len() as u64, 2 * TINY_TILES);
    assert_eq!(all.iter().filter(|t| t.run == 2).count() as u64, TINY_TILES);

    // What the adjuster will do when finished: the report is served from the store once the state is done.
    let report_url = format!("{}report.json", rerun.campaign.output);
    h.files.write(&report_url, br#"{"version":"1","summary":{"epochs":601}}"#.to_vec()).await.unwrap();
    let done = h.scheduler.bus().campaigns.modify(&state.agency, &state.id, |c| {
        c.status = CampaignStatus::Done;
        c.report = Some(report_url.clone());
        true
    });
    done.await.unwrap().unwrap();
    assert_eq!(hh.report("tiny-1").await.unwrap()["summary"]["epochs"], 601);
    // Bremen's tiny-1 (cancelled) has no report; hamburg's is not served to it.
    let e = hb.report("tiny-1").await.unwrap_err();
    assert_eq!(status_of(&e), StatusCode::CONFLICT, "{e}");
    assert!(!e.to_string().contains("601"), "{e}");
    assert_eq!(status_of(&hh.cancel("tiny-1").await.unwrap_err()), StatusCode::CONFLICT);

    let metrics = reqwest::get(format!("{}/metrics", h.server)).await.unwrap().text().await.unwrap();
    for line in [
        format!("plumbline_tasks_published_total {}", 3 * TINY_TILES),
        format!("plumbline_tasks_duplicate_total {TINY_TILES}"),
        "plumbline_campaigns{status=\"done\"} 1".to_owned(),
        format!("plumbline_work_queue_messages {}", 3 * TINY_TILES),
        "plumbline_api_requests_total{route=\"/v1/campaigns/{id}\",status=\"404\"} 2".to_owned(),
        "plumbline_api_requests_total{route=\"/v1/campaigns/{id}/report\",status=\"200\"} 1".to_owned(),
    ] {
        assert!(metrics.lines().any(|l| l == line), "{line} missing from\n{metrics}");
    }
    let ready = reqwest::get(format!("{}/readyz", h.server)).await.unwrap();
    assert_eq!(ready.status(), StatusCode::OK);

    // Whoever can write the KV bucket cannot redirect the report: its location is derived from the agency
    // and the id, not read from the state; a state rewritten to name another agency is refused (500, never
    // served) and serves that agency nothing.
    let tamper = |f: fn(&mut plumbline_scheduler::messages::CampaignState)| {
        let bus = h.scheduler.bus();
        async move {
            bus.campaigns
                .modify(&state.agency, &state.id, |c| {
                    f(c);
                    true
                })
                .await
                .unwrap()
                .unwrap()
        }
    };
    tamper(|c| c.report = Some("file:///etc/hostname".into())).await;
    assert_eq!(hh.report("tiny-1").await.unwrap()["summary"]["epochs"], 601);
    let kv = jetstream::new(async_nats::connect(h.nats.url()).await.unwrap());
    let kv = kv.get_key_value(plumbline_scheduler::bus::CAMPAIGNS_BUCKET).await.unwrap();
    let key = plumbline_scheduler::bus::campaign_key(&state.agency, &state.id);
    let mut forged = h.scheduler.bus().campaigns.get(&state.agency, &state.id).await.unwrap().unwrap().0;
    forged.agency = plumbline_scheduler::messages::Agency::parse("bremen").unwrap();
    kv.put(key, forged.to_json().into()).await.unwrap();
    let e = hh.report("tiny-1").await.unwrap_err();
    assert_eq!(status_of(&e), StatusCode::INTERNAL_SERVER_ERROR, "{e}");
    assert!(e.to_string().contains("inconsistent") && !e.to_string().contains("601"), "{e}");
    let e = hb.report("tiny-1").await.unwrap_err();
    assert_eq!(status_of(&e), StatusCode::CONFLICT, "bremen's own tiny-1 is cancelled: {e}");
    assert!(!e.to_string().contains("601"), "{e}");
}

/// Fair dispatch on a real nats-server: agency hamburg has 210 tiles waiting in 7 campaigns when bremen
/// submits a one-tile campaign. The work queue holds at most a window (4) of hamburg's tasks, so a worker
/// taking tasks in queue order — acking each and counting it as handled, as worker and adjuster do — reaches
/// bremen's tile after at most 4 of hamburg's, while almost all of hamburg's are still unpublished; the
/// dispatcher tops hamburg up as its tiles are handled.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_agencys_backlog_does_not_hold_up_anothers_tile() {
    use futures::StreamExt as _;
    use plumbline_scheduler::messages::Agency;
    use plumbline_scheduler::service::Quotas;
    let h = Harness::local_with_quotas(Quotas { dispatch_window: 4, ..Quotas::default() }).await;
    let (hh, hb) = (h.client(HAMBURG), h.client(BREMEN));
    let tiled = |id: &str, size: &str, overlap: &str| {
        manifest(id, "nav/dg.csv", "results/")
            .replace("tile_size_m = 100.0", &format!("tile_size_m = {size}"))
            .replace("overlap_m = 10.0", &format!("overlap_m = {overlap}"))
            .into_bytes()
    };
    let mut backlog = 0;
    for k in 0..7 {
        let id = format!("big-{k}");
        h.upload_inputs("hamburg", &id).await;
        let view = hh.submit(tiled(&id, "12.0", "1.0"), false).await.unwrap();
        assert!(view.campaign.dispatched <= 4, "{view:#?}");
        backlog += view.campaign.tiles_total;
    }
    assert!(backlog >= 200, "hamburg's campaigns have {backlog} tiles");
    h.upload_inputs("bremen", "one").await;
    let one = hb.submit(tiled("one", "1000.0", "10.0"), false).await.unwrap();
    assert_eq!((one.campaign.tiles_total, one.campaign.dispatched), (1, 1));
    let queued = all_tasks(&h).await;
    let hamburg = queued.iter().filter(|t| t.agency.as_str() == "hamburg").count();
    assert_eq!((hamburg, queued.len()), (4, 5), "the queue holds a window of hamburg's tasks and bremen's");

    let js = jetstream::new(async_nats::connect(h.nats.url()).await.unwrap());
    let stream = js.get_stream(TASKS_STREAM).await.unwrap();
    let consumer: jetstream::consumer::PullConsumer =
        stream.get_consumer(plumbline_scheduler::bus::WORKERS_CONSUMER).await.unwrap();
    let mut before = 0;
    let started = Instant::now();
    let found = loop {
        assert!(started.elapsed() < Duration::from_secs(60), "bremen's task never came");
        let mut batch = consumer.fetch().max_messages(1).expires(Duration::from_secs(2)).messages().await.unwrap();
        let Some(message) = batch.next().await else { continue };
        let message = message.unwrap();
        let task = TileTask::from_json(&message.payload).unwrap();
        message.double_ack().await.unwrap();
        if task.agency.as_str() == "bremen" {
            break task;
        }
        before += 1;
        let handled = h.scheduler.bus().campaigns.modify(&task.agency, &task.campaign, |c| {
            c.tiles_done += 1;
            true
        });
        handled.await.unwrap().unwrap();
    };
    assert_eq!(found.campaign.as_str(), "one");
    assert!(before <= 4, "bremen's tile came after {before} of hamburg's");
    let bremen = Agency::parse("bremen").unwrap();
    let finished = h.scheduler.bus().campaigns.modify(&bremen, &found.campaign, |c| {
        c.tiles_done = 1;
        c.status = CampaignStatus::Done;
        true
    });
    assert_eq!(finished.await.unwrap().unwrap().status, CampaignStatus::Done);
    let listed = hh.list().await.unwrap().campaigns;
    let unpublished: u64 = listed.iter().map(|c| c.tiles_total - c.dispatched).sum();
    assert!(unpublished >= backlog - 8, "{unpublished} of hamburg's {backlog} tiles still unpublished");
    // Hamburg's handled tiles are replaced by new ones within a round.
    let started = Instant::now();
    loop {
        let listed = hh.list().await.unwrap().campaigns;
        let out: u64 = listed.iter().map(|c| c.dispatched - c.tiles_done).sum();
        if out == 4 {
            break;
        }
        assert!(started.elapsed() < Duration::from_secs(10), "hamburg has {out} tasks out, not 4");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// The bytes an agency keeps under its prefix are bounded: over its quota, a submission is 429 naming the
/// bytes; another agency under its own quota is not held up.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bytes_quota_bounds_what_an_agency_keeps() {
    use plumbline_scheduler::service::Quotas;
    let one = (support::trajectory_csv().len() + support::panorama_index().len()) as u64;
    let h = Harness::local_with_quotas(Quotas { bytes_stored: one, ..Quotas::default() }).await;
    for (agency, id) in [("hamburg", "b-1"), ("hamburg", "b-2"), ("bremen", "b-3")] {
        h.upload_inputs(agency, id).await;
    }
    let text = |id: &str| manifest(id, "nav/dg.csv", "results/").into_bytes();
    let e = h.client(HAMBURG).submit(text("b-1"), false).await.unwrap_err();
    assert_eq!(status_of(&e), StatusCode::TOO_MANY_REQUESTS, "{e}");
    assert!(e.to_string().contains(&format!("keeps {} bytes in 4 objects", 2 * one)), "{e}");
    assert!(h.client(HAMBURG).list().await.unwrap().campaigns.is_empty());
    assert_eq!(h.client(BREMEN).submit(text("b-3"), false).await.unwrap().campaign.run, 1);
}

/// One agency's backlog and submission rate are bounded (429 naming the quota); another agency is not held
/// up by them, and a cancelled campaign frees its place.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn quotas_bound_an_agencys_backlog_and_submission_rate() {
    use plumbline_scheduler::service::Quotas;
    let quotas = Quotas {
        campaigns_in_flight: 1,
        tiles_queued: 10 * TINY_TILES,
        submissions_per_minute: 4,
        ..Quotas::default()
    };
    let h = Harness::local_with_quotas(quotas).await;
    for (agency, id) in [("hamburg", "q-1"), ("hamburg", "q-2"), ("bremen", "q-3")] {
        h.upload_inputs(agency, id).await;
    }
    let (hh, hb) = (h.client(HAMBURG), h.client(BREMEN));
    let text = |id: &str| manifest(id, "nav/dg.csv", "results/").into_bytes();
    hh.submit(text("q-1"), false).await.unwrap();
    let e = hh.submit(text("q-2"), false).await.unwrap_err();
    assert_eq!(status_of(&e), StatusCode::TOO_MANY_REQUESTS, "{e}");
    assert!(e.to_string().contains("1 campaigns in flight"), "{e}");
    hb.submit(text("q-3"), false).await.unwrap();
    hh.cancel("q-1").await.unwrap();
    hh.submit(text("q-2"), false).await.unwrap();
    // The same manifest again (a resubmission, answered 200) is the fourth submission of the minute.
    hh.submit(text("q-2"), false).await.unwrap();
    let e = hh.submit(text("q-2"), false).await.unwrap_err();
    assert_eq!(status_of(&e), StatusCode::TOO_MANY_REQUESTS, "{e}");
    assert!(e.to_string().contains("4 submissions in the last minute"), "{e}");
    assert_eq!(hb.list().await.unwrap().campaigns.len(), 1);

    // Tiles: a campaign that alone passes the agency's quota of queued tiles is refused before it is queued.
    let small = Quotas { tiles_queued: TINY_TILES - 1, ..Quotas::default() };
    let h = Harness::local_with_quotas(small).await;
    h.upload_inputs("hamburg", "q-1").await;
    let e = h.client(HAMBURG).submit(text("q-1"), false).await.unwrap_err();
    assert_eq!(status_of(&e), StatusCode::TOO_MANY_REQUESTS, "{e}");
    assert!(e.to_string().contains(&format!("0 tiles queued; {TINY_TILES} more")), "{e}");
    assert!(h.client(HAMBURG).list().await.unwrap().campaigns.is_empty());
}

/// Clients that never finish their headers are closed after the header-read timeout, and connections beyond
/// the limit are closed when accepted, so slow clients cannot hold the API.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn slow_and_surplus_connections_are_closed() {
    use tokio::io::{AsyncReadExt as _, AsyncWriteExt as _};
    let limits = plumbline_scheduler::service::HttpLimits {
        header_read: Duration::from_secs(1),
        request: Duration::from_secs(5),
        connection: Duration::from_secs(60),
        max_connections: 3,
    };
    let h = Harness::local_with(limits).await;
    let addr = h.server.trim_start_matches("http://").to_owned();
    let connect = || async { tokio::net::TcpStream::connect(&addr).await.unwrap() };
    /// Read until the server closes (EOF or reset); `None` if it is still open after `limit`.
    async fn closed_within(s: &mut tokio::net::TcpStream, limit: Duration) -> Option<Duration> {
        let started = Instant::now();
        let mut buf = [0u8; 256];
        loop {
            match tokio::time::timeout(limit.saturating_sub(started.elapsed()), s.read(&mut buf)).await {
                Err(_) => return None,
                Ok(Ok(0) | Err(_)) => return Some(started.elapsed()),
                Ok(Ok(_)) => {}
            }
        }
    }
    let mut slow = Vec::new();
    for _ in 0..3 {
        let mut s = connect().await;
        s.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n").await.unwrap();
        slow.push(s);
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    // Every slot is held: a fourth connection is closed at once, its complete request unanswered.
    let mut extra = connect().await;
    let _ = extra.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n").await;
    let mut answer = Vec::new();
    let _ =
        tokio::time::timeout(Duration::from_secs(3), extra.read_to_end(&mut answer)).await.expect("closed, not held");
    assert!(answer.is_empty(), "{}", String::from_utf8_lossy(&answer));
    // The slow ones are closed by the header-read timeout (1 s after their first byte), freeing the slots.
    for s in &mut slow {
        let after = closed_within(s, Duration::from_secs(4)).await.expect("a slow client was held open");
        assert!(after < Duration::from_secs(3), "closed after {after:?}");
    }
    let ok = reqwest::get(format!("{}/healthz", h.server)).await.unwrap();
    assert_eq!(ok.status(), StatusCode::OK);
}

/// Submit `text` as Hamburg and return the status and the problems' fields.
async fn rejected(h: &Harness, text: &str) -> (StatusCode, Vec<String>, String) {
    let e = h.client(HAMBURG).submit(text.as_bytes().to_vec(), false).await.unwrap_err();
    let plumbline_scheduler::client::ClientError::Api { status, body } = &e else { panic!("{e}") };
    (*status, body.problems.iter().map(|p| p.field.clone()).collect(), e.to_string())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rejected_manifests_name_their_fields() {
    let h = Harness::local().await;
    h.upload_inputs("hamburg", "bad").await;
    h.upload_inputs("bremen", "theirs").await;

    // `..` out of the manifest's directory: invalid (422), naming the field.
    let (status, fields, _) =
        rejected(&h, &manifest("bad", "../../../../bremen/campaigns/theirs/nav/dg.csv", "results/")).await;
    assert_eq!((status, fields), (StatusCode::UNPROCESSABLE_ENTITY, vec!["trajectory[0].url".to_owned()]));
    // Absolute URLs into another agency's prefix: forbidden (403), naming every field.
    let theirs = format!("{}nav/dg.csv", h.campaign_dir("bremen", "theirs"));
    let out = format!("{}out/", h.campaign_dir("bremen", "theirs"));
    let (status, fields, message) = rejected(&h, &manifest("bad", &theirs, &out)).await;
    assert_eq!(status, StatusCode::FORBIDDEN, "{message}");
    assert_eq!(fields, ["trajectory[0].url", "output"]);
    let sneaky = format!("{}../../../bremen/campaigns/theirs/nav/dg.csv", h.campaign_dir("hamburg", "bad"));
    assert_eq!(rejected(&h, &manifest("bad", &sneaky, "results/")).await.0, StatusCode::FORBIDDEN);

    // An invalid manifest lists every problem.
    let invalid = manifest("bad", "nav/dg.csv", "results/")
        .replace("crs = 25832", "crs = 4326")
        .replace("overlap_m = 10.0", "overlap_m = 300.0");
    let (status, fields, message) = rejected(&h, &invalid).await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(fields.iter().any(|f| f == "crs") && fields.iter().any(|f| f == "tiling.overlap_m"), "{message}");
    // Unparseable, and inputs that are not there.
    let (status, fields, _) = rejected(&h, "version = \"1\"\ncrs = \"x\"\n").await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    assert_eq!(fields.len(), 1);
    let (status, _, message) = rejected(&h, &manifest("bad", "nav/missing.csv", "results/")).await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(message.contains("missing.csv"), "{message}");
    // Nothing was queued.
    assert!(h.client(HAMBURG).list().await.unwrap().campaigns.is_empty());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn publishes_again_after_a_nats_restart() {
    let mut h = Harness::local().await;
    let hh = h.client(HAMBURG);
    h.upload_inputs("hamburg", "before").await;
    hh.submit(manifest("before", "nav/dg.csv", "results/").into_bytes(), false).await.unwrap();

    h.nats.kill();
    h.upload_inputs("hamburg", "after").await;
    let down = wait_for_readyz(&h, StatusCode::SERVICE_UNAVAILABLE).await;
    assert_eq!(down, serde_json::json!({ "nats": false, "store": true }));
    let refused = hh.submit(manifest("after", "nav/dg.csv", "results/").into_bytes(), false).await.unwrap_err();
    assert_eq!(status_of(&refused), StatusCode::SERVICE_UNAVAILABLE, "{refused}");
    h.nats.restart();
    let started = Instant::now();
    let view = loop {
        match hh.submit(manifest("after", "nav/dg.csv", "results/").into_bytes(), false).await {
            Ok(view) => break view,
            Err(e) if started.elapsed() < Duration::from_secs(20) => {
                assert_eq!(status_of(&e), StatusCode::SERVICE_UNAVAILABLE, "{e}");
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
            Err(e) => panic!("no reconnect within 20 s: {e}"),
        }
    };
    assert_eq!(view.campaign.status, CampaignStatus::Queued);
    let all = tasks(&h).await;
    assert_eq!(all.len() as u64, 2 * TINY_TILES, "tasks of both campaigns are in the persisted stream");
    assert_eq!(hh.status("before").await.unwrap().campaign.status, CampaignStatus::Queued);
    wait_for_readyz(&h, StatusCode::OK).await;
}

/// Poll `/readyz` until it answers `status` (10 s at most); its body.
async fn wait_for_readyz(h: &Harness, status: StatusCode) -> serde_json::Value {
    let started = Instant::now();
    loop {
        let answer = reqwest::get(format!("{}/readyz", h.server)).await.unwrap();
        if answer.status() == status {
            return answer.json().await.unwrap();
        }
        assert!(started.elapsed() < Duration::from_secs(10), "/readyz never answered {status}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}
