//! `plumbline validate`: parse a campaign manifest, list every problem, and check what needs the outside
//! world (the CRS exists in PROJ and is projected, the named inputs exist).

use std::process::ExitCode;

use clap::Args as ClapArgs;
use plumbline_campaign::{ManifestV1, Problem};

use crate::exit::INVALID;
use crate::io::{Context, file_name};

/// Arguments of `validate`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// The manifest (TOML, or JSON when it ends in `.json`), by path or URL.
    pub manifest: String,
    /// Only check the manifest itself: do not open the input files it names.
    #[arg(long)]
    pub offline: bool,
}

/// Run `validate`: the manifest's own checks, then (unless `--offline`) every named input opened cheaply
/// (headers, schemas, the first image of each index). Every problem at once; exit code 2 when any.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let name = file_name(&args.manifest).to_owned();
    let manifest = plumbline_scheduler::parse_manifest(&name, &ctx.read(&args.manifest).await?)?;
    let mut problems: Vec<String> = match manifest.validate() {
        Ok(_) => Vec::new(),
        Err(problems) => problems.iter().map(Problem::to_string).collect(),
    };
    let latest = manifest.into_latest();
    if !problems.iter().any(|p| p.starts_with("crs:")) {
        problems.extend(crs_problems(&latest));
    }
    let mut unchecked = Vec::new();
    let mut warnings = Vec::new();
    if !args.offline {
        missing_inputs(ctx, &args.manifest, &latest, &mut problems, &mut unchecked).await;
        if problems.is_empty() && unchecked.is_empty() {
            let found = plumbline_scheduler::check_inputs(ctx.files(), &args.manifest, &latest).await;
            problems.extend(found.problems);
            warnings.extend(found.warnings);
        }
    }
    for w in unchecked.iter().chain(&warnings) {
        eprintln!("warning: {w}");
    }
    if !problems.is_empty() {
        eprintln!("{name}: {} problem{}", problems.len(), if problems.len() == 1 { "" } else { "s" });
        for p in &problems {
            eprintln!("  {p}");
        }
        return Ok(ExitCode::from(INVALID));
    }
    if !unchecked.is_empty() {
        anyhow::bail!(
            "{name}: {} input(s) could not be checked (see the warnings; --offline skips the check)",
            unchecked.len()
        );
    }
    let opened = if args.offline { "inputs not opened (--offline)" } else { "every named input opened" };
    let warned = match warnings.len() {
        0 => String::new(),
        n => format!(", {n} warning(s)"),
    };
    println!("{name}: valid (campaign `{}`, EPSG:{}; {opened}{warned})", latest.campaign.id.as_str(), latest.crs.0);
    Ok(ExitCode::SUCCESS)
}

/// The campaign CRS must exist in PROJ and be projected; trajectory CRS overrides must exist.
fn crs_problems(m: &ManifestV1) -> Vec<String> {
    let mut out = Vec::new();
    match plumbline_runtime::is_projected(m.crs.0) {
        Ok(true) => {}
        Ok(false) => {
            out.push(format!("crs: EPSG:{} is not a projected CRS; expected a projected CRS (metres)", m.crs.0))
        }
        Err(e) => out.push(format!("crs: {e}; expected an EPSG code known to PROJ")),
    }
    for (i, t) in m.trajectory.iter().enumerate() {
        if let Some(epsg) = t.epsg()
            && let Err(e) = plumbline_runtime::crs_name(epsg.0)
        {
            out.push(format!("trajectory[{i}].epsg: {e}; expected an EPSG code known to PROJ"));
        }
    }
    out
}

/// Report every input the manifest names that does not exist (a problem) or cannot be reached (unchecked),
/// each resolved against the manifest's location.
async fn missing_inputs(
    ctx: &Context,
    manifest_url: &str,
    m: &ManifestV1,
    problems: &mut Vec<String>,
    unchecked: &mut Vec<String>,
) {
    let base = plumbline_scheduler::manifest_base(manifest_url);
    for (path, location) in m.input_locations() {
        let Ok(url) = plumbline_campaign::resolve(&base, location.as_str()) else {
            continue; // the manifest's own validation already names the bad location
        };
        match ctx.exists(&url).await {
            Ok(true) => {}
            Ok(false) => problems.push(format!("{path}: `{url}` does not exist; expected an existing file")),
            Err(e) => unchecked.push(format!("{path}: `{url}` could not be checked: {}", root_cause(&e))),
        }
    }
}

fn root_cause(e: &anyhow::Error) -> String {
    e.chain().last().map_or_else(|| e.to_string(), ToString::to_string)
}
