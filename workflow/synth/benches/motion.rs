//! Motion benchmark: epochs per second of the true drive, the DG error process, GNSS, IMU increments and
//! their CSV encoding on a route through the `district` world at 200 Hz, single-threaded.
//! Run with `cargo bench -p plumbline-synth --bench motion`.

use std::time::Instant;

use plumbline_synth::motion::dg::{self, DgConfig};
use plumbline_synth::motion::gnss::{self, GnssConfig};
use plumbline_synth::motion::imu::{self, ImuErrors};
use plumbline_synth::motion::{Drive, DriveConfig, files};
use plumbline_synth::world::{Preset, World, WorldConfig};

/// Median wall time of `runs` calls, seconds, and the last result.
fn time<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = None;
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            out = Some(f());
            start.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    (t[t.len() / 2], out.unwrap_or_else(|| unreachable!("runs > 0")))
}

fn row(what: &str, epochs: usize, seconds: f64) {
    println!("| {what:<24} | {epochs:>8} | {:>9.1} | {:>10.2} |", seconds * 1e3, epochs as f64 / seconds / 1e6);
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let route = World::generate(&WorldConfig::new(Preset::District, 1))?.route(1, 2000.0);
    let config = DriveConfig::default();
    let runs = 5;
    let (t_drive, drive) = time(runs, || Drive::simulate(&route, &config, 1));
    let drive = drive?;
    let n = drive.trajectory.len();
    let dg_config = DgConfig::default();
    let (t_dg, dg) = time(runs, || dg::simulate(&drive, &dg_config, 1));
    let dg = dg?;
    let (t_gnss, fixes) = time(runs, || gnss::simulate(&drive, &dg, &dg_config, &GnssConfig::default(), 1));
    let fixes = fixes?;
    let (t_imu, imu_data) = time(runs, || imu::simulate(&drive, &ImuErrors::NAVIGATION, 1));
    let imu_data = imu_data?;
    let (t_csv, bytes) = time(runs, || files::imu_csv(&imu_data).len() + files::dg_errors_csv(&dg.errors).len());
    let length = drive.kinematics.last().map_or(0.0, |k| k.distance);
    let (t0, t1) = drive.trajectory.span();
    println!(
        "district drive: {length:.0} m, {:.0} s, {n} epochs at {} Hz; median of {runs} runs",
        t1 - t0,
        config.rate_hz
    );
    println!("| {:<24} | {:>8} | {:>9} | {:>10} |", "stage", "epochs", "ms", "Mepochs/s");
    println!("|{}|{}|{}|{}|", "-".repeat(26), "-".repeat(10), "-".repeat(11), "-".repeat(12));
    row("true drive", n, t_drive);
    row("DG error process", n, t_dg);
    row(&format!("GNSS ({} fixes)", fixes.len()), n, t_gnss);
    row("IMU increments", n, t_imu);
    row(&format!("CSV IMU + errors ({} MB)", bytes / 1_000_000), n, t_csv);
    Ok(())
}
