//! Fault tests of the distributed path on real servers (nats-server, moto S3), one short simulated campaign
//! shared by three scenarios that run in parallel, each with its own servers, one `plumbline serve worker`
//! and one `plumbline serve adjuster` process and an in-process scheduler:
//!
//! - **poison tile**: one tile's input is bad for good (the terrain model that stands in for the missing
//!   camera height has no data under the tile's first panorama) → the worker terminates the task at its
//!   first delivery and dead-letters it; the job API and `plumbline status` list the tile with the reason;
//!   the campaign is adjusted from the other tiles and ends `done`, its report naming the missing tile;
//! - **S3 outage**: the store goes away while a tile reads its inputs and again while the campaign is
//!   adjusted → the worker naks and retries, the adjuster keeps the campaign `adjusting` and retries → the
//!   campaign ends with the same trajectory as `plumbline run`. moto keeps its objects in memory, so
//!   stopping it would lose them: the roles reach it through a [`FlakyProxy`] that goes down and up instead;
//! - **NATS restart**: nats-server is killed (SIGKILL) while a tile is in progress and started again on the
//!   same port and store → workers and adjuster reconnect, the campaign ends with the same trajectory.
//!
//! Every fault is triggered by what the services log (not by a fixed sleep), and each test asserts that the
//! fault was hit and that the services logged their retry or reconnection.
//!
//! The campaign (`simulate --preset tiny --length 120`, 2–3 tiles) and its `plumbline run` reference are
//! made once per test build: nextest runs every test in its own process, so the processes agree through the
//! file system (lock file + rename into place, as in `worker.rs`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use plumbline_fixtures::services::{SchedulerApi, TOKEN, s3_files, upload};
use plumbline_geo::formats;
use plumbline_runtime::Files;
use plumbline_scheduler::api::CampaignView;
use plumbline_scheduler::bus::{DEAD_STREAM, dead_subject};
use plumbline_scheduler::messages::{CampaignStatus, FailureKind, TileFailed};
use plumbline_scheduler::service;
use plumbline_testkit::{FlakyProxy, MotoServer, NatsServer};
use support::plumbline;
use support::services::Role;

const LIMIT: Duration = Duration::from_secs(600);

/// The simulated campaign and the trajectory `plumbline run` corrects it to.
struct Shared {
    dir: PathBuf,
    id: String,
    expected: Vec<formats::SbetRecord>,
}

/// Simulated once per test build (see the module doc).
fn shared() -> &'static Shared {
    static SHARED: OnceLock<Shared> = OnceLock::new();
    SHARED.get_or_init(|| {
        let dir = simulated();
        let manifest = std::fs::read_to_string(dir.join("campaign.toml")).unwrap();
        let id = manifest.lines().find_map(|l| l.strip_prefix("id = \"")).unwrap().trim_end_matches('"').to_owned();
        let expected =
            formats::parse_sbet(&std::fs::read(dir.join("results/trajectory.sbet")).unwrap(), "run").unwrap();
        Shared { dir, id, expected }
    })
}

fn simulated() -> PathBuf {
    support::once_per_build("faults-e2e", "results/trajectory.sbet", |out| {
        let t0 = Instant::now();
        let path = out.to_str().unwrap();
        plumbline(&["simulate", "--preset", "tiny", "--length", "120", "--out", path]).run().success();
        plumbline(&["run", out.join("campaign.toml").to_str().unwrap(), "--quiet"]).run().success();
        eprintln!("simulate + plumbline run: {:.1} s", t0.elapsed().as_secs_f64());
    })
}

/// One scenario's servers, scheduler, API client and roles.
struct Rig {
    dir: tempfile::TempDir,
    nats: NatsServer,
    moto: MotoServer,
    files: Files,
    scheduler: SchedulerApi,
}

