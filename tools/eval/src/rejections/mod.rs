//! What the adjustment rejects on a finished simulated campaign, against the simulation's truth: the tiles of
//! an earlier `plumbline demo`/`run` (its `results/tiles/*.json`) merged and adjusted again, every tie ray and
//! aerial point scored against the surface under its pixel (`truth/pixels`) seen from the true pose
//! (`truth/images.csv`), and every rejected observation given a cause — wrong in truth (which surface it lies
//! on) or correct and rejected because the trajectory model could not fit it (near a DG fault or not).
//!
//! Variants: `default` is what `finish` does (merge, join the tie points sharing an image point, adjust);
//! `unjoined` leaves them apart (as before the join); `no_elevation_sigma` is `default` with every ray's
//! σ across used in elevation too; the others change one σ of the unjoined set or drop a kind of tie from it.
//!
//! Run: `cargo run --release -p plumbline-eval -- rejections DIR [VARIANT...] [--dump FILE]` with DIR a demo
//! folder (`campaign.toml`, `truth/`, outputs under `results/`); no VARIANT runs `default` and `unjoined`,
//! `all` every one. The accepted rays' errors are also split into across / elevation by range
//! (`decompose.rs`); `--dump FILE` writes those rays as CSV.

mod decompose;
mod score;
mod truth;

use std::collections::BTreeMap;
use std::path::PathBuf;

use plumbline_adjuster::{AdjusterConfig, Merged, Solved, join_shared_points, merge, panorama_mount, solve};
use plumbline_adjustment::ObservationRef;
use plumbline_fixtures::adjuster::tiles::read_tiles;
use plumbline_geo::camera::Equirectangular;
use plumbline_geo::metrics::{compare, median};
use plumbline_runtime::Files;

use score::{Scores, Verdict};
use truth::Truth;

/// A named change to the settings or to the merged observations.
struct Variant {
    name: &'static str,
    apply: fn(&mut AdjusterConfig, &mut Merged),
}

const VARIANTS: &[Variant] = &[
    Variant {
        name: "default",
        apply: |_, m| {
            join_shared_points(m);
        },
    },
    Variant { name: "unjoined", apply: |_, _| {} },
    Variant { name: "rays_x1.5", apply: |_, m| scale_rays(m, 1.5) },
    Variant { name: "rays_x2", apply: |_, m| scale_rays(m, 2.0) },
    Variant { name: "aerial_xy_x1.4", apply: |_, m| scale_aerial(m, 1.4, 1.0) },
    Variant { name: "no_mm_only_ties", apply: |_, m| m.observations.ties.retain(|t| t.aerial.is_some()) },
    Variant { name: "no_height_bias", apply: |c, _| c.adjustment.height_biases = None },
    Variant { name: "ray_sigma_by_range", apply: |_, m| scale_rays_by_range(m, 7.0) },
    Variant {
        name: "no_elevation_sigma",
        apply: |_, m| {
            join_shared_points(m);
            m.observations.ties.iter_mut().flat_map(|t| t.rays.iter_mut()).for_each(|r| r.sigma_elevation = None);
        },
    },
    Variant {
        name: "no_ties_beyond_10m",
        apply: |_, m| m.observations.ties.retain(|t| t.rays.iter().all(|r| ground_range(r) < 10.0)),
    },
];

/// The camera's height above the road in the simulated campaigns (`panoramas.camera_height_m`).
const CAMERA_HEIGHT: f64 = 3.75;

/// The range to a ray's point if it lies on the road: the camera height over the ray's depression (camera
/// y is down for the nominal mount).
fn ground_range(r: &plumbline_adjustment::TieRay) -> f64 {
    if r.direction[1] > 0.05 { CAMERA_HEIGHT / r.direction[1] } else { f64::INFINITY }
}

/// Scale each ray's σ by its ground range over `from` metres (≥ 1).
fn scale_rays_by_range(m: &mut Merged, from: f64) {
    for r in m.observations.ties.iter_mut().flat_map(|t| t.rays.iter_mut()) {
        r.sigma *= (ground_range(r) / from).clamp(1.0, 4.0);
    }
}

