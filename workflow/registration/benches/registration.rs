//! Registration speed on a synthetic campaign, per GNSS profile: the panoramas, the seconds the campaign took
//! to build (render, not pipeline), and the time per stage per panorama from [`StageTimings`]. Timing only:
//! nothing is scored against the truth here. Accuracy (Jende et al. 2017 Table 1, failure reasons, where
//! true correspondences are lost, image motion, heights, the cross-panorama check) is measured by
//! `cargo run --release -p plumbline-eval -- registration` (flags for the preset, realism, profiles and
//! pipeline overrides there).
//!
//! `cargo bench -p plumbline-registration --bench registration`: the `tiny` world, seed 1, a 400 m route with
//! panoramas every 5 m at 1024 px, ideal realism, profiles open, urban and canyon.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

use std::time::{Duration, Instant};

use plumbline_fixtures::registration::{Campaign, Profile, Spec};
use plumbline_geo::tiling::TileId;
use plumbline_registration::pipeline::prepare_panoramas;
use plumbline_registration::{PipelineConfig, StageTimings, register_tile};
use plumbline_synth::render::{Realism, RealismLevel};
use plumbline_synth::world::Preset;

/// One profile's panoramas, build seconds and stage times.
struct Row {
    name: &'static str,
    images: usize,
    build_s: f64,
    timings: StageTimings,
}

fn run(name: &'static str, profile: Profile) -> Row {
    let spec = Spec {
        preset: Preset::Tiny,
        seed: 1,
        profile,
        length: 400.0,
        spacing: 5.0,
        width: 1024,
        window: None,
        realism: Realism::of(RealismLevel::Ideal),
    };
    let t0 = Instant::now();
    let campaign = Campaign::build(&spec);
    let build_s = t0.elapsed().as_secs_f64();
    let config = PipelineConfig::default();
    let t1 = Instant::now();
    let prepared = prepare_panoramas(&campaign.panoramas, &campaign.rig, &config.mm);
    let mut run = register_tile(TileId { col: 0, row: 0 }, &prepared, &campaign.rig, &campaign.reference, &config);
    // The wall time of step 1 and the features (prepared first) and of the pairs.
    run.timings.total = t1.elapsed();
    Row { name, images: campaign.panoramas.len(), build_s, timings: run.timings }
}

fn main() {
    println!("registration timing: tiny, seed 1, route 400 m, panoramas every 5 m at 1024 px, ideal realism");
    let profiles = [("open", Profile::Open), ("urban", Profile::Urban), ("canyon", Profile::Canyon)];
    let rows: Vec<Row> = profiles.into_iter().map(|(name, p)| run(name, p)).collect();
    println!(
        "\n| profile | images | ortho-projection | features | matching | triangulation | aerial | lines | elapsed | build (not pipeline) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let per = |d: Duration| 1e3 * d.as_secs_f64() / r.images.max(1) as f64;
        let t = &r.timings;
        println!(
            "| {} | {} | {:.0} ms | {:.0} ms | {:.0} ms | {:.2} ms | {:.0} ms | {:.1} ms | {:.0} ms | {:.1} s |",
            r.name,
            r.images,
            per(t.ortho),
            per(t.features),
            per(t.matching),
            per(t.triangulation),
            per(t.aerial),
            per(t.lines),
            per(t.total),
            r.build_s
        );
    }
    println!("\nStage times are thread-time per panorama (stages run in parallel on rayon's pool); `elapsed` is the");
    println!(
        "wall time of `prepare_panoramas` + `register_tile` divided by the panoramas, on {} threads.",
        rayon::current_num_threads()
    );
}
