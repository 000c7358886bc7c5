//! `plumbline serve <role>`: the long-running services of the distributed path, on NATS JetStream and an
//! object store, until SIGINT or SIGTERM. `scheduler` serves the job API (`plumbline_scheduler::service`),
//! `worker` processes tile tasks (`plumbline_worker::service`), `adjuster` counts results and runs the
//! global adjustment of finished campaigns (`plumbline_adjuster::service`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Args as ClapArgs, Subcommand};
use plumbline_scheduler::bus::{Bus, TASKS_STREAM, bind, workers_consumer};
use plumbline_scheduler::service::{self, NatsAuth, Scheduler, Tokens};

use crate::exit::{OrInvalid, invalid};
use crate::io::Context;

/// The service roles.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// The job API: validates and plans submitted campaigns, publishes their tile tasks, tracks their state.
    Scheduler(SchedulerArgs),
    /// Processes tile tasks from the work queue and writes their outputs to the store.
    Worker(WorkerArgs),
    /// Counts tile results into the campaign states and adjusts campaigns whose tiles are all handled.
    Adjuster(AdjusterArgs),
}

/// Connection arguments every role shares.
#[derive(Debug, ClapArgs)]
pub struct Connection {
    /// NATS server with JetStream (2.10 or newer). Credentials and TLS come from the runtime config:
    /// PLUMBLINE_NATS_USER + PLUMBLINE_NATS_PASSWORD_FILE (one user per role, see deploy/nats.conf), or
    /// PLUMBLINE_NATS_TOKEN_FILE, or PLUMBLINE_NATS_CREDS_FILE; PLUMBLINE_NATS_TLS_CA_FILE requires TLS.
    #[arg(long, env = "PLUMBLINE_NATS_URL", value_name = "URL")]
    pub nats: String,
    /// Connect to NATS without credentials. Development only: without it a role refuses to start when no
    /// NATS credentials are configured.
    #[arg(long)]
    pub insecure_no_nats_auth: bool,
    /// Object store all agencies' data lives in: s3://bucket/prefix, file:///dir or a local directory.
    #[arg(long, env = "PLUMBLINE_STORE_URL", value_name = "URL")]
    pub store: String,
    /// Seconds to keep trying the first NATS connection.
    #[arg(long, default_value_t = 30)]
    pub connect_timeout_s: u64,
}

/// The ops listener of the worker and adjuster.
#[derive(Debug, ClapArgs)]
pub struct OpsArgs {
    /// Address of the ops HTTP listener (`/healthz`, `/readyz`, `/metrics`), e.g. 0.0.0.0:9090; off unless
    /// given. Port 0 picks a free one; the address is logged as `ops listening`.
    #[arg(long, env = "PLUMBLINE_OPS_LISTEN", value_name = "ADDR")]
    pub ops_listen: Option<String>,
}

impl OpsArgs {
    /// Bind the listener, if asked for.
    async fn bind(&self, store: &str) -> anyhow::Result<Option<plumbline_runtime::ops::Ops>> {
        let Some(addr) = &self.ops_listen else { return Ok(None) };
        let listener = tokio::net::TcpListener::bind(addr).await.or_invalid(&format!("--ops-listen {addr}"))?;
        tracing::info!(addr = %listener.local_addr()?, "ops listening");
        let store_probe = format!("{}/.readyz", store.trim_end_matches('/'));
        Ok(Some(plumbline_runtime::ops::Ops { listener, store_probe }))
    }
}

/// Arguments of `serve worker`.
#[derive(Debug, ClapArgs)]
pub struct WorkerArgs {
    #[command(flatten)]
    pub connection: Connection,
    #[command(flatten)]
    pub ops: OpsArgs,
    /// Tile tasks in flight at once (each tile already uses every core).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..=64))]
    pub concurrency: u16,
    /// Seconds between in-progress acks while a tile runs (keep it below the consumer's ack wait).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub heartbeat_s: u64,
    /// Testing knob: rewrite the shared `workers` consumer's ack wait (and every redelivery backoff step)
    /// to this many seconds, so a killed worker's task comes back quickly. Any role started later resets
    /// the consumer to the defaults (60 s); do not use in production.
    #[arg(long, value_name = "S", value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub ack_wait_s: Option<u64>,
    /// Seconds a task waits before its next delivery after a retryable error (store or NATS unavailable).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub retry_delay_s: u64,
}

