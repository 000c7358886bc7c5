//! The `plumbline` command-line tool: run campaigns (`run`, `demo`), validate manifests, simulate, and the
//! tools for trajectories, matching, cadastres, adjustment and navigation.
//!
//! ```text
//! plumbline run MANIFEST (one process; `serve` splits the same steps over scheduler, workers, adjuster):
//!   plumbline_scheduler::load_campaign → Campaign (manifest, trajectory, tables, tile plan)
//!   per tile, on a bounded pool: plumbline_worker::run_tile → {output}tiles/{col}_{row}.json (resumable)
//!   plumbline_adjuster::finish → corrected trajectory, corrections.csv, observations.gpkg, report
//! plumbline demo = simulate (a synthetic campaign with its truth) + run + the table against the truth
//! ```
//!
//! Exit codes: 0 success, 1 failure while working (I/O, store, internal; `match` finding no reliable
//! transform), 2 invalid input (a bad manifest, a malformed or implausible trajectory, an unknown CRS, a bad
//! argument, an image over its pixel budget).

mod adjust;
mod cadastre;
mod demo;
mod exit;
mod io;
mod lines;
mod matching;
mod navigate;
mod poles;
mod run;
mod serve;
mod simulate;
mod status;
mod submit;
mod trajectory;
mod validate;

use std::collections::HashMap;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Corrects mobile-mapping trajectories in cities with aerial images and pole cadastres.
#[derive(Debug, Parser)]
#[command(name = "plumbline", version, about, long_about = None)]
struct Cli {
    /// Runtime config file (TOML: store credentials, logging). PLUMBLINE_* environment variables override it.
    #[arg(long, global = true, value_name = "FILE")]
    config: Option<PathBuf>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a small campaign with ground truth and run it: the before/after table and a report.
    Demo(demo::Args),
    /// Run a whole campaign in one process: register, match poles, adjust, write the corrected trajectory,
    /// observations.gpkg and the report (resumes from finished tiles).
    Run(run::Args),
    /// Check a campaign manifest and list every problem found (exit code 2 when invalid).
    Validate(validate::Args),
    /// Trajectory tools: format and CRS conversion, comparison against a reference.
    #[command(subcommand)]
    Trajectory(trajectory::Command),
    /// Write a synthetic campaign with ground truth (trajectories, raw GNSS/IMU, DG errors, manifest).
    Simulate(simulate::Args),
    /// Register two images (AKAZE + RANSAC) and print the transform A → B pixels, inliers and residuals as JSON.
    Match(matching::Args),
    /// Cadastre tools: inspect a GeoPackage's layers, CRS, classes and problems.
    #[command(subcommand)]
    Cadastre(cadastre::Command),
    /// Adjust a DG trajectory with observation sets (poles, tie points, GNSS); write it corrected.
    Adjust(adjust::Args),
    /// Fuse raw GNSS and IMU (Kalman filter + RTS smoother) with integrity tests; write the smoothed trajectory.
    Navigate(navigate::Args),
    /// Road-line tools: export a run's road lines (GeoPackage, GeoJSON), compare them with a marking layer.
    #[command(subcommand)]
    Lines(lines::Command),
    /// Pole tools: detect poles and tree trunks in static LAS/LAZ clouds.
    #[command(subcommand)]
    Poles(poles::Command),
    /// Run a service of the distributed path (NATS JetStream + object store).
    #[command(subcommand)]
    Serve(serve::Command),
    /// Submit a campaign manifest to a scheduler's job API; prints the campaign id.
    Submit(submit::Args),
    /// Show a submitted campaign's state; --watch follows it with progress bars until it ends.
    Status(status::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let env: HashMap<String, String> = std::env::vars().collect();
    let ctx = match io::Context::load(cli.config.as_deref(), &env, service_name(&cli.command)) {
        Ok(ctx) => ctx,
        Err(e) => return report(&e),
    };
    let runtime = match tokio::runtime::Builder::new_multi_thread().enable_all().build() {
        Ok(rt) => rt,
        Err(e) => return report(&anyhow::anyhow!("cannot start the async runtime: {e}")),
    };
    let result = runtime.block_on(async {
        match cli.command {
            Command::Demo(args) => demo::run(&ctx, args).await,
            Command::Run(args) => run::run(&ctx, args).await,
            Command::Validate(args) => validate::run(&ctx, args).await,
            Command::Trajectory(cmd) => trajectory::run(&ctx, cmd).await,
            Command::Simulate(args) => simulate::run(&ctx, args).await,
            Command::Match(args) => matching::run(&ctx, args).await,
            Command::Cadastre(cmd) => cadastre::run(&ctx, cmd).await,
            Command::Adjust(args) => adjust::run(&ctx, args).await,
            Command::Navigate(args) => navigate::run(&ctx, args).await,
            Command::Lines(cmd) => lines::run(&ctx, cmd).await,
            Command::Poles(cmd) => poles::run(&ctx, cmd).await,
            Command::Serve(cmd) => serve::run(&ctx, cmd).await,
            Command::Submit(args) => submit::run(&ctx, args).await,
            Command::Status(args) => status::run(&ctx, args).await,
        }
    });
    match result {
        Ok(code) => code,
        Err(e) => report(&e),
    }
}

/// The OpenTelemetry `service.name` spans are exported under: the role for `serve`, else the command.
fn service_name(command: &Command) -> &'static str {
    match command {
        Command::Serve(serve::Command::Scheduler(_)) => "plumbline-scheduler",
        Command::Serve(serve::Command::Worker(_)) => "plumbline-worker",
        Command::Serve(serve::Command::Adjuster(_)) => "plumbline-adjuster",
        Command::Run(_) => "plumbline-run",
        Command::Demo(_) => "plumbline-demo",
        _ => "plumbline-cli",
    }
}

/// Print an error chain and pick the exit code from its kind.
fn report(e: &anyhow::Error) -> ExitCode {
    eprintln!("error: {e}");
    for cause in e.chain().skip(1) {
        eprintln!("  caused by: {cause}");
    }
    if exit::is_invalid(e) { ExitCode::from(exit::INVALID) } else { ExitCode::FAILURE }
}
