//! The adjustment's accuracy on a finished campaign: the tiles of an earlier `plumbline run`/`demo` (its
//! `tiles/*.json`) merged (tie points sharing an image point joined, as `finish` does) and adjusted again with the default settings and with single features switched
//! off, each compared with the campaign's reference trajectory in the form of Meyer et al. (2023). Only the adjustment
//! runs (seconds), so variants can be compared on real-pipeline observations.
//!
//! Run: `cargo bench -p plumbline-adjuster --bench campaign -- DIR [VARIANT...]` with DIR a demo folder
//! (holding `campaign.toml`, outputs under `results/`); no VARIANT runs all of them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use plumbline_adjuster::{AdjusterConfig, Merged, join_shared_points, merge, panorama_mount, solve};
use plumbline_fixtures::adjuster::tiles::read_tiles;
use plumbline_geo::metrics::compare;
use plumbline_runtime::Files;

/// A named change to the settings or to the merged observations.
struct Variant {
    name: &'static str,
    apply: fn(&mut AdjusterConfig, &mut Merged),
}

const VARIANTS: &[Variant] = &[
    Variant { name: "default", apply: |_, _| {} },
    Variant { name: "no_height_bias", apply: |c, _| c.adjustment.height_biases = None },
    Variant {
        name: "sqrt_n_heights",
        apply: |c, m| {
            c.adjustment.height_biases = None;
            scale_heights_per_tile(m);
        },
    },
    Variant { name: "no_jump_detection", apply: |c, _| c.adjustment.jump_detection = None },
    Variant {
        name: "no_jumps_no_bias",
        apply: |c, _| {
            c.adjustment.jump_detection = None;
            c.adjustment.height_biases = None;
        },
    },
    Variant { name: "no_fault_floor", apply: |c, _| c.adjustment.fault_prior = None },
    Variant { name: "no_localization", apply: |c, _| c.adjustment.jump_localization = None },
    Variant { name: "no_pole_offsets", apply: |c, _| c.adjustment.pole_offsets = false },
    Variant { name: "no_standstills", apply: |c, _| c.standstills = false },
    Variant { name: "no_weak_links", apply: |_, m| m.motions.clear() },
    Variant { name: "no_image_motions", apply: |c, _| c.image_motions = false },
    Variant { name: "no_kinematic_jumps", apply: |c, _| c.adjustment.kinematic_jumps = None },
    Variant { name: "no_aerial_heights", apply: |_, m| inflate_heights(m, 1e3) },
    Variant { name: "no_poles", apply: |_, m| m.observations.poles.clear() },
    Variant { name: "no_ties", apply: |_, m| m.observations.ties.clear() },
];

/// Scale every aerial height σ by √n, n the aerial points of the same panorama-pair prefix's tile (the
/// earlier stop-gap, for comparison).
fn scale_heights_per_tile(m: &mut Merged) {
    let tile_of = |id: &str| {
        let image = id.rsplit_once(':').map_or(id, |(a, _)| a);
        m.images.iter().find(|i| i.image == image).map(|i| i.tile)
    };
    let tiles: Vec<_> = m.observations.ties.iter().map(|t| tile_of(&t.id.0)).collect();
    for (tie, tile) in m.observations.ties.iter_mut().zip(&tiles) {
        let n = tiles.iter().filter(|t| *t == tile).count() as f64;
        if let Some(a) = tie.aerial.as_mut() {
            scale_height(&mut a.covariance, n.sqrt());
        }
    }
}

fn inflate_heights(m: &mut Merged, k: f64) {
    for a in m.observations.ties.iter_mut().filter_map(|t| t.aerial.as_mut()) {
        scale_height(&mut a.covariance, k);
    }
}

fn scale_height(c: &mut [[f64; 3]; 3], k: f64) {
    for row in c.iter_mut() {
        row[2] *= k;
    }
    for v in c[2].iter_mut() {
        *v *= k;
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let dir = args.first().expect("usage: campaign DIR [VARIANT...]").trim_end_matches('/').to_owned();
    let wanted: Vec<&str> = args[1..].iter().map(String::as_str).collect();
    let rt = tokio::runtime::Runtime::new().unwrap();
    let files = Files::default();
    let campaign = rt.block_on(plumbline_scheduler::load_campaign(&files, &format!("{dir}/campaign.toml"))).unwrap();
    let tiles = read_tiles(&format!("{dir}/results/tiles"));
    let reference = campaign.reference.as_ref().expect("the campaign names a reference trajectory");
    let dg = &campaign.trajectory.trajectory;
    let mount = panorama_mount(&campaign.manifest);
    let before = compare(dg, reference).unwrap();
    println!("# {dir}: {} tiles\n", tiles.len());
    println!(
        "| variant | along 95 % | cross 95 % | cross max | height median | 2D RMSE | σ0 | iterations | rejected | jumps |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut details = Vec::new();
    let row = |name: &str, c: &plumbline_geo::metrics::Comparison, tail: &str| {
        println!(
            "| {name} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {tail} |",
            c.along.p95, c.cross.p95, c.cross.max, c.height.median, c.rmse_2d
        );
    };
    row("DG", &before, " | | | ");
    for v in VARIANTS.iter().filter(|v| wanted.is_empty() || wanted.contains(&v.name)) {
        let mut config = AdjusterConfig::from_manifest(&campaign.manifest);
        let mut merged = merge(&tiles);
        join_shared_points(&mut merged);
        (v.apply)(&mut config, &mut merged);
        let solved = solve(dg, &merged, &mount, &config).unwrap();
        let a = &solved.adjustment;
        let after = compare(&solved.corrected, reference).unwrap();
        row(v.name, &after, &format!("{:.3} | {} | {} | {}", a.sigma0, a.iterations, a.rejected.len(), a.jumps.len()));
        details.push((v.name, a.jumps.clone(), a.height_biases.clone()));
    }
    for (name, jumps, biases) in details {
        let t0 = dg.records().first().map_or(0.0, |r| r.time);
        let jumps: Vec<String> =
            jumps.iter().map(|j| format!("{:.1}–{:.1} s (w {:.1})", j.start - t0, j.end - t0, j.w)).collect();
        println!("\n{name}: jumps detected: {}", jumps.join(", "));
        for b in biases {
            println!(
                "  height bias {}: {:+.3} ± {:.3} m (prior {:.3}, {} points)",
                b.frames.join("+"),
                b.bias,
                b.sigma,
                b.prior_sigma,
                b.points
            );
        }
    }
}