impl Rig {
    /// Servers, the campaign's inputs uploaded (after `edit` changed a private copy), a scheduler.
    async fn start(edit: impl FnOnce(&Path)) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let copy = dir.path().join("campaign");
        support::copy_dir(&shared().dir, &copy);
        edit(&copy);
        let moto = MotoServer::start();
        moto.create_bucket("plumbline");
        let files = s3_files(moto.endpoint());
        upload(&files, &copy, &shared().id).await;
        let nats = NatsServer::start();
        let scheduler = SchedulerApi::start(&nats.url(), files.clone()).await;
        Self { dir, nats, moto, files, scheduler }
    }

    /// An adjuster and a worker (1 s heartbeats, 4 s ack wait, 2 s retry delay) reaching S3 at `s3`.
    fn roles(&self, s3: &str) -> (Role, Role) {
        let adjuster = Role::start("adjuster", &self.nats.url(), s3, self.dir.path().join("adjuster.log"), &[]);
        let knobs = ["--heartbeat-s", "1", "--ack-wait-s", "4", "--retry-delay-s", "2"];
        let worker = Role::start("worker", &self.nats.url(), s3, self.dir.path().join("worker.log"), &knobs);
        (adjuster, worker)
    }

    /// Submit the (stored) manifest; the number of tiles.
    async fn submit(&self) -> u64 {
        let manifest = std::fs::read(self.dir.path().join("campaign/campaign.toml")).unwrap();
        let submitted = self.scheduler.api.submit(manifest, false).await.unwrap();
        assert!(submitted.campaign.tiles_total >= 2, "the campaign must span several tiles: {submitted:#?}");
        submitted.campaign.tiles_total
    }

    /// Poll the campaign until it is terminal; panics with the roles' logs after [`LIMIT`].
    async fn wait_terminal(&self, roles: &[&Role]) -> CampaignView {
        let (id, start) = (&shared().id, Instant::now());
        loop {
            // The API may be briefly unable to answer (NATS restarting): poll again.
            if let Ok(view) = self.scheduler.api.status(id).await
                && view.campaign.status.is_terminal()
            {
                return view;
            }
            let logs: Vec<String> = roles.iter().map(|r| r.log()).collect();
            assert!(
                start.elapsed() < LIMIT,
                "campaign {id} not finished after {LIMIT:?}; logs:\n{}",
                logs.join("\n----\n")
            );
            tokio::time::sleep(Duration::from_millis(500)).await;
        }
    }

    /// The campaign's corrected trajectory must equal `plumbline run`'s.
    async fn assert_same_trajectory(&self, view: &CampaignView, what: &str) {
        let found = self.files.read(&format!("{}trajectory.sbet", view.campaign.output)).await.unwrap();
        let found = formats::parse_sbet(&found, what).unwrap();
        let expected = &shared().expected;
        assert_eq!(found.len(), expected.len(), "{what}: record count");
        for (i, (f, e)) in found.iter().zip(expected).enumerate() {
            for (a, b) in f.to_array().iter().zip(e.to_array()) {
                assert!((a - b).abs() <= 1e-9, "{what}: record {i} differs: {a} vs {b}");
            }
        }
    }
}

/// Where in `log` a field `name` with `value` was logged first (pretty `name: value`, `name=value` or json).
fn field(log: &str, name: &str, value: &str) -> Option<usize> {
    [format!("{name}: {value}"), format!("{name}={value}"), format!("\"{name}\":\"{value}\"")]
        .iter()
        .filter_map(|needle| {
            log.match_indices(needle.as_str())
                .find(|(i, _)| !log[i + needle.len()..].starts_with(|c: char| c.is_alphanumeric()))
                .map(|(i, _)| i)
        })
        .min()
}

