//! End-to-end test of the distributed path on real servers (nats-server, moto S3): a short simulated
//! campaign is uploaded under an agency's prefix, submitted to an in-process scheduler, processed by two
//! `plumbline serve worker` processes and adjusted by a `plumbline serve adjuster` process; its corrected
//! trajectory must equal the one `plumbline run` computes from the same files. A second submission of the
//! campaign (another id) loses a worker to `kill -9` in the middle of a tile: the tile is redelivered to the
//! other worker and the campaign completes with the same trajectory. The roles' ops listeners are scraped
//! after the first campaign: their counters must match what happened. The first campaign resubmitted with a
//! changed parameter is processed again and equals `plumbline run` of the changed manifest; a second agency's
//! campaign of the same id whose index reaches into the first agency's prefix and the worker's disk has those
//! rows refused, and its orthophoto and terrain VRTs naming a worker-local file and a URL are refused by name
//! without GDAL opening either. NATS runs on the deployment's own
//! `deploy/nats.conf`: every role connects as its user and works within that user's permissions; a second
//! test shows those permissions hold a role (or a stranger) to its subjects.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::time::{Duration, Instant};

use async_nats::jetstream;
use plumbline_fixtures::services::{STORE, SchedulerApi, s3_files, upload, upload_to};
use plumbline_geo::formats;
use plumbline_runtime::{NatsConfig, Secret};
use plumbline_scheduler::bus::{self, TASKS_STREAM};
use plumbline_scheduler::client::Client;
use plumbline_scheduler::messages::CampaignStatus;
use plumbline_scheduler::service::{self, NatsAuth};
use plumbline_testkit::{MotoServer, NatsServer};
use support::plumbline;
use support::services::Role;

/// The roles' NATS passwords, as the server's environment hands them to `deploy/nats.conf`.
const USERS: [(&str, &str, &str); 3] = [
    ("scheduler", "PLUMBLINE_NATS_SCHEDULER_PASSWORD", "scheduler-test-secret-1"),
    ("worker", "PLUMBLINE_NATS_WORKER_PASSWORD", "worker-test-secret-2"),
    ("adjuster", "PLUMBLINE_NATS_ADJUSTER_PASSWORD", "adjuster-test-secret-3"),
];

/// A nats-server on the deployment's config file, with the roles' users.
fn nats_with_users() -> NatsServer {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../deploy/nats.conf");
    let env: Vec<(&str, &str)> = USERS.iter().map(|(_, var, password)| (*var, *password)).collect();
    NatsServer::start_with_config(&file, &env)
}

/// The password of `user`.
fn password(user: &str) -> &'static str {
    USERS.iter().find(|(u, ..)| *u == user).map(|(.., p)| *p).unwrap()
}

/// The runtime config of a role connecting as `user`.
fn nats_config(url: &str, user: &str) -> NatsConfig {
    NatsConfig {
        url: url.to_owned(),
        token: None,
        creds_file: None,
        user: Some(user.to_owned()),
        password: Some(Secret::new(password(user))),
        tls_ca_file: None,
    }
}

