//! `plumbline serve <role>`: the long-running services of the distributed path, on NATS JetStream and an
//! object store, until SIGINT or SIGTERM. `scheduler` serves the job API (`plumbline_scheduler::service`),
//! `worker` processes tile tasks (`plumbline_worker::service`), `adjuster` counts results and runs the
//! global adjustment of finished campaigns (`plumbline_adjuster::service`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Args as ClapArgs, Subcommand};
use plumbline_runtime::Secret;
use plumbline_scheduler::bus::{Bus, TASKS_STREAM, ensure, workers_consumer};
use plumbline_scheduler::service::{self, Scheduler, Tokens};

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
    /// NATS server with JetStream (2.10 or newer).
    #[arg(long, env = "PLUMBLINE_NATS_URL", value_name = "URL")]
    pub nats: String,
    /// File holding the NATS token, if the server wants one.
    #[arg(long, env = "PLUMBLINE_NATS_TOKEN_FILE", value_name = "FILE")]
    pub nats_token_file: Option<PathBuf>,
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
    async fn bind(&self, store: &str) -> anyhow::Result<Option<plumbline_worker::service::Ops>> {
        let Some(addr) = &self.ops_listen else { return Ok(None) };
        let listener = tokio::net::TcpListener::bind(addr).await.or_invalid(&format!("--ops-listen {addr}"))?;
        tracing::info!(addr = %listener.local_addr()?, "ops listening");
        let store_probe = format!("{}/.readyz", store.trim_end_matches('/'));
        Ok(Some(plumbline_worker::service::Ops { listener, store_probe }))
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
}

/// Run `serve`.
pub async fn run(ctx: &Context, command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Scheduler(args) => scheduler(ctx, args).await,
        Command::Worker(args) => worker(ctx, args).await,
        Command::Adjuster(args) => adjuster(ctx, args).await,
    }
}

/// Connect (logging every later disconnection and reconnection) and bind the JetStream resources. The
/// client reconnects without limit; stream, consumer and bucket handles are names on the server, so they
/// work again once it is back (a restarted server keeps them in its store directory).
async fn bus(connection: &Connection, role: &str) -> anyhow::Result<Bus> {
    let token = nats_token(connection.nats_token_file.as_ref())?;
    let started = std::time::Instant::now();
    let wait = Duration::from_secs(connection.connect_timeout_s);
    let client = loop {
        let mut options =
            async_nats::ConnectOptions::new().name(format!("plumbline-{role}")).event_callback(|event| async move {
                match event {
                    async_nats::Event::Connected => tracing::info!(%event, "NATS connection event"),
                    _ => tracing::warn!(%event, "NATS connection event"),
                }
            });
        if let Some(token) = &token {
            options = options.token(token.expose().to_owned());
        }
        match options.connect(&connection.nats).await {
            Ok(client) => break client,
            Err(e) if started.elapsed() < wait => {
                tracing::warn!(url = connection.nats, error = %e, "NATS not reachable yet; retrying");
                tokio::time::sleep(Duration::from_millis(500)).await;
            }
            Err(e) => anyhow::bail!("connecting to NATS at {}: {e}", connection.nats),
        }
    };
    Ok(ensure(async_nats::jetstream::new(client)).await?)
}

async fn worker(ctx: &Context, args: WorkerArgs) -> anyhow::Result<ExitCode> {
    let bus = bus(&args.connection, "worker").await?;
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
    plumbline_worker::service::serve(bus, ctx.files().clone(), config, ops, shutdown_signal()).await?;
    Ok(ExitCode::SUCCESS)
}

async fn adjuster(ctx: &Context, args: AdjusterArgs) -> anyhow::Result<ExitCode> {
    let bus = bus(&args.connection, "adjuster").await?;
    tracing::info!(store = args.connection.store, "adjuster starting");
    let ops = args.ops.bind(&args.connection.store).await?;
    plumbline_adjuster::service::serve(bus, ctx.files().clone(), ops, shutdown_signal()).await?;
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

fn nats_token(file: Option<&PathBuf>) -> anyhow::Result<Option<Secret>> {
    match file {
        Some(path) => {
            let token = std::fs::read_to_string(path).or_invalid(&format!("NATS token file {}", path.display()))?;
            Ok(Some(Secret::new(token.trim())))
        }
        None => Ok(None),
    }
}

async fn scheduler(ctx: &Context, args: SchedulerArgs) -> anyhow::Result<ExitCode> {
    let origin = args.tokens.display().to_string();
    let text = std::fs::read_to_string(&args.tokens).or_invalid(&format!("tokens file {origin}"))?;
    let tokens = Tokens::from_toml(&origin, &text).map_err(invalid)?;
    let c = &args.connection;
    let nats_token = nats_token(c.nats_token_file.as_ref())?;
    let client = service::connect(&c.nats, nats_token.as_ref(), Duration::from_secs(c.connect_timeout_s)).await?;
    let scheduler = Scheduler::start(client, ctx.files().clone(), &c.store, tokens).await?;
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