/// The tile to poison and where its first panorama (by time, owned or context) was taken: the tile whose
/// first panorama is the latest of all tiles' first panoramas and lies > 40 m from every other's.
async fn poison_target(dir: &Path) -> (plumbline_geo::tiling::TileId, f64, f64) {
    let campaign = plumbline_scheduler::load_campaign(&Files::default(), dir.join("campaign.toml").to_str().unwrap())
        .await
        .unwrap();
    let firsts: Vec<_> = campaign
        .plan
        .tiles
        .tiles()
        .iter()
        .map(|t| {
            let images = t.owned.iter().chain(&t.context).map(|id| &campaign.plan.panoramas[id.0 as usize]);
            let first = images.min_by(|a, b| a.time.total_cmp(&b.time)).unwrap();
            (t.id, first.time, first.east, first.north)
        })
        .collect();
    let target = *firsts.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    for other in firsts.iter().filter(|f| f.0 != target.0) {
        let d = (other.2 - target.2).hypot(other.3 - target.3);
        assert!(d > 40.0, "the tiles' first panoramas lie {d:.1} m apart: {firsts:?}");
    }
    (target.0, target.2, target.3)
}

/// Drop `camera_height_m` from the manifest (the terrain model stands in) and blank the terrain model
/// (no data) within 15 m of (`east`, `north`).
fn poison(dir: &Path, east: f64, north: f64) {
    let manifest = dir.join("campaign.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    assert!(text.contains("camera_height_m") && text.contains("terrain = \"aerial/terrain.tif\""), "{text}");
    let edited: String = text.lines().filter(|l| !l.starts_with("camera_height_m")).map(|l| format!("{l}\n")).collect();
    std::fs::write(&manifest, edited).unwrap();
    let options = gdal::DatasetOptions { open_flags: gdal::GdalOpenFlags::GDAL_OF_UPDATE, ..Default::default() };
    let ds = gdal::Dataset::open_ex(dir.join("aerial/terrain.tif"), options).unwrap();
    let gt = ds.geo_transform().unwrap();
    let mut band = ds.rasterband(1).unwrap();
    let nodata = band.no_data_value().unwrap_or(-9999.0);
    band.set_no_data_value(Some(nodata)).unwrap();
    let (w, h) = band.size();
    let mut buffer = band.read_as::<f64>((0, 0), (w, h), (w, h), None).unwrap();
    let mut blanked = 0;
    for r in 0..h {
        for c in 0..w {
            let e = gt[0] + (c as f64 + 0.5) * gt[1];
            let n = gt[3] + (r as f64 + 0.5) * gt[5];
            if (e - east).hypot(n - north) < 15.0 {
                buffer.data_mut()[r * w + c] = nodata;
                blanked += 1;
            }
        }
    }
    assert!(blanked > 0, "the terrain model does not cover ({east}, {north})");
    band.write((0, 0), (w, h), &mut buffer).unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_poison_tile_is_dead_lettered_reported_and_the_rest_completes() {
    let (tile, east, north) = poison_target(&shared().dir).await;
    let rig = Rig::start(|dir| poison(dir, east, north)).await;
    let (adjuster, worker) = rig.roles(&rig.moto.endpoint());
    let total = rig.submit().await;
    let view = rig.wait_terminal(&[&adjuster, &worker]).await;
    let c = &view.campaign;
    // Done with the tiles it has; the poisoned tile listed with its reason.
    assert_eq!(c.status, CampaignStatus::Done, "{view:#?}\n{}", adjuster.log());
    assert_eq!((c.tiles_done, c.tiles_failed, c.tiles_total), (total - 1, 1, total), "{view:#?}");
    assert_eq!(c.dead_lettered.len(), 1, "{view:#?}");
    assert_eq!(c.dead_lettered[0].tile, tile);
    assert!(c.dead_lettered[0].error.contains("terrain model"), "{:?}", c.dead_lettered[0]);
    // Terminated at its first delivery (permanent), and in the dead-letter stream.
    assert_eq!(worker.log().matches("tile given up").count(), 1, "{}", worker.log());
    let client =
        service::connect(&rig.nats.url(), service::NatsAuth::Insecure, "test", Duration::from_secs(10)).await.unwrap();
    let js = async_nats::jetstream::new(client);
    let id: plumbline_campaign::CampaignId = shared().id.parse().unwrap();
    let mut dead = js.get_stream(DEAD_STREAM).await.unwrap();
    assert_eq!(dead.info().await.unwrap().state.messages, 1);
    let hamburg = plumbline_scheduler::messages::Agency::parse("hamburg").unwrap();
    let letter = dead.get_last_raw_message_by_subject(&dead_subject(&hamburg, &id)).await.unwrap();
    let letter = TileFailed::from_json(&letter.payload).unwrap();
    assert_eq!((letter.tile, letter.kind, letter.attempts), (tile, FailureKind::Permanent, 1));
    // The report names the missing tile; `plumbline status` shows it with its reason.
    let report = rig.scheduler.api.report(&shared().id).await.unwrap().to_string();
    assert!(report.contains(&format!("tile {tile}")) && report.contains("dead-lettered"), "{report}");
    let token = support::write(&rig.dir, "token", TOKEN);
    let status = plumbline(&["status", &shared().id, "--server", &rig.scheduler.server, "--token-file", &token]).run();
    status.success();
    assert!(status.stdout.contains(": done") && status.stdout.contains(&format!("dead-lettered tile {tile}: ")));
    assert!(status.stdout.contains("terrain model"), "{}", status.stdout);
    let args = ["status", &shared().id, "--watch", "--server", &rig.scheduler.server, "--token-file", &token];
    let watched = plumbline(&args).run();
    watched.failure_with(3);
    assert!(watched.stdout.contains(&format!("dead-lettered tile {tile}: ")), "{}", watched.stdout);
}

