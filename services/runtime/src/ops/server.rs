//! The ops HTTP listener of the worker and adjuster roles (`--ops-listen ADDR`): `GET /healthz` (200
//! while the process runs), `GET /readyz` (200 when NATS is connected and the store answers, else 503; JSON
//! says which), `GET /metrics` (Prometheus text). A minimal HTTP/1.1 responder: one request per connection,
//! no body, `Connection: close` — all a probe or a scraper needs.

use std::future::Future;
use std::sync::Arc;
use std::time::Duration;

use futures::future::BoxFuture;
use tokio::io::{AsyncReadExt as _, AsyncWriteExt as _};
use tokio::net::{TcpListener, TcpStream};

use crate::Files;

/// The ops listener of a role: where to answer probes and scrapes, and a URL in the store to probe.
#[derive(Debug)]
pub struct Ops {
    /// The bound listener.
    pub listener: TcpListener,
    /// A URL in the store (its absence is fine; an error means the store does not answer).
    pub store_probe: String,
}

/// Whether NATS is connected, and whether the store answers at `probe` (a missing object is an answer): what
/// every role's `/readyz` says.
pub async fn ready(client: &async_nats::Client, files: &Files, probe: Option<&str>) -> (bool, bool) {
    let nats = client.connection_state() == async_nats::connection::State::Connected;
    let store = match probe {
        Some(url) => match files.exists(url).await {
            Ok(_) => true,
            Err(e) => {
                tracing::warn!(error = %e, "store not reachable");
                false
            }
        },
        None => true,
    };
    (nats, store)
}

/// What the listener asks its service.
pub trait Probe: Send + Sync + 'static {
    /// Whether NATS is connected and whether the store answers.
    fn ready(&self) -> BoxFuture<'_, (bool, bool)>;
    /// The exposition text (gauges read at scrape time included).
    fn metrics(&self) -> BoxFuture<'_, String>;
}

/// Answer requests on `listener` until `shutdown` completes.
pub async fn serve_ops(listener: TcpListener, probe: Arc<dyn Probe>, shutdown: impl Future<Output = ()> + Send) {
    tokio::pin!(shutdown);
    loop {
        let accepted = tokio::select! {
            () = &mut shutdown => return,
            accepted = listener.accept() => accepted,
        };
        match accepted {
            Ok((stream, _)) => {
                let probe = probe.clone();
                tokio::spawn(async move {
                    if let Err(e) = answer(stream, probe.as_ref()).await {
                        tracing::debug!(error = %e, "ops request failed");
                    }
                });
            }
            Err(e) => {
                tracing::warn!(error = %e, "ops listener: accept failed");
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        }
    }
}

/// Read one request head and write the response.
async fn answer(mut stream: TcpStream, probe: &dyn Probe) -> std::io::Result<()> {
    let mut head = Vec::with_capacity(512);
    let mut buf = [0u8; 512];
    let read = async {
        while !head.windows(4).any(|w| w == b"\r\n\r\n") && head.len() < 8192 {
            let n = stream.read(&mut buf).await?;
            if n == 0 {
                break;
            }
            head.extend_from_slice(&buf[..n]);
        }
        Ok::<_, std::io::Error>(())
    };
    tokio::time::timeout(Duration::from_secs(5), read).await.map_err(|_| std::io::ErrorKind::TimedOut)??;
    let line = String::from_utf8_lossy(&head);
    let mut parts = line.split_whitespace();
    let (method, path) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
    let (status, kind, body) = route(method, path, probe).await;
    let response = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    );
    stream.write_all(response.as_bytes()).await?;
    stream.shutdown().await
}

/// Status line, content type and body of a request.
async fn route(method: &str, path: &str, probe: &dyn Probe) -> (&'static str, &'static str, String) {
    const JSON: &str = "application/json";
    if method != "GET" {
        return ("405 Method Not Allowed", "text/plain", "only GET\n".into());
    }
    match path {
        "/healthz" => ("200 OK", "text/plain", "ok\n".into()),
        "/readyz" => {
            let (nats, store) = probe.ready().await;
            let body = format!("{{\"nats\":{nats},\"store\":{store}}}");
            (if nats && store { "200 OK" } else { "503 Service Unavailable" }, JSON, body)
        }
        "/metrics" => ("200 OK", "text/plain; version=0.0.4", probe.metrics().await),
        _ => ("404 Not Found", "text/plain", format!("no route {path}\n")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Fixed(bool);

    impl Probe for Fixed {
        fn ready(&self) -> BoxFuture<'_, (bool, bool)> {
            Box::pin(async move { (true, self.0) })
        }
        fn metrics(&self) -> BoxFuture<'_, String> {
            Box::pin(async { "plumbline_x 1\n".to_owned() })
        }
    }

    async fn get(addr: std::net::SocketAddr, path: &str) -> String {
        let mut s = TcpStream::connect(addr).await.unwrap();
        s.write_all(format!("GET {path} HTTP/1.1\r\nHost: x\r\n\r\n").as_bytes()).await.unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).await.unwrap();
        out
    }

    #[tokio::test]
    async fn health_readiness_metrics_and_unknown_routes() {
        for (store, ready_status) in [(true, "200 OK"), (false, "503 Service Unavailable")] {
            let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
            let addr = listener.local_addr().unwrap();
            let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
            let server = tokio::spawn(serve_ops(listener, Arc::new(Fixed(store)), async {
                let _ = stopped.await;
            }));
            assert!(get(addr, "/healthz").await.starts_with("HTTP/1.1 200 OK\r\n"));
            let ready = get(addr, "/readyz").await;
            assert!(ready.starts_with(&format!("HTTP/1.1 {ready_status}\r\n")), "{ready}");
            assert!(ready.ends_with(&format!("{{\"nats\":true,\"store\":{store}}}")), "{ready}");
            let metrics = get(addr, "/metrics").await;
            assert!(metrics.contains("version=0.0.4") && metrics.ends_with("\r\n\r\nplumbline_x 1\n"), "{metrics}");
            assert!(get(addr, "/nope").await.starts_with("HTTP/1.1 404 "));
            let _ = stop.send(());
            server.await.unwrap();
        }
    }
}
