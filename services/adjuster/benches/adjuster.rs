//! Time of the adjuster's steps against campaign size: merging tile outputs, the adjustment (consistency
//! check + adjust + apply), the report, the GeoPackage layers and their encoding, corrections.csv, and the
//! whole `finish` with its file writes (into a temporary directory). Deep-canyon drives through the
//! `district` world at 50 Hz, observations simulated from truth as in the tests; median of `runs` runs.
//!
//! Run: `cargo bench -p plumbline-adjuster --bench adjuster [-- runs]`.
#![allow(clippy::unwrap_used)]

use plumbline_fixtures::adjuster;

use std::time::Instant;

use plumbline_adjuster::{
    AdjusterConfig, build_report, corrections_csv, finish, merge, observation_layers, panorama_mount, solve,
};
use plumbline_campaign::progress::NoProgress;
use plumbline_runtime::Files;
use plumbline_synth::world::Preset;

fn median(mut v: Vec<f64>) -> f64 {
    plumbline_geo::metrics::median(&mut v).unwrap_or(f64::NAN)
}

fn time<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut seconds = Vec::new();
    let mut last = None;
    for _ in 0..runs {
        let t = Instant::now();
        last = Some(f());
        seconds.push(t.elapsed().as_secs_f64());
    }
    (median(seconds), last.unwrap())
}

fn main() {
    let runs: usize = std::env::args().skip(1).find_map(|a| a.parse().ok()).unwrap_or(3);
    let threads = rayon::current_num_threads();
    println!("# Adjuster steps, deep-canyon district drives at 50 Hz ({threads} threads, median of {runs} runs)\n");
    println!("| route | epochs | ties | poles | merge s | solve s | report s | layers s | gpkg s | csv s | finish s |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let rt = tokio::runtime::Runtime::new().unwrap();
    for length in [1000.0, 2000.0, 4000.0] {
        let s = adjuster::scenario_of(Preset::District, length, 50.0, 1);
        let dir = tempfile::tempdir().unwrap();
        let c = adjuster::campaign(&s, &format!("{}/", dir.path().display()));
        let tiles = adjuster::tiles(&s, &s.poles);
        let config = AdjusterConfig::default();
        let mount = panorama_mount(&c.manifest);
        let (t_merge, m) = time(runs, || merge(&tiles));
        let (t_solve, solved) = time(runs, || solve(&s.dg, &m, &mount, &config).unwrap());
        let (t_report, _) = time(runs, || build_report(&c, &m, &solved, c.reference.as_ref(), &[]));
        let (t_layers, layers) = time(runs, || observation_layers(&c, &m, &solved));
        let (t_gpkg, _) = time(runs, || plumbline_runtime::gdal_write::geopackage(&layers, adjuster::EPSG).unwrap());
        let (t_csv, _) = time(runs, || corrections_csv(&s.dg, &solved.corrected));
        let (t_finish, _) = time(runs, || {
            rt.block_on(finish(&Files::default(), &c, &tiles, &config, &NoProgress)).unwrap();
        });
        println!(
            "| {length:.0} m | {} | {} | {} | {t_merge:.3} | {t_solve:.3} | {t_report:.3} | {t_layers:.3} | {t_gpkg:.3} | \
             {t_csv:.3} | {t_finish:.3} |",
            s.dg.len(),
            m.observations.ties.len(),
            m.observations.poles.len(),
        );
    }
}
