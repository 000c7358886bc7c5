//! A real S3-compatible server for tests: `moto_server` on a free loopback port, killed on drop.

use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::free_port;

const INSTALL_HINT: &str = "install it with `pip install 'moto[server]'` (it must be on PATH)";
const STARTUP_TIMEOUT: Duration = Duration::from_secs(60);

/// A running `moto_server`; dropping it kills the process.
#[derive(Debug)]
pub struct MotoServer {
    child: Child,
    port: u16,
}

impl MotoServer {
    /// Starts `moto_server` on a free port and waits until it answers. Panics (failing the test)
    /// with an install hint if the binary is missing.
    pub fn start() -> Self {
        let port = free_port();
        let child = Command::new("moto_server")
            .args(["-H", "127.0.0.1", "-p", &port.to_string()])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| match e.kind() {
                ErrorKind::NotFound => panic!("moto_server not found: {INSTALL_HINT}"),
                _ => panic!("cannot start moto_server ({e}); {INSTALL_HINT}"),
            });
        let mut server = Self { child, port };
        server.wait_until_ready();
        server
    }

    /// `http://127.0.0.1:PORT`.
    pub fn endpoint(&self) -> String {
        format!("http://127.0.0.1:{}", self.port)
    }

    /// Creates a bucket with a plain, unsigned HTTP PUT (moto accepts it).
    pub fn create_bucket(&self, bucket: &str) {
        let status = self.request("PUT", &format!("/{bucket}"));
        assert_eq!(status, 200, "creating bucket {bucket} on moto_server");
    }

    fn wait_until_ready(&mut self) {
        let started = Instant::now();
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                panic!("moto_server exited at startup with {status}; {INSTALL_HINT}");
            }
            if self.try_request("GET", "/").is_ok_and(|status| status == 200) {
                return;
            }
            assert!(started.elapsed() < STARTUP_TIMEOUT, "moto_server did not answer within {STARTUP_TIMEOUT:?}");
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// The body of an unsigned `GET path` (moto answers it), e.g. `/bucket?uploads` to list the bucket's
    /// unfinished multipart uploads. Panics (failing the test) when the request fails.
    pub fn get(&self, path: &str) -> String {
        let response = self.exchange("GET", path).unwrap_or_else(|e| panic!("GET {path} on moto_server: {e}"));
        response.split_once("\r\n\r\n").map_or_else(String::new, |(_, body)| body.to_owned())
    }

    fn request(&self, method: &str, path: &str) -> u16 {
        self.try_request(method, path).unwrap_or_else(|e| panic!("{method} {path} on moto_server: {e}"))
    }

    /// Sends a body-less HTTP/1.1 request and returns the status code.
    fn try_request(&self, method: &str, path: &str) -> std::io::Result<u16> {
        let response = self.exchange(method, path)?;
        parse_status(&response)
            .ok_or_else(|| std::io::Error::new(ErrorKind::InvalidData, format!("bad HTTP response: {response:.80}")))
    }

    /// Sends a body-less HTTP/1.1 request and returns the whole response.
    fn exchange(&self, method: &str, path: &str) -> std::io::Result<String> {
        let mut stream = TcpStream::connect(("127.0.0.1", self.port))?;
        stream.set_read_timeout(Some(Duration::from_secs(10)))?;
        let host = format!("127.0.0.1:{}", self.port);
        write!(stream, "{method} {path} HTTP/1.1\r\nHost: {host}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")?;
        let mut response = String::new();
        stream.read_to_string(&mut response)?;
        Ok(response)
    }
}

impl Drop for MotoServer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn parse_status(response: &str) -> Option<u16> {
    response.split_whitespace().nth(1)?.parse().ok()
}