/// Arguments of `serve adjuster`.
#[derive(Debug, ClapArgs)]
pub struct AdjusterArgs {
    #[command(flatten)]
    pub connection: Connection,
    #[command(flatten)]
    pub ops: OpsArgs,
}

/// Arguments of `serve scheduler`.
#[derive(Debug, ClapArgs)]
pub struct SchedulerArgs {
    #[command(flatten)]
    pub connection: Connection,
    /// Address to serve the API on.
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "ADDR")]
    pub listen: String,
    /// Bearer tokens: a TOML file whose `[tokens]` table maps each token to its agency.
    #[arg(long, env = "PLUMBLINE_TOKENS_FILE", value_name = "FILE")]
    pub tokens: PathBuf,
    /// Per agency: campaigns neither done, failed nor cancelled.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(1..))]
    pub quota_campaigns: u64,
    /// Per agency: tiles of its campaigns in flight not yet handled.
    #[arg(long, default_value_t = 5_000, value_parser = clap::value_parser!(u64).range(1..))]
    pub quota_tiles: u64,
    /// Per agency: submissions in any minute.
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u64).range(1..))]
    pub quota_submissions_per_minute: u64,
    /// Per agency: bytes kept under its prefix, in GiB.
    #[arg(long, default_value_t = 10_240, value_parser = clap::value_parser!(u64).range(1..))]
    pub quota_gib: u64,
    /// Per agency: tasks in the work queue or in progress at once (fair dispatch); the most another agency's
    /// new tile waits behind. Keep it at or above the number of workers one agency should keep busy.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u64).range(1..))]
    pub dispatch_window: u64,
}

/// Run `serve`.
pub async fn run(ctx: &Context, command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Scheduler(args) => scheduler(ctx, args).await,
        Command::Worker(args) => worker(ctx, args).await,
        Command::Adjuster(args) => adjuster(ctx, args).await,
    }
}

/// Connect as `plumbline-{role}` with the configured credentials; refuse to start without any unless
/// `--insecure-no-nats-auth` says so.
async fn connect(ctx: &Context, connection: &Connection, role: &str) -> anyhow::Result<async_nats::Client> {
    let config = ctx.nats();
    let auth = match (config, connection.insecure_no_nats_auth) {
        (Some(c), true) if c.has_credentials() => {
            return Err(invalid(
                "--insecure-no-nats-auth is given while NATS credentials are configured; drop one of them",
            ));
        }
        (Some(c), false) if c.has_credentials() => NatsAuth::Config(c),
        (_, false) => {
            return Err(invalid(
                "no NATS credentials configured: set PLUMBLINE_NATS_USER and PLUMBLINE_NATS_PASSWORD_FILE (each \
                 role has its user in deploy/nats.conf), or PLUMBLINE_NATS_TOKEN_FILE, or PLUMBLINE_NATS_CREDS_FILE; \
                 a development server without authentication needs --insecure-no-nats-auth",
            ));
        }
        (config, true) => {
            tracing::warn!("connecting to NATS without credentials (--insecure-no-nats-auth): development only");
            config.map_or(NatsAuth::Insecure, NatsAuth::Config)
        }
    };
    let wait = Duration::from_secs(connection.connect_timeout_s);
    Ok(service::connect(&connection.nats, auth, role, wait).await?)
}

