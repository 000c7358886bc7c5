//! `plumbline cadastre inspect`: what a cadastre GeoPackage holds (layers, geometry types, CRS, fields, class
//! values) and the problems reading it would meet. A report: exit 0 even when problems are found, 2 when the
//! file is missing or cannot be opened as a GeoPackage.

use std::fmt::Write as _;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, Subcommand};
use plumbline_campaign::count_diagnostics;
use plumbline_runtime::cadastre::{CadastreInspection, CadastreSource, LayerInspection, inspect_cadastre};

use crate::exit::invalid;
use crate::io::Context;

/// Problems listed one by one in the text report; `--json` has them all.
const MAX_LISTED_PROBLEMS: usize = 50;

/// Cadastre tools.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Print a GeoPackage's layers, feature counts by geometry type, CRS, fields, class values and problems.
    Inspect(InspectArgs),
}

/// Arguments of `cadastre inspect`.
#[derive(Debug, ClapArgs)]
pub struct InspectArgs {
    /// The GeoPackage, by path or URL.
    pub file: String,
    /// The attribute holding the class; without it, text fields named like class/type/art are summarised.
    #[arg(long, value_name = "FIELD")]
    pub class_attribute: Option<String>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Run a `cadastre` command.
pub async fn run(ctx: &Context, command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Inspect(args) => inspect(ctx, args).await,
    }
}

async fn inspect(ctx: &Context, args: InspectArgs) -> anyhow::Result<ExitCode> {
    let bytes = ctx.read(&args.file).await?;
    let (name, class_attribute) = (args.file.clone(), args.class_attribute.clone());
    // GDAL work is blocking.
    let report = tokio::task::spawn_blocking(move || {
        inspect_cadastre(CadastreSource::Bytes { name: &name, bytes: &bytes }, class_attribute.as_deref())
    })
    .await
    .context("the inspection task failed")?;
    let report = match report {
        Ok(report) => report,
        Err(e) if e.is_file_problem() => return Err(invalid(e.to_string())),
        Err(e) => return Err(e.into()),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", text(&report));
    }
    Ok(ExitCode::SUCCESS)
}

/// The human-readable report.
fn text(report: &CadastreInspection) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{}: {} layer(s), {} problem(s)", report.file, report.layers.len(), report.diagnostics.len());
    for layer in &report.layers {
        layer_text(&mut out, layer);
    }
    if !report.diagnostics.is_empty() {
        let counts = count_diagnostics(&report.diagnostics);
        let counts: Vec<String> = counts.iter().map(|(kind, n)| format!("{kind:?} {n}")).collect();
        let _ = writeln!(out, "problems: {}", counts.join(", "));
        for d in report.diagnostics.iter().take(MAX_LISTED_PROBLEMS) {
            let _ = writeln!(out, "  {d}");
        }
        if report.diagnostics.len() > MAX_LISTED_PROBLEMS {
            let _ = writeln!(out, "  … and {} more (--json lists all)", report.diagnostics.len() - MAX_LISTED_PROBLEMS);
        }
    }
    out
}

fn layer_text(out: &mut String, layer: &LayerInspection) {
    let crs = match (&layer.crs.epsg, &layer.crs.name) {
        (Some(epsg), Some(name)) => format!("CRS EPSG:{epsg} ({name})"),
        (None, Some(name)) => format!("CRS {name} (no EPSG code)"),
        _ => "no CRS".to_owned(),
    };
    let _ = writeln!(out, "layer {}: {} feature(s), {crs}", layer.name, layer.feature_count);
    let geometries: Vec<String> = layer.geometry_counts.iter().map(|(t, n)| format!("{t} {n}")).collect();
    let _ = writeln!(out, "  geometry: {}", geometries.join(", "));
    let fields: Vec<String> = layer.fields.iter().map(|f| format!("{} ({})", f.name, f.type_name)).collect();
    let _ = writeln!(out, "  fields: {}", fields.join(", "));
    for class in &layer.class_values {
        let values: Vec<String> = class.values.iter().map(|(v, n)| format!("{v:?} {n}")).collect();
        let _ = write!(out, "  class values of {}: {}", class.field, values.join(", "));
        let _ = writeln!(
            out,
            "; null {}{}",
            class.nulls,
            if class.other > 0 { format!("; other {}", class.other) } else { String::new() }
        );
    }
}