/// Poll the campaign until it is terminal; panics with the roles' logs after `limit`.
async fn wait_terminal(
    client: &Client,
    id: &str,
    limit: Duration,
    roles: &[&Role],
) -> plumbline_scheduler::api::CampaignView {
    let start = Instant::now();
    loop {
        let view = client.status(id).await.unwrap();
        if view.campaign.status.is_terminal() {
            return view;
        }
        if start.elapsed() > limit {
            let logs: Vec<String> = roles.iter().map(|r| r.log()).collect();
            panic!(
                "campaign {id} still {:?} after {limit:?}: {view:#?}\nlogs:\n{}",
                view.campaign.status,
                logs.join("\n----\n")
            );
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
    }
}

/// `GET path` on the ops listener at `addr`: status line and body.
fn get(addr: &str, path: &str) -> (String, String) {
    use std::io::{Read as _, Write as _};
    let mut stream = std::net::TcpStream::connect(addr).unwrap();
    write!(stream, "GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut text = String::new();
    stream.read_to_string(&mut text).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap();
    (head.lines().next().unwrap().to_owned(), body.to_owned())
}

/// The value of the sample `name{labels}` (`name` alone when unlabelled) in an exposition text, 0 if absent.
fn sample(text: &str, series: &str) -> f64 {
    text.lines().find_map(|l| l.strip_prefix(series)?.strip_prefix(' ')?.parse().ok()).unwrap_or(0.0)
}

/// Scrape the roles after campaign (a): probes answer and the counters match what happened.
fn assert_metrics(workers: &[&Role], adjuster: &Role, tiles: u64) {
    let tiles = tiles as f64;
    let mut done = 0.0;
    for role in workers.iter().chain([&adjuster]) {
        let addr = role.ops_addr();
        assert_eq!(get(&addr, "/healthz").0, "HTTP/1.1 200 OK");
        let (status, body) = get(&addr, "/readyz");
        assert_eq!((status.as_str(), body.as_str()), ("HTTP/1.1 200 OK", "{\"nats\":true,\"store\":true}"));
    }
    for w in workers {
        // The worker counts a tile as it acks it, which may be a moment after the adjuster has seen its result.
        let scrape = || get(&w.ops_addr(), "/metrics").1;
        let start = Instant::now();
        let mut text = scrape();
        while sample(&text, "plumbline_worker_tasks_in_flight") != 0.0 && start.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(200));
            text = scrape();
        }
        let finished = sample(&text, "plumbline_worker_tasks_total{outcome=\"done\"}");
        done += finished + sample(&text, "plumbline_worker_tasks_total{outcome=\"resumed\"}");
        assert_eq!(sample(&text, "plumbline_worker_stage_seconds_count{stage=\"total\"}"), finished, "{text}");
        assert!(sample(&text, "plumbline_worker_stage_seconds_sum{stage=\"total\"}") > 0.0 || finished == 0.0);
        assert_eq!(sample(&text, "plumbline_worker_tasks_in_flight"), 0.0, "{text}");
        assert_eq!(sample(&text, "plumbline_worker_tasks_total{outcome=\"dead_lettered\"}"), 0.0, "{text}");
        assert!(text.contains("plumbline_worker_queue_pending 0\n"), "{text}");
    }
    assert_eq!(done, tiles, "tiles done over both workers");
    let text = get(&adjuster.ops_addr(), "/metrics").1;
    assert_eq!(sample(&text, "plumbline_adjuster_results_total{outcome=\"done\"}"), tiles, "{text}");
    assert_eq!(sample(&text, "plumbline_adjuster_campaigns_total{status=\"done\"}"), 1.0, "{text}");
    assert_eq!(sample(&text, "plumbline_adjuster_adjustment_seconds_count"), 1.0, "{text}");
    assert!(text.contains("plumbline_adjuster_queue_pending 0\n"), "{text}");
}

