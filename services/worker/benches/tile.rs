//! Time `process_tile` on every tile of a campaign and print a table: panoramas, matches, ties, pole updates,
//! seconds per tile and per stage, the process's CPU seconds and bytes read per tile; then the totals per
//! panorama, the process's peak RSS and a one-line cost model per 100 km of drive.
//!
//! `cargo bench -p plumbline-worker --bench tile -- CAMPAIGN.toml`, e.g. on a
//! campaign from `plumbline simulate --preset tiny --out /tmp/camp` (or `--preset district`). Tiles run one
//! after the other, each using every core inside. CPU seconds are the process's user + system time
//! (`/proc/self/stat`, clock ticks of 1/100 s), bytes read its `rchar` (`/proc/self/io`: every byte read from
//! files and sockets, GDAL's reads included).

use std::time::Instant;

use plumbline_runtime::Files;
use plumbline_scheduler::load_campaign;
use plumbline_worker::{WorkerConfig, process_tile};

fn main() -> plumbline_runtime::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let Some(manifest) = args.first() else {
        eprintln!("usage: cargo bench -p plumbline-worker --bench tile -- CAMPAIGN.toml");
        return Ok(());
    };
    let runtime = tokio::runtime::Runtime::new()?;
    runtime.block_on(run(manifest))
}

async fn run(manifest: &str) -> plumbline_runtime::Result<()> {
    let files = Files::default();
    let t0 = Instant::now();
    let campaign = load_campaign(&files, manifest).await?;
    println!("campaign loaded and planned in {:.2} s", t0.elapsed().as_secs_f64());
    let config = WorkerConfig::from_manifest(&campaign.manifest);
    println!(
        "| tile | owned | context | depth | matched / images | ties | with aerial | pole updates | skipped | wall s | \
         CPU s | MB read | read | decode | ortho | features | prepare | matching | aerial | registration | poles |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let (mut owned, mut matched, mut wall, mut cpu, mut read) = (0, 0, 0.0, 0.0, 0u64);
    for tile in campaign.plan.tiles.tiles() {
        let start = Instant::now();
        let (cpu0, read0) = (cpu_seconds(), bytes_read());
        let out = process_tile(&files, &campaign, &tile.id, &config).await?;
        let seconds = start.elapsed().as_secs_f64();
        let (tile_cpu, tile_read) = (cpu_seconds() - cpu0, bytes_read().saturating_sub(read0));
        let stage = |name: &str| out.seconds.iter().find(|(s, _)| s == name).map_or(0.0, |(_, v)| *v);
        let r = out.registration.as_ref().map(|r| r.summary.clone()).unwrap_or_default();
        println!(
            "| c{}_r{} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {seconds:.1} | {tile_cpu:.1} | {:.0} | {:.1} | \
             {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
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
            tile_read as f64 / 1e6,
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
        cpu += tile_cpu;
        read += tile_read;
    }
    let n = owned.max(1) as f64;
    println!(
        "total: {owned} panoramas, {matched} matched, {wall:.1} s over {} tiles ({:.2} s, {:.2} CPU s and {:.1} MB \
         read per panorama); stage columns are thread-seconds",
        campaign.plan.tiles.tiles().len(),
        wall / n,
        cpu / n,
        read as f64 / 1e6 / n,
    );
    println!(
        "`prepare` and `registration` are elapsed seconds (reading + step 1, and the pairs); peak RSS {}",
        peak_rss()
    );
    let km = drive_km(campaign.trajectory.trajectory.records());
    if km > 0.0 {
        println!(
            "cost per 100 km of drive ({km:.2} km here, panoramas and depth images as in this campaign): {:.1} \
             CPU-hours, {:.1} GB read",
            cpu / km * 100.0 / 3600.0,
            read as f64 / km * 100.0 / 1e9
        );
    }
    Ok(())
}

/// The horizontal length of the drive, kilometres.
fn drive_km(records: &[plumbline_geo::TrajectoryRecord]) -> f64 {
    records
        .windows(2)
        .map(|w| (w[1].position.x() - w[0].position.x()).hypot(w[1].position.y() - w[0].position.y()))
        .sum::<f64>()
        / 1000.0
}

/// The process's user + system CPU time, seconds (`/proc/self/stat` fields 14 and 15, in 1/100 s).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // The command name (field 2) may hold spaces; the fields after its closing parenthesis start at field 3.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |k: usize| fields.get(k).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

/// Bytes the process has read (`rchar` of `/proc/self/io`).
fn bytes_read() -> u64 {
    std::fs::read_to_string("/proc/self/io")
        .ok()
        .and_then(|s| s.lines().find_map(|l| l.strip_prefix("rchar:").and_then(|v| v.trim().parse().ok())))
        .unwrap_or(0)
}

/// The process's peak resident set size (`VmHWM` of /proc/self/status), as the kernel reports it.
fn peak_rss() -> String {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("VmHWM:")).map(|l| l["VmHWM:".len()..].trim().to_owned()))
        .unwrap_or_else(|| "unknown".into())
}