/// Connect and bind the JetStream resources the scheduler created (waiting for them as long as for the
/// connection). Stream, consumer and bucket handles are names on the server, so they work again once a
/// restarted server is back (it keeps them in its store directory).
async fn bus(ctx: &Context, connection: &Connection, role: &str) -> anyhow::Result<Bus> {
    let client = connect(ctx, connection, role).await?;
    let wait = Duration::from_secs(connection.connect_timeout_s);
    Ok(bind(async_nats::jetstream::new(client), wait).await?)
}

async fn worker(ctx: &Context, args: WorkerArgs) -> anyhow::Result<ExitCode> {
    let bus = bus(ctx, &args.connection, "worker").await?;
    if let Some(seconds) = args.ack_wait_s {
        shorten_ack_wait(&bus, Duration::from_secs(seconds)).await?;
    }
    let config = plumbline_worker::service::ServiceConfig {
        concurrency: usize::from(args.concurrency),
        heartbeat: Duration::from_secs(args.heartbeat_s),
        retry_delay: Duration::from_secs(args.retry_delay_s),
    };
    tracing::info!(store = args.connection.store, "worker starting");
    let ops = args.ops.bind(&args.connection.store).await?;
    let layout = service::Layout::new(&args.connection.store);
    plumbline_worker::service::serve(bus, ctx.files().clone(), layout, config, ops, shutdown_signal()).await?;
    Ok(ExitCode::SUCCESS)
}

async fn adjuster(ctx: &Context, args: AdjusterArgs) -> anyhow::Result<ExitCode> {
    let bus = bus(ctx, &args.connection, "adjuster").await?;
    tracing::info!(store = args.connection.store, "adjuster starting");
    let ops = args.ops.bind(&args.connection.store).await?;
    let layout = service::Layout::new(&args.connection.store);
    plumbline_adjuster::service::serve(bus, ctx.files().clone(), layout, ops, shutdown_signal()).await?;
    Ok(ExitCode::SUCCESS)
}

/// Rewrite the workers consumer's ack wait and backoff (the `--ack-wait-s` testing knob).
async fn shorten_ack_wait(bus: &Bus, wait: Duration) -> anyhow::Result<()> {
    let mut config = workers_consumer();
    config.ack_wait = wait;
    config.backoff = vec![wait; config.backoff.len()];
    let stream = bus.js.get_stream(TASKS_STREAM).await?;
    stream.update_consumer(config).await?;
    tracing::warn!(seconds = wait.as_secs(), "workers consumer's ack wait shortened (testing knob)");
    Ok(())
}

async fn scheduler(ctx: &Context, args: SchedulerArgs) -> anyhow::Result<ExitCode> {
    let origin = args.tokens.display().to_string();
    let text = std::fs::read_to_string(&args.tokens).or_invalid(&format!("tokens file {origin}"))?;
    let tokens = Tokens::from_toml(&origin, &text).map_err(invalid)?;
    let client = connect(ctx, &args.connection, "scheduler").await?;
    let quotas = service::Quotas {
        campaigns_in_flight: usize::try_from(args.quota_campaigns).unwrap_or(usize::MAX),
        tiles_queued: args.quota_tiles,
        submissions_per_minute: usize::try_from(args.quota_submissions_per_minute).unwrap_or(usize::MAX),
        dispatch_window: args.dispatch_window,
        bytes_stored: args.quota_gib.saturating_mul(1 << 30),
    };
    let store = &args.connection.store;
    let scheduler = Scheduler::start_with(client, ctx.files().clone(), store, tokens, quotas).await?;
    let listener =
        tokio::net::TcpListener::bind(&args.listen).await.or_invalid(&format!("--listen {}", args.listen))?;
    tracing::info!(listen = %listener.local_addr()?, "scheduler API listening");
    service::serve(listener, scheduler, shutdown_signal()).await?;
    tracing::info!("scheduler stopped");
    Ok(ExitCode::SUCCESS)
}

/// Completes on SIGINT or SIGTERM.
async fn shutdown_signal() {
    let interrupt = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut signal) => {
                signal.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let terminate = std::future::pending::<()>();
    tokio::select! {
        () = interrupt => {},
        () = terminate => {},
    }
}
