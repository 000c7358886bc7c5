//! `plumbline adjust`: the global trajectory adjustment run standalone — a DG trajectory (CSV or SBET) and
//! observation sets (JSON, `schemas/observations.v1.schema.json`) in, the corrected full-rate trajectory in
//! the input's format, per-epoch corrections with posterior σ (CSV) and a summary (JSON) out.
//!
//! Layout under `--out`: `trajectory.csv` or `trajectory.sbet` + `trajectory.smrmsg` (the input's format
//! and CRS), `corrections.csv`, `summary.json`.

mod input;
mod output;

use std::process::ExitCode;

use anyhow::Context as _;
use clap::Args as ClapArgs;
use plumbline_adjustment::{AdjustmentConfig, AdjustmentInput, adjust};
use plumbline_geo::dg::{Boresight, CameraMount};

use crate::exit::OrInvalid;
use crate::io::Context;
use crate::trajectory::Format;

/// Arguments of `adjust`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// The DG trajectory (CSV or SBET), by path or URL.
    #[arg(long, value_name = "PATH|URL")]
    pub trajectory: String,
    /// Format of the trajectory (default: from the extension; `.sbet`/`.out` are SBET, anything else CSV).
    #[arg(long = "from", value_enum)]
    pub format: Option<Format>,
    /// Applanix smrmsg file with the standard deviations of an SBET trajectory.
    #[arg(long, value_name = "PATH|URL")]
    pub smrmsg: Option<String>,
    /// EPSG code of the projected CRS the observations are in (the campaign CRS). Required for SBET and
    /// geographic CSV; a projected CSV is taken to be in it already.
    #[arg(long, value_name = "EPSG")]
    pub epsg: Option<u32>,
    /// Observation sets (JSON, version 1); their observations are adjusted together.
    #[arg(long, value_name = "PATH|URL", num_args = 1.., required = true)]
    pub observations: Vec<String>,
    /// Intervals whose DG relative constraints are weakened (JSON list of {start, end, factor}), e.g. the
    /// consistency check's flags.
    #[arg(long, value_name = "PATH|URL")]
    pub weak_links: Option<String>,
    /// Panorama camera lever arm in the body frame (x forward, y right, z down), metres: X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = triple, default_value = "0,0,0")]
    pub camera_lever_arm: [f64; 3],
    /// Panorama camera boresight misalignment (roll, pitch, yaw), degrees: R,P,Y.
    #[arg(long, value_name = "R,P,Y", value_parser = triple, default_value = "0,0,0")]
    pub camera_boresight: [f64; 3],
    /// Extra correction nodes every this many seconds besides the observation epochs.
    #[arg(long, value_name = "SECONDS")]
    pub node_spacing: Option<f64>,
    /// Directory or object-store prefix for the results.
    #[arg(long, value_name = "DIR|URL")]
    pub out: String,
}

/// Parse "a,b,c" into three finite numbers.
pub(crate) fn triple(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("`{v}`: {e}")))
        .collect::<Result<_, _>>()?;
    match values.as_slice() {
        [a, b, c] if values.iter().all(|v| v.is_finite()) => Ok([*a, *b, *c]),
        _ => Err(format!("expected three finite comma-separated numbers, got `{text}`")),
    }
}

/// Run `adjust`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    if args.node_spacing.is_some_and(|s| !(s.is_finite() && s > 0.0)) {
        return Err(crate::exit::invalid("--node-spacing must be a finite number of seconds > 0"));
    }
    let loaded = input::trajectory(ctx, &args).await?;
    let observations = input::observations(ctx, &args.observations).await?;
    let weak_links = match &args.weak_links {
        Some(url) => input::weak_links(ctx, url).await?,
        None => Vec::new(),
    };
    let [r, p, y] = args.camera_boresight;
    let mount = CameraMount::new(args.camera_lever_arm, &Boresight::from_degrees(r, p, y));
    let config = AdjustmentConfig { node_spacing: args.node_spacing, ..AdjustmentConfig::default() };
    let trajectory = loaded.trajectory.clone();
    let set = observations.set.clone();
    let links = weak_links.clone();
    let (result, corrected) = tokio::task::spawn_blocking(move || -> anyhow::Result<_> {
        let input = AdjustmentInput { trajectory: &trajectory, observations: &set, mount: &mount, weak_links: &links };
        let result = adjust(&input, &config, faer::Par::rayon(0)).context("adjustment")?;
        let corrected = result.apply(&trajectory).or_invalid("corrected trajectory")?;
        Ok((result, corrected))
    })
    .await
    .context("adjustment task")??;
    for s in &result.skipped {
        tracing::warn!(observation = %observations.describe(&s.item), field = s.field, problem = %s.problem, "skipped");
    }
    let prefix = if args.out.ends_with('/') { args.out.clone() } else { format!("{}/", args.out) };
    let written = output::trajectory(ctx, &prefix, &loaded, &corrected).await?;
    ctx.write(&format!("{prefix}corrections.csv"), plumbline_adjuster::corrections_csv(&loaded.trajectory, &corrected))
        .await?;
    let summary = output::summary(&result, &observations, &weak_links, &loaded, &written);
    ctx.write(&format!("{prefix}summary.json"), serde_json::to_vec_pretty(&summary)?).await?;
    eprintln!(
        "adjusted {} records with {} observations: {} iterations, sigma0 {:.3}, {} rejected, {} skipped",
        corrected.len(),
        observations.count(),
        result.iterations,
        result.sigma0,
        result.rejected.len(),
        result.skipped.len()
    );
    println!("{prefix}summary.json");
    Ok(ExitCode::SUCCESS)
}
