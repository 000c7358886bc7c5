//! Pole benchmark (`cargo bench -p plumbline-poles`), throughput only: detections per second from depth
//! images (decode + back-projection + detection, the renderer excluded) on a `district` world, points per
//! second reading LAS and LAZ (and the `laz` decoder alone on the same LAZ), and the static stems'
//! throughput. The accuracy figures (recall, matching precision, the coordinate updates' χ², depth camera
//! and roof laser scanner) are `cargo run --release -p plumbline-eval -- poles`. Environment:
//! POLE_BENCH_LENGTH (route metres, default 2000), POLE_BENCH_WIDTH (depth image width, default 640;
//! height = width × 9/16), POLE_BENCH_RATE (Hz, default 1), POLE_BENCH_SEED (default 1) build the scenario
//! whose depth frames are timed; POLE_BENCH_STEMS_ONLY (only the static stems' throughput).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::io::Cursor;
use std::time::Instant;

use las::{Builder, Point, Transform, Vector, Writer, point::Format};
use plumbline_fixtures::poles::{SHARE, Scenario};
use plumbline_poles::{
    DetectConfig, StemConfig, StemDetector, decode_depth_png, depth_points, detect, read_las, stream_las_xyz,
};
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
    las_throughput();
    stems_throughput();
}

fn depth_throughput(sc: &Scenario, pngs: &[Vec<u8>]) {
    let t = Instant::now();
    let mut detections = 0usize;
    let mut points = 0usize;
    for (i, png) in pngs.iter().enumerate() {
        let depth = decode_depth_png(&sc.shots[i].id, png, &sc.intrinsics).unwrap();
        let frame = depth_points(&depth, &sc.intrinsics, SHARE, &sc.mount, &sc.shots[i].dg.pose());
        points += frame.points.len();
        detections += detect(&frame, &DetectConfig::default()).map_or(0, |d| d.detections.len());
    }
    let s = t.elapsed().as_secs_f64();
    println!("\n| depth stage (decode + georeference + detect) | value |\n|---|---|");
    println!("| frames | {} |\n| points | {points} |\n| detections | {detections} |", pngs.len());
    println!("| time | {s:.2} s |\n| frames / s | {:.1} |", pngs.len() as f64 / s);
    println!("| detections / s | {:.1} |\n| points / s | {:.2} M |", detections as f64 / s, points as f64 / s / 1e6);
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
        let copy = compressed.then(|| bytes.clone());
        let t = Instant::now();
        let read = read_las("bench", bytes).unwrap();
        let s = t.elapsed().as_secs_f64();
        assert_eq!(read.points.len(), n);
        let name = if compressed { "LAZ" } else { "LAS" };
        println!("| {name} | {size} | {s:.3} s | {:.2} M |", n as f64 / s / 1e6);
        // The `laz` crate alone, decoding the same fields into one buffer: the floor under "LAZ".
        if let Some(copy) = copy {
            let vlr = las::Reader::new(Cursor::new(copy.clone())).unwrap().header().laz_vlr().unwrap();
            let t = Instant::now();
            decode_alone(copy, vlr);
            let s = t.elapsed().as_secs_f64();
            println!("| LAZ, the `laz` decoder alone | {size} | {s:.3} s | {:.2} M |", n as f64 / s / 1e6);
        }
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

/// Decode a LAZ file's coordinates and GPS times with the `laz` crate alone, into one reused buffer.
fn decode_alone(laz: Vec<u8>, vlr: laz::LazVlr) {
    let header = plumbline_poles::parse_las_header("strip", &laz, Some(laz.len() as u64)).unwrap();
    let record_len = usize::from(header.point_record_length);
    let mut source = Cursor::new(laz);
    source.set_position(u64::from(header.offset_to_point_data));
    let selection = laz::DecompressionSelection::xy_returns_channel().decompress_z().decompress_gps_time();
    let mut decoder = laz::LasZipDecompressor::selective(source, vlr, selection).unwrap();
    let mut buffer = vec![0u8; 65_536 * record_len];
    let mut left = header.point_count as usize;
    while left > 0 {
        let n = left.min(65_536);
        laz::LazDecompressor::decompress_many(&mut decoder, &mut buffer[..n * record_len]).unwrap();
        left -= n;
    }
}
