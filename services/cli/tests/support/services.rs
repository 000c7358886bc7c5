//! Shared pieces of the distributed end-to-end tests: `plumbline serve` child processes and the upload of a
//! simulated campaign under an agency's prefix of the S3 store.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use futures::StreamExt as _;
use plumbline_runtime::{Files, S3Options, Secret};

/// The store every role of the tests uses (bucket `plumbline`, prefix `pl`).
pub const STORE: &str = "s3://plumbline/pl";

/// A `plumbline serve` child process, killed when dropped; its stderr goes to `log`.
pub struct Role {
    child: Child,
    log: PathBuf,
}

impl Role {
    /// Start `plumbline serve ROLE` against `nats` (without authentication: `--insecure-no-nats-auth`) and
    /// the S3 endpoint `s3` (moto or a proxy in front of it).
    pub fn start(role: &str, nats: &str, s3: &str, log: PathBuf, extra: &[&str]) -> Self {
        Self::spawn(Self::command(role, nats, s3, &log).arg("--insecure-no-nats-auth").args(extra), log)
    }

    /// [`Self::start`] as the NATS user `user` with `password` (given as `PLUMBLINE_NATS_PASSWORD_FILE`).
    pub fn start_as(
        role: &str,
        nats: &str,
        s3: &str,
        log: PathBuf,
        extra: &[&str],
        user: &str,
        password: &str,
    ) -> Self {
        let secret = log.with_extension("nats-password");
        std::fs::write(&secret, format!("{password}\n")).expect("write the password file");
        let mut cmd = Self::command(role, nats, s3, &log);
        cmd.args(extra)
            .env("PLUMBLINE_NATS_URL", nats)
            .env("PLUMBLINE_NATS_USER", user)
            .env("PLUMBLINE_NATS_PASSWORD_FILE", &secret);
        Self::spawn(&mut cmd, log)
    }

    fn command(role: &str, nats: &str, s3: &str, log: &Path) -> Command {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_plumbline"));
        cmd.args(["serve", role, "--nats", nats, "--store", STORE]);
        for (key, _) in std::env::vars() {
            if key.starts_with("PLUMBLINE_") {
                cmd.env_remove(key);
            }
        }
        cmd.env("PLUMBLINE_S3_ENDPOINT", s3)
            .env("PLUMBLINE_S3_ACCESS_KEY_ID", "test")
            .env("PLUMBLINE_S3_SECRET_ACCESS_KEY", "test")
            .env("PLUMBLINE_LOG_FILTER", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(log).expect("role log file"));
        cmd
    }

    fn spawn(cmd: &mut Command, log: PathBuf) -> Self {
        Self { child: cmd.spawn().expect("plumbline serve starts"), log }
    }

