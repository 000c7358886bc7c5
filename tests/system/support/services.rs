//! `plumbline serve` child processes for the distributed end-to-end tests (the store layout, the upload of a
//! campaign and the in-process scheduler are in `plumbline_fixtures::services`).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use plumbline_fixtures::services::STORE;

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
