//! Scale benchmark of the distributed path: one simulated `district` campaign (or a part of it) on a real
//! moto S3 and a real nats-server, the scheduler in process, 1 then 2 `plumbline serve worker` processes
//! and one adjuster; prints wall time, tiles/s and CPU utilisation per worker count.
//!
//! ```text
//! cargo bench -p plumbline-cli --bench scale -- [--campaign DIR | --length M] [--workers 1,2] [--concurrency C]
//! ```
//!
//! Without `--campaign`, `plumbline simulate --preset district --length M` (default 500) writes the campaign
//! to `$TMPDIR/plumbline-scale-district-M` once and later runs reuse it. `PLUMBLINE_BIN` names another
//! `plumbline` binary to run (default: the one cargo builds for this bench). CPU utilisation is the sum of
//! the workers' utime + stime (`/proc/PID/stat`) over the tile phase's wall time × cores; the machine-wide
//! busy share (`/proc/stat`) is printed beside it, since anything else running competes for the same cores.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a benchmark: a failed step ends it with its message

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

// The system tests' S3 helpers (store layout, credentials, upload); this bench starts its own `plumbline serve`
// processes (another binary can be named, and it reads the process's CPU time).
use plumbline_fixtures::services;
use plumbline_runtime::{Files, Secret};
use plumbline_scheduler::client::Client;
use plumbline_scheduler::service::{self, Scheduler, Tokens};
use plumbline_testkit::{MotoServer, NatsServer};

const TOKEN: &str = "scale-token-0123456789abcdef";
use services::STORE;
const AGENCY: &str = "hamburg";
/// How long one campaign may take before the benchmark gives up.
const CAMPAIGN_LIMIT: Duration = Duration::from_secs(3 * 3600);

/// Command-line options (cargo passes `--bench` too; it is ignored).
#[derive(Debug)]
struct Options {
    campaign: Option<PathBuf>,
    length_m: u32,
    workers: Vec<usize>,
    concurrency: u16,
}

fn parse_options() -> Options {
    let mut options = Options { campaign: None, length_m: 500, workers: vec![1, 2], concurrency: 1 };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| panic!("{arg} needs a value"));
        match arg.as_str() {
            "--campaign" => options.campaign = Some(PathBuf::from(value())),
            "--length" => options.length_m = value().parse().expect("--length: metres"),
            "--workers" => options.workers = value().split(',').map(|n| n.parse().expect("--workers: 1,2")).collect(),
            "--concurrency" => options.concurrency = value().parse().expect("--concurrency: tiles per worker"),
            "--bench" => {}
            other => panic!("unknown argument {other}"),
        }
    }
    options
}

/// The `plumbline` binary the services run as.
fn plumbline_bin() -> PathBuf {
    std::env::var_os("PLUMBLINE_BIN").map_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_plumbline")), PathBuf::from)
}

/// A `plumbline` command with the caller's PLUMBLINE_* settings removed.
fn plumbline(args: &[&str]) -> Command {
    let mut cmd = Command::new(plumbline_bin());
    cmd.args(args);
    for (key, _) in std::env::vars().filter(|(k, _)| k.starts_with("PLUMBLINE_")) {
        cmd.env_remove(key);
    }
    cmd
}

/// The campaign directory: given, cached, or simulated now (timed).
fn prepare_campaign(options: &Options) -> PathBuf {
    if let Some(dir) = &options.campaign {
        return dir.clone();
    }
    let dir = std::env::temp_dir().join(format!("plumbline-scale-district-{}", options.length_m));
    if dir.join("campaign.toml").exists() {
        eprintln!("reusing {}", dir.display());
        return dir;
    }
    let partial = dir.with_extension("partial");
    let _ = std::fs::remove_dir_all(&partial);
    let started = Instant::now();
    let length = options.length_m.to_string();
    let status = plumbline(&["simulate", "--preset", "district", "--length", &length, "--out"])
        .arg(&partial)
        .stdout(Stdio::null())
        .status()
        .expect("plumbline simulate runs");
    assert!(status.success(), "plumbline simulate failed: {status}");
    std::fs::rename(&partial, &dir).unwrap();
    eprintln!("simulate --preset district --length {length}: {:.0} s", started.elapsed().as_secs_f64());
    dir
}

/// A `plumbline serve ROLE` child process, killed when dropped; stderr goes to `log`.
struct Role {
    child: Child,
    log: PathBuf,
}