fn scale_rays(m: &mut Merged, k: f64) {
    for r in m.observations.ties.iter_mut().flat_map(|t| t.rays.iter_mut()) {
        r.sigma *= k;
    }
}

/// Scale the aerial points' horizontal σ by `xy` and height σ by `z`.
fn scale_aerial(m: &mut Merged, xy: f64, z: f64) {
    let k = [xy, xy, z];
    for a in m.observations.ties.iter_mut().filter_map(|t| t.aerial.as_mut()) {
        for (i, row) in a.covariance.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v *= k[i] * k[j];
            }
        }
    }
}

/// The arguments of `plumbline-eval rejections` (see the module docs).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A finished demo folder: `campaign.toml`, `truth/`, outputs under `results/`.
    pub dir: String,
    /// Variants to run: default, unjoined, rays_x1.5, rays_x2, aerial_xy_x1.4, no_mm_only_ties,
    /// no_height_bias, ray_sigma_by_range, no_elevation_sigma, no_ties_beyond_10m, or `all`; none:
    /// `default` and `unjoined`.
    pub variants: Vec<String>,
    /// Write the accepted later rays of road ties (the range table's rays) to this CSV file.
    #[arg(long, value_name = "FILE")]
    pub dump: Option<PathBuf>,
}

/// `plumbline-eval rejections`: every table of the module docs.
pub fn main(args: &Args) {
    let dir = args.dir.trim_end_matches('/').to_owned();
    let wanted: Vec<&str> = args.variants.iter().map(String::as_str).collect();
    if let Some(unknown) = wanted.iter().find(|w| **w != "all" && !VARIANTS.iter().any(|v| v.name == **w)) {
        eprintln!("unknown variant {unknown}");
        std::process::exit(2);
    }
    let rt = tokio::runtime::Runtime::new().unwrap();
    let campaign =
        rt.block_on(plumbline_scheduler::load_campaign(&Files::default(), &format!("{dir}/campaign.toml"))).unwrap();
    let tiles = read_tiles(&format!("{dir}/results/tiles"));
    let spec = campaign.manifest.panoramas.as_ref().expect("the campaign has panoramas");
    let camera = Equirectangular::new(spec.width_px.unwrap(), spec.height_px.unwrap()).unwrap();
    let mount = panorama_mount(&campaign.manifest);
    let mut truth = Truth::load(&dir, camera, mount);
    let reference = campaign.reference.as_ref().expect("the campaign names a reference trajectory");
    let dg = &campaign.trajectory.trajectory;
    let reported = report_rejections(&dir);
    println!("# {dir}: {} tiles; report.json lists {reported} rejected observations\n", tiles.len());
    let before = compare(dg, reference).unwrap();
    let mut rows = vec![row("DG", &before, None)];
    for v in VARIANTS.iter().filter(|v| {
        (["default", "unjoined"].contains(&v.name) && wanted.is_empty())
            || wanted.contains(&"all")
            || wanted.contains(&v.name)
    }) {
        let mut config = AdjusterConfig::from_manifest(&campaign.manifest);
        let mut merged = merge(&tiles);
        (v.apply)(&mut config, &mut merged);
        let solved = solve(dg, &merged, &mount, &config).unwrap();
        let obs = &merged.observations;
        let rays: usize = obs.ties.iter().map(|t| t.rays.len()).sum();
        let multi = obs.ties.iter().filter(|t| t.rays.len() > 2).count();
        let aerial = obs.ties.iter().filter(|t| t.aerial.is_some()).count();
        println!("{} tie points ({multi} with 3 or more rays), {rays} rays, {aerial} aerial points\n", obs.ties.len());
        let scores = Scores::of(&merged, &mut truth);
        println!("## variant {}: {} rejected\n", v.name, solved.adjustment.rejected.len());
        print_causes(&merged, &solved, &scores, &truth);
        scores.print_distributions(&solved);
        scores.print_by_class();
        decompose::print(&scores, &solved, std::f64::consts::TAU / f64::from(camera.width), args.dump.as_deref());
        truth.self_check(&merged);
        scores.print_height_biases(&merged, &solved);
        rows.push(row(v.name, &compare(&solved.corrected, reference).unwrap(), Some(&solved)));
    }
    println!("## against the reference (form of Meyer et al. 2023, metres)\n");
    println!(
        "| variant | along 95 % | cross 95 % | cross max | height median | height 95 % | 2D RMSE | σ0 | rejected |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        println!("{r}");
    }
}

