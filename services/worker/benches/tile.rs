//! Time `process_tile` on every tile of a campaign and print a table: panoramas, matches, ties, pole updates
//! and seconds per tile and per stage.
//!
//! `cargo bench -p plumbline-worker --bench tile -- CAMPAIGN.toml`, e.g. on a
//! campaign from `plumbline simulate --preset tiny --out /tmp/camp` (or with `--panorama-width 4096`). Tiles
//! run one after the other, each using every core inside; the last line gives the process's peak RSS.

use std::time::Instant;

use plumbline_runtime::Files;
use plumbline_scheduler::load_campaign;
use plumbline_worker::{WorkerConfig, process_tile};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let Some(manifest) = args.first() else {
        eprintln!("usage: cargo bench -p plumbline-worker --bench tile -- CAMPAIGN.toml");
        return Ok(());
    };
    let runtime = tokio::runtime::Runtime::new()?;
    runtime.block_on(run(manifest))
}

async fn run(manifest: &str) -> anyhow::Result<()> {
    let files = Files::default();
    let t0 = Instant::now();
    let campaign = load_campaign(&files, manifest).await?;
    println!("campaign loaded and planned in {:.2} s", t0.elapsed().as_secs_f64());
    let config = WorkerConfig::from_manifest(&campaign.manifest);
    println!(
        "| tile | owned | context | depth | matched / images | ties | with aerial | pole updates | skipped | wall s | \
         read | decode | ortho | features | prepare | matching | aerial | registration | poles |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let (mut owned, mut matched, mut wall) = (0, 0, 0.0);
    for tile in campaign.plan.tiles.tiles() {
        let start = Instant::now();
        let out = process_tile(&files, &campaign, &tile.id, &config).await?;
        let seconds = start.elapsed().as_secs_f64();
        let stage = |name: &str| out.seconds.iter().find(|(s, _)| s == name).map_or(0.0, |(_, v)| *v);
        let r = out.registration.as_ref().map(|r| r.summary.clone()).unwrap_or_default();
        println!(
            "| c{}_r{} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {seconds:.1} | {:.1} | {:.1} | {:.1} | {:.1} | \
             {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            tile.id.col,
            tile.id.row,
            tile.owned.len(),
            tile.context.len(),
            campaign.plan.depth_of(&tile.id).len(),
            r.images_matched,
            r.images,
            r.ties,
            r.ties_with_aerial,
            out.poles.len(),
            out.skipped.len(),
            stage("read"),
            stage("decode"),
            stage("ortho"),
            stage("features"),
            stage("prepare"),
            stage("matching"),
            stage("aerial"),
            stage("registration"),
            stage("poles"),
        );
        owned += tile.owned.len();
        matched += r.images_matched;
        wall += seconds;
    }
    println!(
        "total: {owned} panoramas, {matched} matched, {wall:.1} s over {} tiles ({:.2} s per panorama); stage \
         columns are thread-seconds",
        campaign.plan.tiles.tiles().len(),
        wall / owned.max(1) as f64
    );
    println!(
        "`prepare` and `registration` are elapsed seconds (reading + step 1, and the pairs); peak RSS {}",
        peak_rss()
    );
    Ok(())
}

/// The process's peak resident set size (`VmHWM` of /proc/self/status), as the kernel reports it.
fn peak_rss() -> String {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("VmHWM:")).map(|l| l["VmHWM:".len()..].trim().to_owned()))
        .unwrap_or_else(|| "unknown".into())
}
