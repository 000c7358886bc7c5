//! The scheduler service: the job API agencies submit campaigns through (axum), on top of the JetStream
//! resources of [`crate::bus`] and the object store.
//!
//! | route | auth | answers |
//! |---|---|---|
//! | `POST /v1/campaigns` | bearer | 201 + [`CampaignView`](crate::api::CampaignView) (new campaign or new run; its first tasks dispatched, [`dispatch`]), 200 (resubmission of an active campaign: its dispatched tasks published again, de-duplicated), 401, 403 (a location outside the agency's prefix, by field), 409 (active with a different manifest), 413, 422 (unparseable or invalid manifest, by field; unreadable inputs), 429 (a quota), 503 |
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
pub mod dispatch;
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
use plumbline_runtime::{Error, Files, NatsConfig, Result};

pub use auth::{Agency, MIN_TOKEN_LEN, Tokens};
pub use openapi::openapi;
pub use prefix::{Layout, PrefixProblem, StoredOutputError, check_locations, load_agency_campaign, stored_output};

use crate::bus::{Bus, BusError, ensure};
use metrics::Metrics;

/// Largest manifest accepted.
pub const MAX_MANIFEST_BYTES: usize = 1 << 20;

/// Per-agency limits of the job API: one agency's backlog cannot fill the queue nor its client flood the
/// scheduler. A submission over a limit is refused with 429 naming the limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quotas {
    /// Campaigns of one agency that are neither done, failed nor cancelled.
    pub campaigns_in_flight: usize,
    /// Tiles of one agency's campaigns in flight not yet handled, the new submission's included.
    pub tiles_queued: u64,
    /// Submissions (`POST /v1/campaigns`) one agency may make in any minute.
    pub submissions_per_minute: usize,
    /// Tasks of one agency in the work queue or in progress at once ([`dispatch`]): the most another
    /// agency's newly submitted tile waits behind.
    pub dispatch_window: u64,
    /// Bytes one agency may keep under its prefix (inputs and results), listed at each submission.
    pub bytes_stored: u64,
}

impl Default for Quotas {
    fn default() -> Self {
        Self {
            campaigns_in_flight: 8,
            tiles_queued: 5_000,
            submissions_per_minute: 30,
            dispatch_window: 32,
            bytes_stored: 10 << 40,
        }
    }
}

/// The scheduler's shared state.
#[derive(Debug)]
pub struct Scheduler {
    bus: Bus,
    client: async_nats::Client,
    files: Files,
    layout: Layout,
    tokens: Tokens,
    metrics: Metrics,
    quotas: Quotas,
    /// Each agency's submissions of the last minute.
    recent: std::sync::Mutex<std::collections::HashMap<String, std::collections::VecDeque<std::time::Instant>>>,
    /// The planned tiles of active campaigns, for dispatch.
    plans: std::sync::Mutex<dispatch::PlanCache>,
    /// Held while a dispatch round runs.
    dispatching: tokio::sync::Mutex<()>,
    /// Wakes the dispatcher before its next round is due.
    wake: Arc<tokio::sync::Notify>,
}

impl Scheduler {
    /// Bind (or create) the JetStream resources and serve campaigns stored under `store`, with the default
    /// [`Quotas`]; starts the dispatcher ([`dispatch`]), which stops when the scheduler is dropped.
    pub async fn start(
        client: async_nats::Client,
        files: Files,
        store: &str,
        tokens: Tokens,
    ) -> Result<Arc<Self>, BusError> {
        Self::start_with(client, files, store, tokens, Quotas::default()).await
    }

    /// [`Self::start`] with other quotas.
    pub async fn start_with(
        client: async_nats::Client,
        files: Files,
        store: &str,
        tokens: Tokens,
        quotas: Quotas,
    ) -> Result<Arc<Self>, BusError> {
        let bus = ensure(async_nats::jetstream::new(client.clone())).await?;
        let layout = Layout::new(store);
        tracing::info!(store = layout.root(), ?quotas, "scheduler ready");
        let scheduler = Arc::new(Self {
            bus,
            client,
            files,
            layout,
            tokens,
            metrics: Metrics::default(),
            quotas,
            recent: std::sync::Mutex::default(),
            plans: std::sync::Mutex::default(),
            dispatching: tokio::sync::Mutex::new(()),
            wake: Arc::new(tokio::sync::Notify::new()),
        });
        dispatch::spawn_dispatcher(&scheduler);
        Ok(scheduler)
    }