/// Whoever can publish on NATS (it has no authentication yet) rewrites the campaign's state and publishes a
/// task naming a manifest the job API never stored: the worker does not follow it. Tasks still naming the
/// real manifest no longer match the state and are dropped; the forged task's tile fails as invalid input,
/// naming why, and nothing is read from the forged location.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_manifest_forged_on_the_bus_is_not_followed() {
    use plumbline_scheduler::messages::TileTask;
    let rig = Rig::start(|_| {}).await;
    rig.submit().await;
    let client =
        service::connect(&rig.nats.url(), service::NatsAuth::Insecure, "test", Duration::from_secs(10)).await.unwrap();
    let bus = plumbline_scheduler::bus::ensure(async_nats::jetstream::new(client)).await.unwrap();
    let id: plumbline_campaign::CampaignId = shared().id.parse().unwrap();
    let hamburg = plumbline_scheduler::messages::Agency::parse("hamburg").unwrap();
    let (state, _) = bus.campaigns.get(&hamburg, &id).await.unwrap().unwrap();
    // Another agency's folder: the manifest there is not this agency's stored one.
    let forged = state.manifest.replace("/agencies/hamburg/", "/agencies/bremen/");
    assert_ne!(forged, state.manifest);
    let text = std::fs::read(rig.dir.path().join("campaign/campaign.toml")).unwrap();
    rig.files.write(&forged, text).await.unwrap();
    let set = forged.clone();
    bus.campaigns
        .modify(&hamburg, &id, move |c| {
            c.manifest = set.clone();
            true
        })
        .await
        .unwrap()
        .unwrap();
    let tile = plumbline_geo::tiling::TileId { col: 9_999, row: 9_999 };
    let task = TileTask {
        agency: hamburg.clone(),
        campaign: id.clone(),
        run: state.run,
        manifest: forged,
        tile,
        output: state.output,
    };
    assert!(bus.publish_task(&task).await.unwrap());
    let (_adjuster, worker) = rig.roles(&rig.moto.endpoint());
    worker.wait_for("tile given up", 1, LIMIT);
    let log = worker.log();
    assert!(log.contains("is not where the job API stores agency hamburg's manifest"), "{log}");
    assert!(log.contains("another manifest than its campaign's state"), "{log}");
    assert!(!log.contains("tile started"), "a tile was processed from a forged manifest: {log}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_s3_outage_while_tiles_and_the_adjustment_run_is_retried_to_the_same_trajectory() {
    let rig = Rig::start(|_| {}).await;
    let proxy = FlakyProxy::start(&rig.moto.endpoint().replace("http://", ""));
    let (adjuster, worker) = rig.roles(&proxy.endpoint());
    rig.submit().await;
    // `status --watch` through a proxy of the job API that goes down with the store: it polls through.
    let api = FlakyProxy::start(rig.scheduler.server.trim_start_matches("http://"));
    let token = support::write(&rig.dir, "token", TOKEN);
    let (id, server) = (shared().id.clone(), api.endpoint());
    let args = ["status", &id, "--watch", "--interval-s", "0.5", "--server", &server, "--token-file", &token];
    let args: Vec<String> = args.iter().map(|a| (*a).to_owned()).collect();
    let watcher = std::thread::spawn(move || plumbline(&args.iter().map(String::as_str).collect::<Vec<_>>()).run());
    // Outage 1: while the first tile reads its inputs, until the worker has given the attempt up for later.
    worker.wait_for("tile inputs being read", 1, LIMIT);
    proxy.down();
    api.down();
    let log = worker.log();
    assert!(log.matches("tile started").count() > log.matches("tile written").count(), "no tile in progress");
    worker.wait_for("retrying later", 1, LIMIT);
    let refused = proxy.refused();
    proxy.up();
    api.up();
    // Outage 2: as soon as the adjustment starts, until the adjuster has deferred it.
    adjuster.wait_for("adjustment started", 1, LIMIT);
    proxy.down();
    adjuster.wait_for("adjustment interrupted by the store", 1, LIMIT);
    proxy.up();
    let view = rig.wait_terminal(&[&adjuster, &worker]).await;
    assert_eq!(view.campaign.status, CampaignStatus::Done, "{view:#?}\n{}", adjuster.log());
    assert_eq!(view.campaign.tiles_done, view.campaign.tiles_total, "{view:#?}");
    assert!(refused > 0 && proxy.refused() > refused, "the outages refused no connection ({refused})");
    // The inputs the outage kept from the worker failed the attempt instead of leaving holes in the tile.
    assert!(worker.log().contains("input(s) could not be read from the store"), "{}", worker.log());
    assert!(adjuster.log().matches("adjustment started").count() >= 2, "{}", adjuster.log());
    rig.assert_same_trajectory(&view, "after S3 outages").await;
    let watched = watcher.join().unwrap();
    watched.success();
    assert!(api.refused() > 0, "the job API's outage refused no poll");
    assert!(watched.stderr.contains("still watching") && watched.stdout.contains(": done"), "{}", watched.stderr);
    let retry = worker.log().lines().find(|l| l.contains("retrying later")).unwrap_or_default().to_owned();
    eprintln!("S3 outages: {} connections refused, {} cut; worker: {retry}", proxy.refused(), proxy.cut());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_nats_restart_mid_campaign_is_survived_to_the_same_trajectory() {
    let mut rig = Rig::start(|_| {}).await;
    let (adjuster, worker) = rig.roles(&rig.moto.endpoint());
    rig.submit().await;
    worker.wait_for("tile started", 1, LIMIT);
    rig.nats.kill();
    let log = worker.log();
    assert!(log.matches("tile started").count() > log.matches("tile written").count(), "no tile in progress");
    worker.wait_for("NATS connection event", 1, Duration::from_secs(30));
    std::thread::sleep(Duration::from_secs(2));
    rig.nats.restart();
    let view = rig.wait_terminal(&[&adjuster, &worker]).await;
    assert_eq!(view.campaign.status, CampaignStatus::Done, "{view:#?}\n{}", adjuster.log());
    assert_eq!(view.campaign.tiles_done, view.campaign.tiles_total, "{view:#?}");
    for (role, log) in [("worker", worker.log()), ("adjuster", adjuster.log())] {
        let back = field(&log, "event", "disconnected").and_then(|lost| field(&log[lost..], "event", "connected"));
        assert!(back.is_some(), "{role} did not reconnect:\n{log}");
    }
    rig.assert_same_trajectory(&view, "after a NATS restart").await;
}
