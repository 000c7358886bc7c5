//! A TCP fault-injection proxy: listens on a free loopback port and forwards every connection to an
//! upstream address, until told to go [`down`](FlakyProxy::down) — then it cuts the connections it carries
//! and closes every new one at once, until [`up`](FlakyProxy::up). Point a client at the proxy to give it an
//! outage of a server whose state must survive (moto keeps its objects in memory: stopping it would lose
//! them, so a restart cannot stand in for an outage).

use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

/// The state the accept loop and the handle share.
#[derive(Debug, Default)]
struct Shared {
    down: AtomicBool,
    stop: AtomicBool,
    /// Both ends of every forwarded connection, to cut them when going down.
    open: Mutex<Vec<TcpStream>>,
    refused: AtomicU64,
    cut: AtomicU64,
    forwarded: AtomicU64,
    /// Bytes sent from the upstream server to clients.
    downstream_bytes: AtomicU64,
}

/// A running proxy; dropping it stops accepting and cuts every connection.
#[derive(Debug)]
pub struct FlakyProxy {
    port: u16,
    shared: Arc<Shared>,
    accept: Option<JoinHandle<()>>,
}

impl FlakyProxy {
    /// Listen on a free loopback port and forward to `upstream` (`host:port`).
    pub fn start(upstream: &str) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind the proxy's loopback port");
        let port = listener.local_addr().expect("proxy address").port();
        listener.set_nonblocking(true).expect("non-blocking proxy listener");
        let shared = Arc::new(Shared::default());
        let (state, upstream) = (shared.clone(), upstream.to_owned());
        let accept = std::thread::spawn(move || accept_loop(&listener, &state, &upstream));
        Self { port, shared, accept: Some(accept) }
    }

    /// The proxy's port.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// `http://127.0.0.1:PORT`.
    pub fn endpoint(&self) -> String {
        format!("http://127.0.0.1:{}", self.port)
    }

    /// Cut every forwarded connection and close new ones at once until [`up`](Self::up).
    pub fn down(&self) {
        self.shared.down.store(true, Ordering::SeqCst);
        let mut open = self.shared.open.lock().unwrap_or_else(PoisonError::into_inner);
        self.shared.cut.fetch_add(open.len() as u64 / 2, Ordering::SeqCst);
        for stream in open.drain(..) {
            let _ = stream.shutdown(Shutdown::Both);
        }
    }

    /// Forward again.
    pub fn up(&self) {
        self.shared.down.store(false, Ordering::SeqCst);
    }

    /// Connections closed at once while down.
    pub fn refused(&self) -> u64 {
        self.shared.refused.load(Ordering::SeqCst)
    }

    /// Connections cut by [`down`](Self::down).
    pub fn cut(&self) -> u64 {
        self.shared.cut.load(Ordering::SeqCst)
    }

    /// Connections forwarded so far.
    pub fn forwarded(&self) -> u64 {
        self.shared.forwarded.load(Ordering::SeqCst)
    }

    /// Bytes the upstream server sent to clients so far (responses: what a reader transferred).
    pub fn downstream_bytes(&self) -> u64 {
        self.shared.downstream_bytes.load(Ordering::SeqCst)
    }
}

impl Drop for FlakyProxy {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        self.down();
        if let Some(accept) = self.accept.take() {
            let _ = accept.join();
        }
    }
}

fn accept_loop(listener: &TcpListener, shared: &Arc<Shared>, upstream: &str) {
    while !shared.stop.load(Ordering::SeqCst) {
        match listener.accept() {
            Ok((client, _)) => {
                let _ = client.set_nonblocking(false);
                if shared.down.load(Ordering::SeqCst) {
                    shared.refused.fetch_add(1, Ordering::SeqCst);
                    let _ = client.shutdown(Shutdown::Both);
                    continue;
                }
                forward(client, shared, upstream);
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => std::thread::sleep(Duration::from_millis(5)),
            Err(_) => std::thread::sleep(Duration::from_millis(5)),
        }
    }
}

/// Connect to `upstream` and pump bytes both ways on two threads.
fn forward(client: TcpStream, shared: &Arc<Shared>, upstream: &str) {
    let Ok(server) = TcpStream::connect(upstream) else {
        let _ = client.shutdown(Shutdown::Both);
        return;
    };
    let (Ok(client2), Ok(server2), Ok(client3), Ok(server3)) =
        (client.try_clone(), server.try_clone(), client.try_clone(), server.try_clone())
    else {
        return;
    };
    shared.forwarded.fetch_add(1, Ordering::SeqCst);
    shared.open.lock().unwrap_or_else(PoisonError::into_inner).extend([client3, server3]);
    let counted = Arc::clone(shared);
    std::thread::spawn(move || pump(client, server, None));
    std::thread::spawn(move || pump(server2, client2, Some(&counted.downstream_bytes)));
}

/// Copy `from` to `to` until either side closes, then close both; count the bytes in `count` if given.
fn pump(mut from: TcpStream, mut to: TcpStream, count: Option<&AtomicU64>) {
    let mut buf = [0u8; 16 * 1024];
    loop {
        match from.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => {
                if to.write_all(&buf[..n]).is_err() {
                    break;
                }
                if let Some(count) = count {
                    count.fetch_add(n as u64, Ordering::SeqCst);
                }
            }
        }
    }
    let _ = from.shutdown(Shutdown::Both);
    let _ = to.shutdown(Shutdown::Both);
}

#[cfg(test)]
mod tests {
    use std::io::{BufRead, BufReader};

    use super::*;

    /// An echo server on a free port: echoes each line back.
    fn echo() -> u16 {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        std::thread::spawn(move || {
            for stream in listener.incoming().flatten() {
                std::thread::spawn(move || {
                    let mut writer = stream.try_clone().unwrap();
                    for line in BufReader::new(stream).lines().map_while(Result::ok) {
                        if writeln!(writer, "{line}").is_err() {
                            break;
                        }
                    }
                });
            }
        });
        port
    }

    fn roundtrip(stream: &mut TcpStream, reader: &mut BufReader<TcpStream>, text: &str) -> std::io::Result<String> {
        writeln!(stream, "{text}")?;
        let mut line = String::new();
        if reader.read_line(&mut line)? == 0 {
            return Err(std::io::Error::new(ErrorKind::UnexpectedEof, "closed"));
        }
        Ok(line.trim_end().to_owned())
    }

    fn connect(proxy: &FlakyProxy) -> (TcpStream, BufReader<TcpStream>) {
        let stream = TcpStream::connect(("127.0.0.1", proxy.port())).unwrap();
        stream.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let reader = BufReader::new(stream.try_clone().unwrap());
        (stream, reader)
    }

    #[test]
    fn forwards_cuts_refuses_and_recovers() {
        let proxy = FlakyProxy::start(&format!("127.0.0.1:{}", echo()));
        let (mut stream, mut reader) = connect(&proxy);
        assert_eq!(roundtrip(&mut stream, &mut reader, "hello").unwrap(), "hello");
        proxy.down();
        assert_eq!(proxy.cut(), 1);
        assert!(roundtrip(&mut stream, &mut reader, "cut?").is_err(), "an open connection survived down()");
        let (mut fresh, mut fresh_reader) = connect(&proxy);
        assert!(roundtrip(&mut fresh, &mut fresh_reader, "refused?").is_err(), "a new connection got through");
        assert!(proxy.refused() >= 1);
        proxy.up();
        let (mut again, mut again_reader) = connect(&proxy);
        assert_eq!(roundtrip(&mut again, &mut again_reader, "back").unwrap(), "back");
        assert_eq!(proxy.forwarded(), 2);
    }
}
