//! Pole benchmark (`cargo bench -p plumbline-poles`): detections per second from depth images (decode +
//! back-projection + detection, the renderer excluded), points per second reading LAS and LAZ, and the
//! issue-6 figures (recall, precision, χ²) on a `district` world. Environment: POLE_BENCH_LENGTH (route
//! metres, default 2000), POLE_BENCH_WIDTH (depth image width, default 640; height = width × 9/16),
//! POLE_BENCH_RATE (Hz, default 1), POLE_BENCH_SEED (default 1).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use std::io::Cursor;
use std::time::Instant;

use common::Scenario;
use common::eval::chi2_bounds;
use las::{Builder, Point, Transform, Vector, Writer, point::Format};
use plumbline_campaign::Location;
use plumbline_campaign::manifest::{CameraMount as ManifestMount, DepthCamera};
use plumbline_poles::pipeline::DepthFrame;
use plumbline_poles::{
    DetectConfig, PoleConfig, StemConfig, StemDetector, decode_depth_png, depth_points, detect, process_depth_frames,
    read_las, stream_las_xyz,
};
use plumbline_synth::sensors::Mount;
use plumbline_synth::world::Preset;

fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn main() {
    let length: f64 = env("POLE_BENCH_LENGTH", 2000.0);
    let width: u32 = env("POLE_BENCH_WIDTH", 640);
    let rate: f64 = env("POLE_BENCH_RATE", 1.0);
    let seed: u64 = env("POLE_BENCH_SEED", 1);
    let threads = rayon::current_num_threads();
    println!("plumbline-poles benchmark ({threads} rayon threads)\n");
    if env("POLE_BENCH_STEMS_ONLY", false) {
        stems_throughput();
        return;
    }
    let started = Instant::now();
    let sc = Scenario::new(Preset::District, seed, length, (width, width * 9 / 16), rate);
    let pngs: Vec<Vec<u8>> = (0..sc.shots.len()).map(|i| sc.png(i)).collect();
    println!(
        "district world, seed {seed}, {length} m route, {} depth frames {}×{} at {rate} Hz rendered in {:.1} s",
        pngs.len(),
        width,
        width * 9 / 16,
        started.elapsed().as_secs_f64()
    );
    depth_throughput(&sc, &pngs);
    accuracy(&sc, &pngs);
    las_throughput();
    stems_throughput();
}

fn depth_throughput(sc: &Scenario, pngs: &[Vec<u8>]) {
    let t = Instant::now();
    let mut detections = 0usize;
    let mut points = 0usize;
    for (i, png) in pngs.iter().enumerate() {
        let depth = decode_depth_png(&sc.shots[i].id, png, &sc.intrinsics).unwrap();
        let frame = depth_points(&depth, &sc.intrinsics, common::SHARE, &sc.mount, &sc.shots[i].dg.pose());
        points += frame.points.len();
        detections += detect(&frame, &DetectConfig::default()).map_or(0, |d| d.detections.len());
    }
    let s = t.elapsed().as_secs_f64();
    println!("\n| depth stage (decode + georeference + detect) | value |\n|---|---|");
    println!("| frames | {} |\n| points | {points} |\n| detections | {detections} |", pngs.len());
    println!("| time | {s:.2} s |\n| frames / s | {:.1} |", pngs.len() as f64 / s);
    println!("| detections / s | {:.1} |\n| points / s | {:.2} M |", detections as f64 / s, points as f64 / s / 1e6);
}

fn accuracy(sc: &Scenario, pngs: &[Vec<u8>]) {
    let camera = DepthCamera {
        index: Location::from("depth/index.csv"),
        images: Location::from("depth/"),
        intrinsics: sc.intrinsics,
        mount: ManifestMount { lever_arm_m: Mount::DEPTH.lever_arm_m, boresight_deg: Mount::DEPTH.boresight_deg },
        range_error_share: common::SHARE,
    };
    let frames: Vec<DepthFrame<'_>> =
        sc.shots.iter().zip(pngs).map(|(shot, png)| DepthFrame { id: &shot.id, png, dg: &shot.dg }).collect();
    let t = Instant::now();
    let out = process_depth_frames(&camera, &frames, &sc.features(), &PoleConfig::default());
    let s = t.elapsed().as_secs_f64();
    let score = sc.score(&out);
    let (lo, hi) = chi2_bounds(score.dof);
    println!("\n| accuracy (whole pipeline, DG poses) | value |\n|---|---|");
    println!("| pipeline time | {s:.2} s |");
    println!(
        "| poles observable / detected | {} / {} ({:.1} %) |",
        score.observable,
        score.detected,
        100.0 * score.recall()
    );
    println!("| trees observable / detected | {} / {} |", score.trees_observable, score.trees_detected);
    println!(
        "| matches / wrong | {} / {} (precision {:.2} %) |",
        score.matches,
        score.wrong,
        100.0 * score.precision()
    );
    println!("| CUPTs / poles with CUPTs | {} / {} |", score.updates, score.poles_with_updates);
    println!(
        "| χ² stated / σ×2 / σ÷2 (dof {}) | {:.1} / {:.1} / {:.1} (1 % bounds {lo:.1}–{hi:.1}) |",
        score.dof, score.chi2[0], score.chi2[1], score.chi2[2]
    );
}

