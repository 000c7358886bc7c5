//! `plumbline run MANIFEST`: a whole campaign in one process — the scheduler's loading and planning, the
//! workers' tiles through an in-process queue (rayon inside each tile), the adjuster's global adjustment
//! and outputs. The same library code the distributed services run; only the queue differs.
//!
//! Resuming: every finished tile is written to `{output}tiles/`; a re-run reuses them when the campaign
//! (manifest and plan) is unchanged, recorded in `{output}run.json`. `--fresh` reprocesses every tile.

use std::io::IsTerminal as _;
use std::process::ExitCode;
use std::sync::Arc;

use clap::Args as ClapArgs;
use futures::StreamExt as _;
use plumbline_adjuster::{AdjusterConfig, Finished, finish};
use plumbline_campaign::progress::Progress;
use plumbline_campaign::{Campaign, SkipReason, SkippedInput, Stage};
use plumbline_geo::tiling::TileId;
use plumbline_runtime::Files;
use plumbline_runtime::progress::{ProgressStyle, reporter};
use plumbline_scheduler::load_campaign;
use plumbline_worker::{TileOutput, TileOutputV1, WorkerConfig, process_tile_reporting, run_tile_reporting, tile_key};
use serde::{Deserialize, Serialize};

use crate::exit::NO_CONTROL;
use crate::io::Context;

/// Arguments of `run`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// The campaign manifest (TOML, or JSON when it ends in `.json`), by path or URL.
    pub manifest: String,
    /// Reprocess every tile even when its result from an earlier run exists.
    #[arg(long)]
    pub fresh: bool,
    /// Tiles processed at once (each tile already uses every core; more overlaps reading with computing).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u16).range(1..=64))]
    pub jobs: u16,
    /// No progress output (errors and the final summary only).
    #[arg(long)]
    pub quiet: bool,
    /// Progress as JSON lines on stderr.
    #[arg(long, conflicts_with = "quiet")]
    pub json: bool,
    /// Exit with code 4 when a named input gave no control (a cadastre with no pole update, an aerial
    /// reference no panorama matched, point clouds); without it such inputs are warnings.
    #[arg(long)]
    pub strict: bool,
}

/// What a finished run leaves in the output prefix to recognise its tiles on a re-run.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct RunStamp {
    /// Digest of the manifest's bytes and the plan.
    campaign: String,
}

/// Run `run`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let style = ProgressStyle::choose(args.quiet, args.json, std::io::stderr().is_terminal());
    let progress = reporter(style);
    let outcome = run_campaign(ctx.files(), &args.manifest, args.fresh, usize::from(args.jobs), progress).await?;
    print_summary(&outcome);
    let warnings = &outcome.finished.report.warnings;
    if warnings.is_empty() {
        return Ok(ExitCode::SUCCESS);
    }
    let n = warnings.len();
    eprintln!("warning: {n} named input(s) gave no control; the trajectory was corrected without them:");
    for w in warnings {
        eprintln!("  {w}");
    }
    if args.strict {
        eprintln!("--strict: exit code {NO_CONTROL}");
        return Ok(ExitCode::from(NO_CONTROL));
    }
    Ok(ExitCode::SUCCESS)
}

/// The result of a whole campaign run.
#[derive(Debug)]
pub struct Outcome {
    /// The campaign as loaded.
    pub campaign: Campaign,
    /// What the adjuster wrote and measured.
    pub finished: Finished,
    /// Tiles reused from an earlier run.
    pub resumed: usize,
}

/// Load, plan, process every tile, adjust and write the outputs.
pub async fn run_campaign(
    files: &Files,
    manifest: &str,
    fresh: bool,
    jobs: usize,
    progress: Arc<dyn Progress>,
) -> anyhow::Result<Outcome> {
    progress.begin(Stage::Load, None);
    let mut campaign = load_campaign(files, manifest).await?;
    progress
        .note(Stage::Load, &format!("{} panoramas in {} tiles", campaign.plan.panoramas.len(), tiles(&campaign).len()));
    progress.end(Stage::Load);
    let plan_json = campaign.plan.to_json();
    files.write(&format!("{}plan.json", campaign.output), plan_json.clone()).await?;
    let stamp = RunStamp { campaign: digest(&[&files.read(manifest).await?, &plan_json]) };
    let stamp_url = format!("{}run.json", campaign.output);
    let reuse = !fresh && previous_stamp(files, &stamp_url).await.as_ref() == Some(&stamp);
    if !fresh && !reuse {
        tracing::info!("no finished tiles of this campaign in {}: processing every tile", campaign.output);
    }
    files.write(&stamp_url, serde_json::to_vec_pretty(&stamp)?).await?;

    let config = WorkerConfig::from_manifest(&campaign.manifest);
    let ids = tiles(&campaign);
    progress.begin(Stage::Tiles, Some(ids.len() as u64));
    let plan = campaign.plan.tiles.tiles();
    progress.begin(Stage::Registration, Some(plan.iter().map(|t| t.owned.len() as u64).sum()));
    progress.begin(Stage::Poles, Some(plan.iter().map(|t| campaign.plan.depth_of(&t.id).len() as u64).sum()));
    let (outputs, resumed, failed) = process_tiles(files, &campaign, &ids, &config, reuse, jobs, &*progress).await?;
    progress.end(Stage::Registration);
    progress.end(Stage::Poles);
    progress.end(Stage::Tiles);
    campaign.skipped.extend(failed);
    if outputs.is_empty() {
        anyhow::bail!(
            "no tile of {} could be processed (see the errors above)",
            campaign.manifest.campaign.id.as_str()
        );
    }
    let finished =
        finish(files, &campaign, &outputs, &AdjusterConfig::from_manifest(&campaign.manifest), &*progress).await?;
    Ok(Outcome { campaign, finished, resumed })
}