/// The corrected SBET records must match the reference to 1e-9 in every field.
fn assert_same_trajectory(found: &[formats::SbetRecord], expected: &[formats::SbetRecord], what: &str) {
    assert_eq!(found.len(), expected.len(), "{what}: record count");
    for (i, (f, e)) in found.iter().zip(expected).enumerate() {
        for (a, b) in f.to_array().iter().zip(e.to_array()) {
            assert!((a - b).abs() <= 1e-9, "{what}: record {i} differs: {a} vs {b}");
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn distributed_campaign_matches_plumbline_run_and_survives_a_killed_worker() {
    let t0 = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let campaign = dir.path().join("campaign");
    plumbline(&["simulate", "--preset", "tiny", "--length", "150", "--out", campaign.to_str().unwrap()])
        .run()
        .success();
    let manifest = std::fs::read_to_string(campaign.join("campaign.toml")).unwrap();
    let id = manifest.lines().find_map(|l| l.strip_prefix("id = \"")).unwrap().trim_end_matches('"').to_owned();

    let moto = MotoServer::start();
    moto.create_bucket("plumbline");
    let files = s3_files(moto.endpoint());
    let killed_id = format!("{id}-kill");
    upload(&files, &campaign, &id).await;
    upload(&files, &campaign, &killed_id).await;

    // The reference: the whole campaign in one process.
    plumbline(&["run", campaign.join("campaign.toml").to_str().unwrap(), "--quiet"]).run().success();
    let expected = std::fs::read(campaign.join("results/trajectory.sbet")).unwrap();
    let expected = formats::parse_sbet(&expected, "run").unwrap();
    eprintln!("simulate + plumbline run: {:.1} s", t0.elapsed().as_secs_f64());

    let nats = nats_with_users();
    let scheduler_user = nats_config(&nats.url(), "scheduler");
    let scheduler = SchedulerApi::start_as(&nats.url(), files.clone(), NatsAuth::Config(&scheduler_user)).await;
    let api = &scheduler.api;
    // A killed worker's task comes back after 4 s instead of 60 (the workers' user may not change consumers).
    let admin = service::connect(&nats.url(), NatsAuth::Config(&scheduler_user), "test", Duration::from_secs(10))
        .await
        .unwrap();
    let stream = jetstream::new(admin).get_stream(TASKS_STREAM).await.unwrap();
    let mut consumer = bus::workers_consumer();
    consumer.ack_wait = Duration::from_secs(4);
    consumer.backoff = vec![Duration::from_secs(4); consumer.backoff.len()];
    stream.update_consumer(consumer).await.unwrap();

    // (a) Two workers and an adjuster, each as its NATS user.
    let logs = dir.path();
    let ops = ["--ops-listen", "127.0.0.1:0"];
    let role = |name: &str, log: &str, extra: &[&str]| {
        Role::start_as(name, &nats.url(), &moto.endpoint(), logs.join(log), extra, name, password(name))
    };
    let adjuster = role("adjuster", "adjuster.log", &ops);
    let knobs = ["--heartbeat-s", "1", "--ops-listen", "127.0.0.1:0"];
    let mut w1 = role("worker", "w1.log", &knobs);
    let w2 = role("worker", "w2.log", &knobs);
    let started = Instant::now();
    let submitted = api.submit(manifest.clone().into_bytes(), false).await.unwrap();
    assert!(submitted.campaign.tiles_total >= 2, "the campaign must span several tiles: {submitted:#?}");
    let view = wait_terminal(api, &id, Duration::from_secs(600), &[&adjuster, &w1, &w2]).await;
    eprintln!("distributed campaign of {} tiles: {:.1} s", view.campaign.tiles_total, started.elapsed().as_secs_f64());
    assert_eq!(view.campaign.status, CampaignStatus::Done, "{view:#?}\n{}", adjuster.log());
    assert_eq!(view.campaign.tiles_done, view.campaign.tiles_total);
    assert_eq!(view.campaign.tiles_failed, 0);
    let report = api.report(&id).await.unwrap();
    assert_eq!(report["campaign"]["id"], id.as_str());
    let found = files.read(&format!("{}trajectory.sbet", view.campaign.output)).await.unwrap();
    assert_same_trajectory(&formats::parse_sbet(&found, "distributed").unwrap(), &expected, "distributed");
    assert_metrics(&[&w1, &w2], &adjuster, view.campaign.tiles_total);
    for role in [&adjuster, &w1, &w2] {
        assert!(!role.log().to_lowercase().contains("permissions violation"), "{}", role.log());
    }

    // (b) The same campaign under another id; worker 1 is killed as soon as it works on a tile.
    let killed_manifest = manifest.replacen(&format!("id = \"{id}\""), &format!("id = \"{killed_id}\""), 1);
    let before = w1.log().matches("tile started").count();
    api.submit(killed_manifest.into_bytes(), false).await.unwrap();
    let start = Instant::now();
    while w1.log().matches("tile started").count() == before {
        assert!(start.elapsed() < Duration::from_secs(120), "worker 1 never started a tile:\n{}", w1.log());
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    w1.kill();
    let view = wait_terminal(api, &killed_id, Duration::from_secs(600), &[&adjuster, &w1, &w2]).await;
    assert_eq!(view.campaign.status, CampaignStatus::Done, "{view:#?}\n{}", adjuster.log());
    assert_eq!(view.campaign.tiles_done, view.campaign.tiles_total, "{view:#?}");
    let found = files.read(&format!("{}trajectory.sbet", view.campaign.output)).await.unwrap();
    assert_same_trajectory(&formats::parse_sbet(&found, "after kill").unwrap(), &expected, "after kill");
    eprintln!("campaign with a killed worker: {:.1} s", start.elapsed().as_secs_f64());

    // (c) Campaign (a) is done; the same id with a changed tile parameter is its run 2: every tile is processed
    // again (none read back: its fingerprint changed) and the trajectory is `plumbline run`'s of the changed
    // manifest, not run 1's.
    let changed = format!("{manifest}\n[parameters.poles]\nmax_range_m = 5.0\n");
    let local = changed.replacen("output = \"results/\"", "output = \"results-changed/\"", 1);
    std::fs::write(campaign.join("changed.toml"), local).unwrap();
    plumbline(&["run", campaign.join("changed.toml").to_str().unwrap(), "--quiet"]).run().success();
    let reference = std::fs::read(campaign.join("results-changed/trajectory.sbet")).unwrap();
    let reference = formats::parse_sbet(&reference, "changed run").unwrap();
    let differs = reference.iter().zip(&expected).any(|(a, b)| a.to_array() != b.to_array());
    assert!(differs, "the changed parameter must change the trajectory for this check to mean anything");
    let scrape = || get(&w2.ops_addr(), "/metrics").1;
    let done_before = sample(&scrape(), "plumbline_worker_tasks_total{outcome=\"done\"}");
    let resumed_before = sample(&scrape(), "plumbline_worker_tasks_total{outcome=\"resumed\"}");
    let start = Instant::now();
    let run2 = api.submit(changed.into_bytes(), false).await.unwrap();
    assert_eq!(run2.campaign.run, 2, "{run2:#?}");
    let view = wait_terminal(api, &id, Duration::from_secs(600), &[&adjuster, &w2]).await;
    assert_eq!(view.campaign.status, CampaignStatus::Done, "{view:#?}\n{}", adjuster.log());
    let found = files.read(&format!("{}trajectory.sbet", view.campaign.output)).await.unwrap();
    assert_same_trajectory(&formats::parse_sbet(&found, "run 2").unwrap(), &reference, "changed parameters");
    let text = scrape();
    let done = sample(&text, "plumbline_worker_tasks_total{outcome=\"done\"}") - done_before;
    let resumed = sample(&text, "plumbline_worker_tasks_total{outcome=\"resumed\"}") - resumed_before;
    assert_eq!((done, resumed), (view.campaign.tiles_total as f64, 0.0), "tiles processed again: {text}");
    eprintln!("resubmission with a changed parameter: {:.1} s", start.elapsed().as_secs_f64());

    // (d) Agency bremen, same campaign id: its own campaign. Its panorama index names one of hamburg's
    // panoramas and a file on the worker's disk; both rows are refused as outside bremen's prefix and named in
    // its report, the rest is processed, and hamburg's campaign is untouched.
    upload_to(&files, &campaign, "bremen", &id).await;
    let index_url = format!("{STORE}/agencies/bremen/campaigns/{id}/panoramas/index.csv");
    let index = String::from_utf8(files.read(&index_url).await.unwrap().to_vec()).unwrap();
    let column = index.lines().next().unwrap().split(',').position(|c| c == "file").unwrap();
    let theirs = format!("{STORE}/agencies/hamburg/campaigns/{id}/panoramas/");
    let rows: Vec<String> = index
        .lines()
        .enumerate()
        .map(|(i, line)| {
            let mut cells: Vec<String> = line.split(',').map(str::to_owned).collect();
            match i {
                1 => cells[column] = format!("{theirs}{}", cells[column]),
                2 => cells[column] = "file:///etc/hostname".to_owned(),
                _ => {}
            }
            cells.join(",")
        })
        .collect();
    files.write(&index_url, (rows.join("\n") + "\n").into_bytes()).await.unwrap();
    let bremen = &scheduler.bremen;
    let theirs_view = bremen.submit(manifest.clone().into_bytes(), false).await.unwrap();
    assert_eq!((theirs_view.campaign.agency.as_str(), theirs_view.campaign.run), ("bremen", 1));
    let view = wait_terminal(bremen, &id, Duration::from_secs(600), &[&adjuster, &w2]).await;
    assert_eq!(view.campaign.status, CampaignStatus::Done, "{view:#?}\n{}", adjuster.log());
    let report = bremen.report(&id).await.unwrap();
    let skipped = report["skipped"].as_array().unwrap();
    let refused = |needle: &str| {
        skipped
            .iter()
            .any(|s| s["detail"].as_str().is_some_and(|d| d.contains(needle)) && s["reason"].as_str() == Some("url"))
    };
    assert!(refused(&theirs) && refused("file:///etc/hostname"), "{skipped:#?}");
    assert!(report["summary"]["images_matched"].as_u64().unwrap() > 0, "the rest was processed: {report}");
    assert_eq!(api.status(&id).await.unwrap().campaign.run, 2, "hamburg's campaign is its own");

    // (e) Agency bremen's orthophoto and terrain model as VRTs reaching outside its prefix: the terrain's
    // source is a URL on a listener of this test (after an XML comment), the orthophoto's a file on the
    // worker's disk (attributes in single quotes). The terrain is read when the manifest gives no camera
    // height, the orthophoto when it names no aerial frames: one campaign each. Neither source is handed to
    // GDAL — nothing connects to the listener — and both refusals are named.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.set_nonblocking(true).unwrap();
    let bait = format!("/vsicurl/http://{}/terrain.tif", listener.local_addr().unwrap());
    let ortho = hostile_vrt(&campaign.join("aerial/orthophoto.tif"), "/etc/hostname", '\'', "");
    let terrain = hostile_vrt(&campaign.join("aerial/terrain.tif"), &bait, '"', "<!-- a comment first -->");
    let frames = manifest.find("[aerial.frames]").unwrap()..manifest.find("[aerial.orthophoto]").unwrap();
    let cases = [
        ("terrain-vrt", manifest.replace("camera_height_m = 3.75\n", "")),
        ("ortho-vrt", manifest.replace(&manifest[frames], "")),
    ];
    let mut views = Vec::new();
    for (case, text) in cases {
        upload_to(&files, &campaign, "bremen", case).await;
        let dir = format!("{STORE}/agencies/bremen/campaigns/{case}/aerial/");
        files.write(&format!("{dir}orthophoto.vrt"), ortho.clone().into_bytes()).await.unwrap();
        files.write(&format!("{dir}terrain.vrt"), terrain.clone().into_bytes()).await.unwrap();
        let text = text
            .replacen(&format!("id = \"{id}\""), &format!("id = \"{case}\""), 1)
            .replace("aerial/orthophoto.tif", "aerial/orthophoto.vrt")
            .replace("aerial/terrain.tif", "aerial/terrain.vrt");
        bremen.submit(text.into_bytes(), false).await.unwrap();
        views.push(wait_terminal(bremen, case, Duration::from_secs(600), &[&adjuster, &w2]).await);
    }
    assert!(listener.accept().is_err(), "the terrain VRT's URL was fetched");
    // Without a camera height every tile needs the terrain: each fails for good, naming the refused source.
    let refused_terrain = format!("`{bait}` is not relative to the VRT");
    let failed = &views[0].campaign;
    assert_eq!(failed.status, CampaignStatus::Failed, "{failed:#?}");
    assert_eq!(failed.dead_lettered.len() as u64, failed.tiles_total, "{failed:#?}");
    assert!(failed.dead_lettered.iter().all(|d| d.error.contains(&refused_terrain)), "{failed:#?}");
    // Without frames the orthophoto is the reference: refused and named; the campaign ends on its poles.
    assert_eq!(views[1].campaign.status, CampaignStatus::Done, "{:#?}", views[1]);
    let report = bremen.report("ortho-vrt").await.unwrap();
    let named = report["skipped"].as_array().unwrap().iter().any(|s| {
        s["item"].as_str().is_some_and(|i| i.ends_with("/ortho-vrt/aerial/orthophoto.vrt"))
            && s["detail"].as_str().is_some_and(|d| d.contains("`/etc/hostname` is not relative to the VRT"))
    });
    assert!(named, "{:#?}", report["skipped"]);
}

/// A VRT of `raster`'s size, geotransform and band count whose sources are `source` (absolute), with
/// attributes quoted by `quote` and `lead` before the root element.
fn hostile_vrt(raster: &std::path::Path, source: &str, quote: char, lead: &str) -> String {
    let r = plumbline_runtime::gdal_read::RasterSource::open_path(raster).unwrap();
    let ((w, h), g) = (r.size(), r.geotransform());
    let q = quote;
    let mut bands = String::new();
    for band in 1..=r.band_count() {
        bands.push_str(&format!(
            "<VRTRasterBand dataType={q}{ty}{q} band={q}{band}{q}><SimpleSource>\
             <SourceFilename relativeToVRT={q}0{q}>{source}</SourceFilename><SourceBand>{band}</SourceBand>\
             <SrcRect xOff={q}0{q} yOff={q}0{q} xSize={q}{w}{q} ySize={q}{h}{q}/>\
             <DstRect xOff={q}0{q} yOff={q}0{q} xSize={q}{w}{q} ySize={q}{h}{q}/></SimpleSource></VRTRasterBand>",
            ty = r.pixel_type().unwrap(),
        ));
    }
    format!(
        "{lead}<VRTDataset rasterXSize={q}{w}{q} rasterYSize={q}{h}{q}><SRS>EPSG:25832</SRS>\
         <GeoTransform>{}, {}, {}, {}, {}, {}</GeoTransform>{bands}</VRTDataset>",
        g[0], g[1], g[2], g[3], g[4], g[5]
    )
}

/// The users of `deploy/nats.conf` hold each role to its subjects: a stranger and a wrong password are
/// refused; a role without credentials does not start; the worker's user cannot publish tasks or create,
/// change or delete streams; the adjuster's cannot publish results. The roles' own operations (the
/// scheduler's [`bus::ensure`], the others' [`bus::bind`]) pass, and a worker started as its user gets ready.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn nats_users_are_held_to_their_permissions() {
    let nats = nats_with_users();
    let url = nats.url();
    assert!(async_nats::connect(&url).await.is_err(), "a client without a user is refused");
    let mut wrong = nats_config(&url, "worker");
    wrong.password = Some(Secret::new("not-the-password"));
    let refused = service::connect(&url, NatsAuth::Config(&wrong), "worker", Duration::from_secs(5)).await;
    assert!(refused.unwrap_err().to_string().contains("refused plumbline-worker's credentials"));

    // Without credentials and without --insecure-no-nats-auth, a role refuses to start.
    let run = plumbline(&["serve", "worker", "--nats", &url, "--store", STORE, "--connect-timeout-s", "1"]).run();
    run.failure_with(2);
    assert!(run.stderr.contains("no NATS credentials configured"), "{}", run.stderr);

    let as_user = |user: &'static str| {
        let config = nats_config(&url, user);
        async move {
            let client = service::connect(&config.url, NatsAuth::Config(&config), user, Duration::from_secs(10));
            let mut js = jetstream::new(client.await.unwrap());
            js.set_timeout(Duration::from_secs(2));
            js
        }
    };
    let scheduler = bus::ensure(as_user("scheduler").await).await.expect("the scheduler creates the resources");
    let worker = bus::bind(as_user("worker").await, Duration::from_secs(5)).await.expect("the worker binds them");
    let adjuster = bus::bind(as_user("adjuster").await, Duration::from_secs(5)).await.expect("the adjuster too");

    let forged = worker.js.publish("plumbline.tasks.hamburg.forged", "{}".into()).await.unwrap().await;
    assert!(forged.is_err(), "the worker's user published a task");
    assert!(worker.js.delete_stream(TASKS_STREAM).await.is_err(), "the worker's user deleted the task stream");
    let evil = jetstream::stream::Config { name: "EVIL".into(), subjects: vec!["evil.>".into()], ..Default::default() };
    assert!(worker.js.create_stream(evil.clone()).await.is_err(), "the worker's user created a stream");
    let tasks = worker.js.get_stream(TASKS_STREAM).await.unwrap();
    assert!(tasks.purge().await.is_err(), "the worker's user purged the task stream");
    let result = adjuster.js.publish("plumbline.results.hamburg.forged", "{}".into()).await.unwrap().await;
    assert!(result.is_err(), "the adjuster's user published a result");
    assert!(adjuster.js.create_stream(evil).await.is_err(), "the adjuster's user created a stream");

    // Nothing of that reached the server: the task stream is there and empty, no stream EVIL.
    assert_eq!(scheduler.queued_tasks().await.unwrap(), 0);
    assert!(scheduler.js.get_stream("EVIL").await.is_err());

    // A worker started as its user binds the resources and gets ready.
    let dir = tempfile::tempdir().unwrap();
    let moto = MotoServer::start();
    let worker =
        Role::start_as("worker", &url, &moto.endpoint(), dir.path().join("w.log"), &[], "worker", password("worker"));
    worker.wait_for("worker ready", 1, Duration::from_secs(60));
    assert!(!worker.log().contains("Permissions Violation"), "{}", worker.log());
}