fn cloud(n: usize, compressed: bool) -> Vec<u8> {
    let mut builder = Builder::from((1, 2));
    builder.point_format = Format::new(1).unwrap();
    builder.point_format.is_compressed = compressed;
    let t = |offset| Transform { scale: 0.001, offset };
    builder.transforms = Vector { x: t(565_000.0), y: t(5_933_000.0), z: t(0.0) };
    let mut writer = Writer::new(Cursor::new(Vec::new()), builder.into_header().unwrap()).unwrap();
    for i in 0..n {
        let f = i as f64;
        let (s, c) = (f * 0.001).sin_cos();
        let p = Point {
            x: 565_000.0 + 20.0 * c,
            y: 5_933_000.0 + 20.0 * s,
            z: 8.0 + (f * 0.37).sin(),
            gps_time: Some(f * 1e-5),
            ..Default::default()
        };
        writer.write_point(p).unwrap();
    }
    writer.into_inner().unwrap().into_inner()
}

fn las_throughput() {
    let n = 2_000_000;
    println!("\n| point cloud ({n} points, format 1) | bytes | read time | points / s |\n|---|---|---|---|");
    for compressed in [false, true] {
        let bytes = cloud(n, compressed);
        let size = bytes.len();
        let t = Instant::now();
        let read = read_las("bench", bytes).unwrap();
        let s = t.elapsed().as_secs_f64();
        assert_eq!(read.points.len(), n);
        let name = if compressed { "LAZ" } else { "LAS" };
        println!("| {name} | {size} | {s:.3} s | {:.2} M |", n as f64 / s / 1e6);
    }
}

/// `poles detect`'s core on a scanned street of 600 m (`plumbline_synth::scan`, about 2.6 M points): the
/// cloud streamed three times from LAS and LAZ bytes (ground, band, the candidates' surroundings), and the
/// detection on the kept points; one thread.
fn stems_throughput() {
    use plumbline_synth::scan::{ScanScene, scan_scene};
    let scene = ScanScene { length_m: 600.0, ..ScanScene::default() };
    let (points, _) = scan_scene(&scene, 1);
    let n = points.len();
    println!(
        "\n| stems ({n} points, format 0) | bytes | three streamed passes | points / s | finish | stems |\n|---|---|---|---|---|---|"
    );
    for compressed in [false, true] {
        let mut builder = Builder::from((1, 2));
        builder.point_format = Format::new(0).unwrap();
        builder.point_format.is_compressed = compressed;
        let t = |offset| Transform { scale: 0.001, offset };
        builder.transforms = Vector { x: t(512_000.0), y: t(5_403_000.0), z: t(0.0) };
        let mut writer = Writer::new(Cursor::new(Vec::new()), builder.into_header().unwrap()).unwrap();
        for p in &points {
            writer.write_point(Point { x: p[0], y: p[1], z: p[2], ..Default::default() }).unwrap();
        }
        let bytes = std::sync::Arc::new(writer.into_inner().unwrap().into_inner());
        let size = bytes.len();
        let mut d = StemDetector::new(StemConfig::default());
        let started = Instant::now();
        stream_las_xyz("bench", ArcBytes(bytes.clone()), |b| d.ground(b)).unwrap();
        stream_las_xyz("bench", ArcBytes(bytes.clone()), |b| d.collect(b)).unwrap();
        stream_las_xyz("bench", ArcBytes(bytes), |b| d.surroundings(b)).unwrap();
        let read = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let stems = d.finish();
        let finish = started.elapsed().as_secs_f64();
        let name = if compressed { "LAZ" } else { "LAS" };
        println!(
            "| {name} | {size} | {read:.2} s | {:.2} M | {finish:.2} s | {} |",
            3.0 * n as f64 / read / 1e6,
            stems.len()
        );
    }
}

/// Shared bytes for the streaming reader.
struct ArcBytes(std::sync::Arc<Vec<u8>>);

impl AsRef<[u8]> for ArcBytes {
    fn as_ref(&self) -> &[u8] {
        self.0.as_slice()
    }
}
