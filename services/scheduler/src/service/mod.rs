//! The scheduler service: the job API agencies submit campaigns through (axum), on top of the JetStream
//! resources of [`crate::bus`] and the object store.
//!
//! | route | auth | answers |
//! |---|---|---|
//! | `POST /v1/campaigns` | bearer | 201 + [`CampaignView`](crate::api::CampaignView) (new campaign or new run), 200 (resubmission of an active campaign: tasks de-duplicated), 401, 403 (a location outside the agency's prefix, by field), 409 (id owned by another agency, or active with a different manifest), 413, 422 (unparseable or invalid manifest, by field; unreadable inputs), 503 |
//! | `GET /v1/campaigns` | bearer | 200 + [`CampaignList`](crate::api::CampaignList) of the agency's own campaigns |
//! | `GET /v1/campaigns/{id}` | bearer | 200 + [`CampaignView`](crate::api::CampaignView), 404 (unknown or another agency's) |
//! | `GET /v1/campaigns/{id}/report` | bearer | 200 + `report.json`, 409 until done, 404 |
//! | `DELETE /v1/campaigns/{id}` | bearer | 200 + [`CampaignView`](crate::api::CampaignView) (status `cancelled`), 409 when already done/failed, 404 |
//! | `GET /v1/openapi.json` | none | the OpenAPI 3.1 document (`schemas/openapi.json`) |
//! | `GET /healthz` | none | 200 while the process runs |
//! | `GET /readyz` | none | 200 when NATS is connected and the store answers, else 503 (JSON says which) |
//! | `GET /metrics` | none | Prometheus text ([`metrics`]) |
//!
//! Submission body: the manifest itself, TOML (`Content-Type: application/toml`, or anything not JSON) or
//! JSON (`application/json`). It is stored at `{store}/agencies/<agency>/campaigns/<id>/manifest.toml`
//! (`.json`), so its relative locations resolve there; agencies upload their inputs under their prefix
//! `{store}/agencies/<agency>/` first (absolute URLs must stay under it too).

mod auth;
mod error;
pub mod metrics;
mod openapi;
mod prefix;
mod routes;
mod submit;

use std::future::Future;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use plumbline_runtime::{Files, Secret};

pub use auth::{Agency, MIN_TOKEN_LEN, Tokens};
pub use openapi::openapi;
pub use prefix::{Layout, PrefixProblem, check_locations};

use crate::bus::{Bus, BusError, ensure};
use metrics::Metrics;

/// Largest manifest accepted.
pub const MAX_MANIFEST_BYTES: usize = 1 << 20;

/// The scheduler's shared state.
#[derive(Debug)]
pub struct Scheduler {
    bus: Bus,
    client: async_nats::Client,
    files: Files,
    layout: Layout,
    tokens: Tokens,
    metrics: Metrics,
}

impl Scheduler {
    /// Bind (or create) the JetStream resources and serve campaigns stored under `store`.
    pub async fn start(
        client: async_nats::Client,
        files: Files,
        store: &str,
        tokens: Tokens,
    ) -> Result<Arc<Self>, BusError> {
        let bus = ensure(async_nats::jetstream::new(client.clone())).await?;
        let layout = Layout::new(store);
        tracing::info!(store = layout.root(), "scheduler ready");
        Ok(Arc::new(Self { bus, client, files, layout, tokens, metrics: Metrics::default() }))
    }

    /// The bound JetStream resources.
    pub fn bus(&self) -> &Bus {
        &self.bus
    }

    /// The store layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }
}

/// Connect to NATS, retrying the first connection for up to `wait`; later outages are bridged by the
/// client's unlimited reconnects.
pub async fn connect(url: &str, token: Option<&Secret>, wait: Duration) -> anyhow::Result<async_nats::Client> {
    let started = std::time::Instant::now();
    loop {
        let mut options = async_nats::ConnectOptions::new().name("plumbline-scheduler");
        if let Some(token) = token {
            options = options.token(token.expose().to_owned());
        }
        match options.connect(url).await {
            Ok(client) => return Ok(client),
            Err(e) if started.elapsed() < wait => {
                tracing::warn!(url, error = %e, "NATS not reachable yet; retrying");
                tokio::time::sleep(Duration::from_millis(500)).await;
            }
            Err(e) => return Err(anyhow::anyhow!("connecting to NATS at {url}: {e}")),
        }
    }
}

/// The router of the job API.
pub fn router(scheduler: Arc<Scheduler>) -> Router {
    routes::router(scheduler)
}

/// Serve the API on `listener` until `shutdown` completes.
pub async fn serve(
    listener: tokio::net::TcpListener,
    scheduler: Arc<Scheduler>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    axum::serve(listener, router(scheduler)).with_graceful_shutdown(shutdown).await
}