    /// Wait for the process to exit (up to `limit`): its exit code.
    pub fn exit_code(&mut self, limit: Duration) -> Option<i32> {
        let start = Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().expect("poll the role") {
                return status.code();
            }
            assert!(start.elapsed() < limit, "the role still runs after {limit:?}:\n{}", self.log());
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// What the process logged so far.
    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Wait until the log holds `needle` at least `count` times.
    pub fn wait_for(&self, needle: &str, count: usize, limit: Duration) {
        let start = Instant::now();
        while self.log().matches(needle).count() < count {
            assert!(start.elapsed() < limit, "no {count}× {needle:?} within {limit:?}:\n{}", self.log());
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The ops listener's address, from the `ops listening` log line (waits up to 60 s).
    pub fn ops_addr(&self) -> String {
        let start = Instant::now();
        loop {
            let log = self.log();
            if let Some(line) = log.lines().find(|l| l.contains("ops listening")) {
                let from = line.find("127.0.0.1:").expect("a loopback address in the ops line");
                let port: String = line[from + 10..].chars().take_while(char::is_ascii_digit).collect();
                return format!("127.0.0.1:{port}");
            }
            assert!(start.elapsed() < Duration::from_secs(60), "no ops listener logged:\n{log}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// SIGKILL (`kill -9`).
    pub fn kill(&mut self) {
        self.child.kill().expect("kill the role");
        self.child.wait().expect("reap the role");
    }
}

impl Drop for Role {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Files on the S3 endpoint `endpoint` with the test credentials.
pub fn s3_files(endpoint: String) -> Files {
    Files::new(S3Options {
        endpoint: Some(endpoint),
        access_key_id: Some("test".into()),
        secret_access_key: Some(Secret::new("test")),
        ..S3Options::default()
    })
}

/// Every file under `dir` (recursively), relative paths with `/`.
fn walk(dir: &Path, base: &Path, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).expect("read the campaign directory") {
        let path = entry.expect("a directory entry").path();
        if path.is_dir() {
            walk(&path, base, out);
        } else {
            let relative = path.strip_prefix(base).expect("under the base");
            out.push(relative.to_string_lossy().replace('\\', "/"));
        }
    }
}

/// Upload the simulated campaign's inputs (not its `results/`), eight at a time, where a manifest of
/// campaign `id` of agency hamburg finds them; the bytes sent.
pub async fn upload(files: &Files, campaign: &Path, id: &str) -> u64 {
    upload_to(files, campaign, "hamburg", id).await
}

/// [`upload`] for `agency`.
pub async fn upload_to(files: &Files, campaign: &Path, agency: &str, id: &str) -> u64 {
    let mut names = Vec::new();
    walk(campaign, campaign, &mut names);
    let uploads = names.into_iter().filter(|n| !n.starts_with("results/")).map(|name| async move {
        let bytes = std::fs::read(campaign.join(&name)).expect("read a campaign file");
        let size = bytes.len() as u64;
        let url = format!("{STORE}/agencies/{agency}/campaigns/{id}/{name}");
        files.write(&url, bytes).await.expect("upload a campaign file");
        size
    });
    futures::stream::iter(uploads).buffer_unordered(8).fold(0, |sum, size| async move { sum + size }).await
}

/// The agency token of the tests' scheduler (agency hamburg).
pub const TOKEN: &str = "hh-token-0123456789abcdef";
/// Agency bremen's token.
pub const BREMEN_TOKEN: &str = "hb-token-0123456789abcdef";

/// An in-process scheduler on NATS at `nats` with the store `files`, its job API served on a free loopback
/// port until this is dropped.
pub struct SchedulerApi {
    /// The API client with agency hamburg's token.
    pub api: plumbline_scheduler::client::Client,
    /// The API client with agency bremen's token.
    pub bremen: plumbline_scheduler::client::Client,
    /// `http://127.0.0.1:PORT` of the API.
    pub server: String,
    _stop: tokio::sync::oneshot::Sender<()>,
}

impl SchedulerApi {
    /// Connect to `nats` without authentication, start the scheduler and serve its API.
    pub async fn start(nats: &str, files: Files) -> Self {
        Self::start_as(nats, files, plumbline_scheduler::service::NatsAuth::Insecure).await
    }

    /// [`Self::start`] with NATS credentials.
    pub async fn start_as(nats: &str, files: Files, auth: plumbline_scheduler::service::NatsAuth<'_>) -> Self {
        use plumbline_scheduler::service::{self, Scheduler, Tokens};
        let client =
            service::connect(nats, auth, "scheduler", Duration::from_secs(10)).await.expect("connect to nats-server");
        let tokens = Tokens::from_pairs(&[(TOKEN, "hamburg"), (BREMEN_TOKEN, "bremen")]).expect("the test tokens");
        let scheduler = Scheduler::start(client, files, STORE, tokens).await.expect("start the scheduler");
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("a free loopback port");
        let server = format!("http://{}", listener.local_addr().expect("the bound address"));
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        tokio::spawn(service::serve(listener, scheduler, async {
            let _ = stopped.await;
        }));
        let client = |token| plumbline_scheduler::client::Client::new(&server, Secret::new(token)).expect("a client");
        let (api, bremen) = (client(TOKEN), client(BREMEN_TOKEN));
        Self { api, bremen, server, _stop: stop }
    }
}
