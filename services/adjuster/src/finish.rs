//! The async end of a campaign run: merge the tiles, adjust, and write the outputs under the campaign's
//! output prefix — the corrected trajectory in the input's format, `corrections.csv`, `observations.gpkg`
//! (with the road lines), `report.json` and `report.html`. The CPU work runs on the blocking pool.

use std::collections::BTreeMap;

use futures::StreamExt as _;
use plumbline_adjustment::Iteration;
use plumbline_campaign::Campaign;
use plumbline_campaign::progress::Progress;
use plumbline_report::{Figures, Report, StageLine};
use plumbline_runtime::trajectory::write_like_input;
use plumbline_runtime::{Context as _, Files};
use plumbline_worker::TileOutputV1;

use crate::config::AdjusterConfig;
use crate::corrections::corrections_csv;
use crate::join::join_shared_points;
use crate::layers::observation_layers;
use crate::lines::{RoadLines, fill_report, ground_below_body, line_layers, road_lines};
use crate::merge::{Merged, merge};
use crate::report::build_report;
use crate::solve::{Solved, panorama_mount, solve_observed};
use plumbline_runtime::gdal_write::geopackage_with_lines;

/// The progress stage of the adjustment.
pub const STAGE: plumbline_campaign::Stage = plumbline_campaign::Stage::Adjustment;

/// What [`finish`] produced.
#[derive(Clone, Debug)]
pub struct Finished {
    /// The report (also written as `report.json` and `report.html`).
    pub report: Report,
    /// The files written, in order.
    pub written: Vec<String>,
    /// DG against the reference, when there is one.
    pub before: Option<Figures>,
    /// Corrected against the reference, when there is one.
    pub after: Option<Figures>,
    /// The road lines (also in `observations.gpkg` and on the report's map).
    pub road_lines: RoadLines,
}

/// Everything computed off the async runtime.
struct Computed {
    solved: Solved,
    road_lines: RoadLines,
    report: Report,
    corrections: Vec<u8>,
    geopackage: Vec<u8>,
    html: String,
}

/// Merge `tiles`, adjust the campaign's trajectory, and write its outputs under `campaign.output`.
pub async fn finish(
    files: &Files,
    campaign: &Campaign,
    tiles: &[TileOutputV1],
    config: &AdjusterConfig,
    progress: &dyn Progress,
) -> plumbline_runtime::Result<Finished> {
    progress.begin(STAGE, None);
    let (owned, tiles, config) = (campaign.clone(), tiles.to_vec(), *config);
    let (sender, mut iterations) = futures::channel::mpsc::unbounded::<Iteration>();
    let count = i64::try_from(tiles.len()).unwrap_or(i64::MAX);
    let span = tracing::info_span!("stage", stage = STAGE.name(), tiles = count);
    let task = tokio::task::spawn_blocking(move || {
        let _entered = span.enter();
        // Sending fails only when `finish` was dropped: then nobody listens any more.
        compute(&owned, &tiles, &config, &mut |it| {
            let _ = sender.unbounded_send(*it);
        })
    });
    while let Some(it) = iterations.next().await {
        progress.note(STAGE, &it.note());
        progress.advance(STAGE, 1);
    }
    let computed = task.await.context("adjustment task")??;
    let a = &computed.solved.adjustment;
    let note = format!("{} iterations, σ0 {:.3}, {} rejected", a.iterations, a.sigma0, a.rejected.len());
    progress.note(STAGE, &note);
    progress.end(STAGE);
    for b in &a.height_biases {
        let frames = b.frames.join("+");
        tracing::info!(frames, points = b.points, bias = b.bias, sigma = b.sigma, "aerial height bias");
    }
    tracing::info!(iterations = a.iterations, sigma0 = a.sigma0, rejected = a.rejected.len(), "adjusted");

    let prefix = &campaign.output;
    let mut written =
        write_like_input(files, prefix, "trajectory", &campaign.trajectory, &computed.solved.corrected).await?;
    let outputs = [
        ("corrections.csv", computed.corrections),
        ("observations.gpkg", computed.geopackage),
        ("report.json", computed.report.to_json()),
        ("report.html", computed.html.into_bytes()),
    ];
    for (name, bytes) in outputs {
        let url = format!("{prefix}{name}");
        files.write(&url, bytes).await?;
        written.push(url);
    }
    let accuracy = computed.report.accuracy.as_ref();
    let (before, after) = (accuracy.map(|a| a.before), accuracy.map(|a| a.after));
    Ok(Finished { report: computed.report, written, before, after, road_lines: computed.road_lines })
}

fn compute(
    campaign: &Campaign,
    tiles: &[TileOutputV1],
    config: &AdjusterConfig,
    observer: &mut dyn FnMut(&Iteration),
) -> plumbline_runtime::Result<Computed> {
    let mut merged = merge(tiles);
    let joined = join_shared_points(&mut merged);
    tracing::info!(joined, ties = merged.observations.ties.len(), "tie points sharing an image point joined");
    let mount = panorama_mount(&campaign.manifest);
    let solved = solve_observed(&campaign.trajectory.trajectory, &merged, &mount, config, observer)
        .with_context(|| format!("adjusting campaign {}", campaign.manifest.campaign.id))?;
    let stages = stages(tiles, &merged, &solved);
    let mut report = build_report(campaign, &merged, &solved, campaign.reference.as_ref(), &stages);
    let depth = ground_below_body(&campaign.manifest);
    let road_lines = road_lines(&campaign.trajectory.trajectory, &merged, &solved, depth);
    let (pieces, lines) = (road_lines.corrected.pieces.len(), road_lines.corrected.lines.len());
    tracing::info!(panoramas = road_lines.panoramas, strokes = road_lines.strokes, pieces, lines, "road lines");
    fill_report(&mut report, &road_lines);
    let layers = observation_layers(campaign, &merged, &solved);
    let geopackage = geopackage_with_lines(&layers, &line_layers(&road_lines), Some(campaign.epsg()))
        .context("encoding observations.gpkg")?;
    let corrections = corrections_csv(&campaign.trajectory.trajectory, &solved.corrected);
    let html = plumbline_report::html::render(&report);
    Ok(Computed { solved, road_lines, report, corrections, geopackage, html })
}

/// The tiles' stages (seconds summed over tiles, tiles that ran them, items skipped in them) and the
/// adjustment (observations it skipped).
pub fn stages(tiles: &[TileOutputV1], merged: &Merged, solved: &Solved) -> Vec<StageLine> {
    let mut by_name: BTreeMap<&str, StageLine> = BTreeMap::new();
    for t in tiles {
        for (name, seconds) in &t.seconds {
            let s = by_name
                .entry(name.as_str())
                .or_insert_with(|| StageLine { name: name.clone(), ..StageLine::default() });
            s.done += 1;
            s.seconds += seconds;
        }
    }
    for s in by_name.values_mut() {
        s.total = tiles.len();
        s.skipped = merged.skipped.iter().filter(|k| k.stage.name() == s.name).count();
    }
    let mut out: Vec<StageLine> = by_name.into_values().collect();
    out.push(StageLine {
        name: STAGE.name().to_owned(),
        done: 1,
        total: 1,
        skipped: solved.adjustment.skipped.len(),
        seconds: solved.seconds,
    });
    out
}