    /// Count a submission of `agency`; false when it made `submissions_per_minute` already in the last minute.
    fn admit_submission(&self, agency: &str) -> bool {
        let now = std::time::Instant::now();
        let Ok(mut recent) = self.recent.lock() else { return true };
        let times = recent.entry(agency.to_owned()).or_default();
        while times.front().is_some_and(|t| now.duration_since(*t) >= Duration::from_secs(60)) {
            times.pop_front();
        }
        if times.len() >= self.quotas.submissions_per_minute {
            return false;
        }
        times.push_back(now);
        true
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

/// How a role authenticates to NATS: [`NatsConfig`]'s credentials, or none when the caller chose to run
/// without (a development server; `plumbline serve --insecure-no-nats-auth`).
#[derive(Clone, Copy, Debug)]
pub enum NatsAuth<'a> {
    /// The configured credentials (and TLS).
    Config(&'a NatsConfig),
    /// No credentials, no TLS.
    Insecure,
}

/// Connect to NATS as `plumbline-{role}`, retrying the first connection for up to `wait` (an authorization
/// failure is not retried: it would not pass). Every later disconnection and reconnection is logged; the
/// client reconnects without limit.
pub async fn connect(url: &str, auth: NatsAuth<'_>, role: &str, wait: Duration) -> Result<async_nats::Client> {
    let started = std::time::Instant::now();
    loop {
        let options = connect_options(auth, role).await?;
        match options.connect(url).await {
            Ok(client) => return Ok(client),
            Err(e) if e.kind() == async_nats::ConnectErrorKind::AuthorizationViolation => {
                return Err(Error::forbidden(format!("NATS at {url} refused plumbline-{role}'s credentials: {e}")));
            }
            Err(e) if started.elapsed() < wait => {
                tracing::warn!(url, error = %e, "NATS not reachable yet; retrying");
                tokio::time::sleep(Duration::from_millis(500)).await;
            }
            Err(e) => return Err(Error::transient(format!("connecting to NATS at {url}: {e}"))),
        }
    }
}

async fn connect_options(auth: NatsAuth<'_>, role: &str) -> Result<async_nats::ConnectOptions> {
    let mut options =
        async_nats::ConnectOptions::new().name(format!("plumbline-{role}")).event_callback(|event| async move {
            match event {
                async_nats::Event::Connected => tracing::info!(%event, "NATS connection event"),
                _ => tracing::warn!(%event, "NATS connection event"),
            }
        });
    let NatsAuth::Config(config) = auth else { return Ok(options) };
    if let Some(token) = &config.token {
        options = options.token(token.expose().to_owned());
    }
    if let (Some(user), Some(password)) = (&config.user, &config.password) {
        options = options.user_and_password(user.clone(), password.expose().to_owned());
    }
    if let Some(path) = &config.creds_file {
        options = options
            .credentials_file(path)
            .await
            .map_err(|e| Error::invalid(format!("NATS credentials file {}: {e}", path.display())))?;
    }
    if let Some(ca) = &config.tls_ca_file {
        options = options.add_root_certificates(ca.clone()).require_tls(true);
    }
    Ok(options)
}

/// The router of the job API.
pub fn router(scheduler: Arc<Scheduler>) -> Router {
    routes::router(scheduler)
}

/// Limits of the job API's HTTP server against slow or greedy clients.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HttpLimits {
    /// A request's headers must arrive within this, or the connection is closed (slow-loris clients).
    pub header_read: Duration,
    /// A request, its body included, must be answered within this: 408 otherwise (a body sent byte by byte).
    pub request: Duration,
    /// A connection lives at most this long, keep-alive included.
    pub connection: Duration,
    /// Connections served at once; more are closed when accepted.
    pub max_connections: usize,
}

impl Default for HttpLimits {
    fn default() -> Self {
        Self {
            header_read: Duration::from_secs(10),
            request: Duration::from_secs(300),
            connection: Duration::from_secs(900),
            max_connections: 512,
        }
    }
}

/// Serve the API on `listener` with the default [`HttpLimits`] until `shutdown` completes.
pub async fn serve(
    listener: tokio::net::TcpListener,
    scheduler: Arc<Scheduler>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    serve_with(listener, scheduler, HttpLimits::default(), shutdown).await
}

/// Serve the API on `listener` within `limits` until `shutdown` completes; then stop accepting and give the
/// open connections 30 s to finish their requests.
pub async fn serve_with(
    listener: tokio::net::TcpListener,
    scheduler: Arc<Scheduler>,
    limits: HttpLimits,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    use hyper_util::rt::{TokioIo, TokioTimer};
    let request = limits.request;
    let app = router(scheduler).layer(axum::middleware::from_fn(
        move |req: axum::extract::Request, next: axum::middleware::Next| async move {
            match tokio::time::timeout(request, next.run(req)).await {
                Ok(response) => response,
                Err(_) => {
                    let message = format!("the request was not complete within {} s", request.as_secs());
                    axum::response::IntoResponse::into_response(error::ApiError::new(
                        axum::http::StatusCode::REQUEST_TIMEOUT,
                        message,
                    ))
                }
            }
        },
    ));
    let service = hyper_util::service::TowerToHyperService::new(app);
    let slots = Arc::new(tokio::sync::Semaphore::new(limits.max_connections));
    let graceful = hyper_util::server::graceful::GracefulShutdown::new();
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(accepted) => accepted,
                Err(e) => {
                    // Out of file descriptors and the like: wait a moment rather than spin.
                    tracing::warn!(error = %e, "accepting a connection failed");
                    tokio::time::sleep(Duration::from_millis(100)).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        let Ok(slot) = slots.clone().try_acquire_owned() else {
            tracing::warn!(%peer, limit = limits.max_connections, "connection closed: too many open");
            continue;
        };
        let mut http = hyper::server::conn::http1::Builder::new();
        http.timer(TokioTimer::new()).header_read_timeout(limits.header_read);
        let connection = graceful.watch(http.serve_connection(TokioIo::new(stream), service.clone()));
        let lifetime = limits.connection;
        tokio::spawn(async move {
            match tokio::time::timeout(lifetime, connection).await {
                Ok(Err(e)) => tracing::debug!(%peer, error = %e, "connection ended with an error"),
                Err(_) => tracing::debug!(%peer, "connection closed: open too long"),
                Ok(Ok(())) => {}
            }
            drop(slot);
        });
    }
    drop(listener);
    if tokio::time::timeout(Duration::from_secs(30), graceful.shutdown()).await.is_err() {
        tracing::warn!("connections still open 30 s after shutdown; closing them");
    }
    Ok(())
}