fn row(name: &str, c: &plumbline_geo::metrics::Comparison, solved: Option<&Solved>) -> String {
    let tail = solved
        .map_or_else(|| " | ".to_owned(), |s| format!("{:.3} | {}", s.adjustment.sigma0, s.adjustment.rejected.len()));
    format!(
        "| {name} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {tail} |",
        c.along.p95, c.cross.p95, c.cross.max, c.height.median, c.height.p95, c.rmse_2d
    )
}

/// Rejected observations by kind × cause.
fn print_causes(merged: &Merged, solved: &Solved, scores: &Scores, truth: &Truth) {
    let mut table: BTreeMap<(&str, String), (usize, Vec<f64>)> = BTreeMap::new();
    let rays_rejected: std::collections::HashSet<usize> = solved
        .adjustment
        .rejected
        .iter()
        .filter_map(|r| match &r.item {
            ObservationRef::TieRay { index, .. } => Some(*index),
            _ => None,
        })
        .collect();
    for r in &solved.adjustment.rejected {
        let (kind, verdict) = match &r.item {
            ObservationRef::TieRay { index, ray, .. } => ("tie ray", scores.ray_verdict(*index, *ray)),
            ObservationRef::TieAerial { index, .. } => ("tie aerial", scores.aerial_verdict(*index)),
            ObservationRef::Tie { index, .. } if rays_rejected.contains(index) => {
                ("whole tie", Verdict::Consequence("one of its rays rejected, too few left".into()))
            }
            ObservationRef::Tie { index, .. } => ("whole tie", scores.tie_verdict(*index)),
            ObservationRef::Pole { .. } => ("pole", Verdict::Unknown("not scored".into())),
            ObservationRef::Gnss { .. } => ("gnss", Verdict::Unknown("not scored".into())),
        };
        let time = owner_time(merged, &r.item);
        let cause = match verdict {
            Verdict::Correct => {
                format!("correct, {}", truth.fault_at(time, 5.0).unwrap_or_else(|| "no DG fault within 5 s".into()))
            }
            other => other.to_string(),
        };
        let e = table.entry((kind, cause)).or_default();
        e.0 += 1;
        e.1.push(scores.trajectory_error(solved, time));
    }
    println!("| kind | cause | count | adjusted position error there, median m |");
    println!("|---|---|---|---|");
    for ((kind, cause), (n, mut errors)) in table {
        println!("| {kind} | {cause} | {n} | {:.3} |", median(&mut errors).unwrap_or(f64::NAN));
    }
    println!();
}

fn owner_time(merged: &Merged, item: &ObservationRef) -> f64 {
    let set = &merged.observations;
    match item {
        ObservationRef::TieRay { index, ray, .. } => set.ties[*index].rays[*ray].time,
        ObservationRef::TieAerial { index, .. } | ObservationRef::Tie { index, .. } => set.ties[*index].rays[0].time,
        ObservationRef::Pole { index, .. } => set.poles[*index].time,
        ObservationRef::Gnss { index } => set.gnss[*index].time,
    }
}

fn report_rejections(dir: &str) -> usize {
    let bytes = std::fs::read(format!("{dir}/results/report.json")).unwrap();
    let value: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
    value["rejected"].as_array().map_or(0, Vec::len)
}