impl Role {
    fn start(role: &str, nats: &NatsServer, moto: &MotoServer, log: PathBuf, extra: &[&str]) -> Self {
        let mut cmd = plumbline(&["serve", role, "--nats", &nats.url(), "--store", STORE, "--insecure-no-nats-auth"]);
        cmd.args(extra)
            .env("PLUMBLINE_S3_ENDPOINT", moto.endpoint())
            .env("PLUMBLINE_S3_ACCESS_KEY_ID", "test")
            .env("PLUMBLINE_S3_SECRET_ACCESS_KEY", "test")
            .env("PLUMBLINE_LOG_FILTER", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap());
        Self { child: cmd.spawn().expect("plumbline serve starts"), log }
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Waits until the log shows `line` (e.g. `worker ready`).
    async fn wait_for(&self, line: &str) {
        let started = Instant::now();
        while !self.log().contains(line) {
            assert!(
                started.elapsed() < Duration::from_secs(60),
                "no `{line}` in {}:\n{}",
                self.log.display(),
                self.log()
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }

    fn pid(&self) -> u32 {
        self.child.id()
    }
}

impl Drop for Role {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// CPU seconds (utime + stime) a process has used so far.
fn cpu_seconds(pid: u32, ticks_per_s: f64) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // Fields after the parenthesised command name: state is field 3, utime 14, stime 15.
    let rest = stat.rsplit_once(')').map_or("", |(_, rest)| rest);
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i - 3).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(14) + ticks(15)) / ticks_per_s
}

/// Machine-wide (busy, total) jiffies from the first line of /proc/stat.
fn machine_jiffies() -> (f64, f64) {
    let stat = std::fs::read_to_string("/proc/stat").unwrap();
    let values: Vec<f64> =
        stat.lines().next().unwrap().split_whitespace().skip(1).map(|v| v.parse().unwrap()).collect();
    let idle = values[3] + values.get(4).copied().unwrap_or(0.0);
    let total: f64 = values.iter().take(8).sum();
    (total - idle, total)
}

fn clock_ticks() -> f64 {
    let out = Command::new("getconf").arg("CLK_TCK").output().expect("getconf runs");
    String::from_utf8_lossy(&out.stdout).trim().parse().expect("CLK_TCK is a number")
}

/// One measured campaign.
#[derive(Debug)]
struct Row {
    workers: usize,
    tiles: u64,
    failed: u64,
    tiles_s: f64,
    total_s: f64,
    worker_cpu_s: f64,
    adjuster_cpu_s: f64,
    machine_busy: f64,
    status: String,
}

/// Everything a measured campaign needs: servers, the API client, the adjuster.
struct Bench {
    campaign: PathBuf,
    manifest: String,
    id: String,
    moto: MotoServer,
    nats: NatsServer,
    files: Files,
    api: Client,
    adjuster: Role,
    logs: tempfile::TempDir,
    ticks: f64,
    cores: f64,
    concurrency: u16,
}

impl Bench {
    /// Runs the campaign once with `n` fresh workers.
    async fn measure(&self, n: usize) -> Row {
        let id = format!("{}-w{n}", self.id);
        let started = Instant::now();
        let bytes = services::upload(&self.files, &self.campaign, &id).await;
        eprintln!("uploaded {:.0} MB for {id} in {:.0} s", bytes as f64 / 1e6, started.elapsed().as_secs_f64());
        let concurrency = self.concurrency.to_string();
        let workers: Vec<Role> = (0..n)
            .map(|i| {
                let log = self.logs.path().join(format!("{id}-worker{i}.log"));
                Role::start("worker", &self.nats, &self.moto, log, &["--concurrency", &concurrency])
            })
            .collect();
        for worker in &workers {
            worker.wait_for("worker ready").await;
        }
        let worker_cpu = || workers.iter().map(|w| cpu_seconds(w.pid(), self.ticks)).sum::<f64>();
        let adjuster_cpu = || cpu_seconds(self.adjuster.pid(), self.ticks);
        let (cpu0, adj0, machine0) = (worker_cpu(), adjuster_cpu(), machine_jiffies());
        let manifest = self.manifest.replacen(&format!("id = \"{}\"", self.id), &format!("id = \"{id}\""), 1);
        let t0 = Instant::now();
        let submitted = self.api.submit(manifest.into_bytes(), false).await.unwrap();
        let tiles = submitted.campaign.tiles_total;
        let (mut tiles_s, mut cpu1, mut machine1) = (None, cpu0, machine0);
        let view = loop {
            let view = self.api.status(&id).await.unwrap();
            if tiles_s.is_none() && view.campaign.tiles_done + view.campaign.tiles_failed >= tiles {
                (tiles_s, cpu1, machine1) = (Some(t0.elapsed().as_secs_f64()), worker_cpu(), machine_jiffies());
            }
            if view.campaign.status.is_terminal() {
                break view;
            }
            assert!(t0.elapsed() < CAMPAIGN_LIMIT, "{id} unfinished: {view:#?}\n{}", self.adjuster.log());
            tokio::time::sleep(Duration::from_millis(250)).await;
        };
        let total_s = t0.elapsed().as_secs_f64();
        let busy = (machine1.0 - machine0.0) / (machine1.1 - machine0.1).max(1.0);
        Row {
            workers: n,
            tiles,
            failed: view.campaign.tiles_failed,
            tiles_s: tiles_s.unwrap_or(total_s),
            total_s,
            worker_cpu_s: cpu1 - cpu0,
            adjuster_cpu_s: adjuster_cpu() - adj0,
            machine_busy: busy,
            status: format!("{:?}", view.campaign.status),
        }
    }
}

fn print_table(rows: &[Row], cores: f64) {
    println!(
        "\n| workers | tiles (failed) | tile phase s | tiles/s | speed-up | worker CPU s | worker CPU util. | machine busy | campaign s (with adjustment) | adjuster CPU s | status |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let base = rows.first().map_or(1.0, |r| r.tiles as f64 / r.tiles_s);
    for r in rows {
        let rate = r.tiles as f64 / r.tiles_s;
        println!(
            "| {} | {} ({}) | {:.1} | {:.4} | {:.2}× | {:.1} | {:.0} % | {:.0} % | {:.1} | {:.1} | {} |",
            r.workers,
            r.tiles,
            r.failed,
            r.tiles_s,
            rate,
            rate / base,
            r.worker_cpu_s,
            100.0 * r.worker_cpu_s / (r.tiles_s * cores),
            100.0 * r.machine_busy,
            r.total_s,
            r.adjuster_cpu_s,
            r.status
        );
    }
}

async fn start(options: &Options) -> Bench {
    let campaign = prepare_campaign(options);
    let manifest = std::fs::read_to_string(campaign.join("campaign.toml")).unwrap();
    let id = manifest.lines().find_map(|l| l.strip_prefix("id = \"")).unwrap().trim_end_matches('"').to_owned();
    let moto = MotoServer::start();
    moto.create_bucket("plumbline");
    let files = services::s3_files(moto.endpoint());
    let nats = NatsServer::start();
    let client =
        service::connect(&nats.url(), service::NatsAuth::Insecure, "test", Duration::from_secs(10)).await.unwrap();
    let tokens = Tokens::from_pairs(&[(TOKEN, AGENCY)]).unwrap();
    let scheduler = Scheduler::start(client, files.clone(), STORE, tokens).await.unwrap();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let server = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(service::serve(listener, scheduler, std::future::pending::<()>()));
    let api = Client::new(&server, Secret::new(TOKEN)).unwrap();
    let logs = tempfile::Builder::new().prefix("plumbline-scale-logs").tempdir().unwrap();
    let adjuster = Role::start("adjuster", &nats, &moto, logs.path().join("adjuster.log"), &[]);
    adjuster.wait_for("adjuster ready").await;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
    let ticks = clock_ticks();
    Bench {
        campaign,
        manifest,
        id,
        moto,
        nats,
        files,
        api,
        adjuster,
        logs,
        ticks,
        cores,
        concurrency: options.concurrency,
    }
}

fn main() {
    let options = parse_options();
    let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap();
    runtime.block_on(async {
        let bench = start(&options).await;
        let mut rows = Vec::new();
        for &n in &options.workers {
            let row = bench.measure(n).await;
            eprintln!("{row:?}");
            rows.push(row);
        }
        println!(
            "scale benchmark: {} ({}), {} cores, worker concurrency {}, binary {}",
            bench.id,
            bench.campaign.display(),
            bench.cores,
            options.concurrency,
            plumbline_bin().display()
        );
        print_table(&rows, bench.cores);
        eprintln!("service logs: {}", bench.logs.keep().display());
    });
}