/// Every tile through the in-process queue, `jobs` at a time. A tile that fails on something other than
/// invalid campaign input is listed as skipped and the others go on.
async fn process_tiles(
    files: &Files,
    campaign: &Campaign,
    ids: &[TileId],
    config: &WorkerConfig,
    reuse: bool,
    jobs: usize,
    progress: &dyn Progress,
) -> anyhow::Result<(Vec<TileOutputV1>, usize, Vec<SkippedInput>)> {
    let mut queue = futures::stream::iter(ids.iter().copied())
        .map(|tile| async move {
            let result = if reuse {
                run_tile_reporting(files, campaign, &tile, config, progress).await.map_err(anyhow::Error::from)
            } else {
                match process_tile_reporting(files, campaign, &tile, config, progress).await {
                    Ok(out) => write_tile(files, campaign, out).await,
                    Err(e) => Err(e.into()),
                }
            };
            (tile, result)
        })
        .buffer_unordered(jobs.max(1));
    let (mut outputs, mut resumed, mut failed) = (Vec::new(), 0, Vec::new());
    let (mut matched, mut pole_matches) = (0, 0);
    while let Some((tile, result)) = queue.next().await {
        match result {
            Ok((output, was_resumed)) => {
                resumed += usize::from(was_resumed);
                matched += output.registration.as_ref().map_or(0, |r| r.summary.images_matched);
                pole_matches += output.poles.len();
                progress.note(Stage::Registration, &format!("{matched} matched with the aerial images"));
                progress.note(Stage::Poles, &format!("{pole_matches} pole matches"));
                outputs.push(output);
                progress.advance(Stage::Tiles, 1);
            }
            Err(e) if crate::exit::is_invalid(&e) => return Err(e.context(format!("tile {tile}"))),
            Err(e) => {
                tracing::error!(%tile, error = %format!("{e:#}"), "tile failed; the campaign goes on without it");
                let detail = format!("tile {tile}: {e:#}");
                failed.push(SkippedInput::new(Stage::Tiles, format!("tile {tile}"), SkipReason::Failed, detail));
                progress.skip(Stage::Tiles, 1);
            }
        }
    }
    outputs.sort_by_key(|o| o.tile);
    Ok((outputs, resumed, failed))
}

/// Store a freshly processed tile (what `run_tile_reporting` would have written).
async fn write_tile(files: &Files, campaign: &Campaign, out: TileOutputV1) -> anyhow::Result<(TileOutputV1, bool)> {
    let url = format!("{}{}", campaign.output, tile_key(&out.tile));
    let doc = TileOutput::V1(out);
    files.write(&url, serde_json::to_vec_pretty(&doc)?).await?;
    Ok((doc.into_latest(), false))
}

fn tiles(campaign: &Campaign) -> Vec<TileId> {
    campaign.plan.tiles.tiles().iter().map(|t| t.id).collect()
}

async fn previous_stamp(files: &Files, url: &str) -> Option<RunStamp> {
    match files.exists(url).await {
        Ok(true) => serde_json::from_slice(&files.read(url).await.ok()?).ok(),
        _ => None,
    }
}

/// FNV-1a over the parts (stable across builds and platforms; a changed input only costs a re-run).
fn digest(parts: &[&[u8]]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for &b in part.iter().chain(&[0xff]) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    format!("{h:016x}")
}

/// The before/after table and where the outputs are.
pub fn print_summary(outcome: &Outcome) {
    let report = &outcome.finished.report;
    let s = &report.summary;
    println!(
        "campaign {}: {} epochs, {:.0} m; {} of {} panoramas matched, {} tie points, {} pole updates, max correction {:.2} m",
        report.campaign.id,
        s.epochs,
        s.length_m,
        s.images_matched,
        s.images,
        s.ties,
        s.pole_updates,
        s.max_correction_m
    );
    if outcome.resumed > 0 {
        println!("{} tile(s) reused from an earlier run", outcome.resumed);
    }
    for w in &report.warnings {
        println!("WARNING no control from {w}");
    }
    if !report.skipped.is_empty() {
        println!("{} input item(s) skipped (listed in the report):", report.skipped.len());
        for (stage, reason, n) in report.skipped_by_reason().iter().take(8) {
            println!("  {stage:<12} {reason:<28} {n}");
        }
    }
    if !report.road_lines.is_empty() {
        let kinds: Vec<String> =
            report.road_lines.iter().map(|k| format!("{} {} ({:.0} m)", k.lines, k.kind, k.length_m)).collect();
        println!("road lines: {} (layer road_lines of observations.gpkg)", kinds.join(", "));
        if let Some(p) = &report.road_line_panoramas {
            println!(
                "  from {} panorama(s); skipped: {} without strokes (no paint in view or kept), {} unplaced",
                p.with_strokes, p.without_strokes, p.unplaced
            );
        }
    }
    match &report.accuracy {
        Some(acc) => print!("\n{}", acc.table()),
        None => println!("no reference trajectory in the manifest: no before/after table"),
    }
    println!("\nreport: {}report.html", outcome.campaign.output);
}
