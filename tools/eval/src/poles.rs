//! Pole detection and matching against the simulator's truth (Meyer et al. 2023): on a `district` world,
//! the depth camera's whole pipeline with DG poses (poles observable and detected, matches and wrong ones,
//! the coordinate updates' χ² with the stated σ, doubled and halved) and the roof laser scanner's cloud
//! made strip by strip, compressed to LAZ, read back and matched like depth frames (recall, precision,
//! χ²; the laser path's read times beside them). Throughput alone is `cargo bench -p plumbline-poles`.
//!
//! `cargo run --release -p plumbline-eval -- poles [--length 2000] [--width 640] [--rate 1] [--seed 1]
//! [--cloud-only] [--missed]`.

use std::collections::{BTreeMap, HashMap};
use std::io::Cursor;
use std::time::Instant;

use plumbline_campaign::Location;
use plumbline_campaign::manifest::{CameraMount as ManifestMount, DepthCamera};
use plumbline_fixtures::poles::eval::chi2_bounds;
use plumbline_fixtures::poles::{SHARE, Scenario};
use plumbline_poles::pipeline::DepthFrame;
use plumbline_poles::{
    CloudConfig, CloudSlicer, FrameReport, LasEncoding, LasPoint, PoleConfig, encode_las, match_inputs,
    process_depth_frames, stream_las_points,
};
use plumbline_synth::sensors::Mount;
use plumbline_synth::world::Preset;

/// Flags of `plumbline-eval poles`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Route length, m.
    #[arg(long, default_value_t = 2000.0)]
    length: f64,
    /// Depth image width, pixels (height = width × 9/16).
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Depth frame rate, Hz.
    #[arg(long, default_value_t = 1.0)]
    rate: f64,
    /// World and simulation seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Only the laser scanner's figures.
    #[arg(long)]
    cloud_only: bool,
    /// List the laser path's misses and detections off any pole.
    #[arg(long)]
    missed: bool,
}

/// Run the evaluation.
pub fn main(args: &Args) {
    let (length, width, rate, seed) = (args.length, args.width, args.rate, args.seed);
    let started = Instant::now();
    let sc = Scenario::new(Preset::District, seed, length, (width, width * 9 / 16), rate);
    if !args.cloud_only {
        let pngs: Vec<Vec<u8>> = (0..sc.shots.len()).map(|i| sc.png(i)).collect();
        println!(
            "district world, seed {seed}, {length} m route, {} depth frames {}×{} at {rate} Hz rendered in {:.1} s",
            pngs.len(),
            width,
            width * 9 / 16,
            started.elapsed().as_secs_f64()
        );
        accuracy(&sc, &pngs);
    }
    cloud_accuracy(&sc, args);
}

fn accuracy(sc: &Scenario, pngs: &[Vec<u8>]) {
    let camera = DepthCamera {
        index: Location::from("depth/index.csv"),
        images: Location::from("depth/"),
        intrinsics: sc.intrinsics,
        mount: ManifestMount { lever_arm_m: Mount::DEPTH.lever_arm_m, boresight_deg: Mount::DEPTH.boresight_deg },
        range_error_share: SHARE,
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

/// Accuracy figures: the roof laser scanner (`plumbline_synth::mls`) along the whole route, strip by strip
/// (30 s of scanning each) made, compressed to LAZ, streamed back through a `CloudSlicer` and matched like
/// depth frames. Recall counts the world's poles within 15 m of the true drive (all of them, and those the
/// scanner hit at least 10 times 1.0–1.6 m above ground); a detection is of the pole within 0.5 m of its
/// centre less the DG error at its slice's time.
fn cloud_accuracy(sc: &Scenario, args: &Args) {
    use plumbline_geo::PositionInterpolation::Linear;
    use plumbline_synth::mls::{ProfileScanner, profile_times, scan_profiles};
    use plumbline_synth::world::Surface;
    let scanner = ProfileScanner::ROOF;
    let mount = scanner.camera_mount();
    let (truth, dg) = (&sc.drive.trajectory, &sc.dg.trajectory);
    let times = profile_times(&sc.drive, &scanner).unwrap();
    let track = |t: f64| {
        let r = dg.interpolate(t, Linear).ok()?;
        let sigma = r.std.map_or(1.0, |s| s.east.max(s.north));
        Some((mount.camera_pose(&r.pose()).translation.p, sigma))
    };
    let all = vec![f64::NEG_INFINITY..f64::INFINITY];
    let mut slicer = CloudSlicer::new(CloudConfig::default(), "c@", track, all);
    let mut band_hits: HashMap<u32, usize> = HashMap::new();
    let mut surfaces: HashMap<(i64, i64), HashMap<String, usize>> = HashMap::new();
    let ground = sc.world.config.ground_height;
    let (mut points, mut bytes, mut scan_s, mut read_s, mut slice_s) = (0usize, 0usize, 0.0, 0.0, 0.0);
    let (mut copc_s, mut copc_bytes, mut decode_s) = (0.0, 0usize, 0.0);
    let encoding = LasEncoding { compressed: true, wkt: None, adjusted_standard_week: None };
    for strip in times.chunks((30.0 * scanner.profile_rate_hz) as usize) {
        let t = Instant::now();
        let scanned = scan_profiles(&sc.world, truth, dg, &scanner, strip, sc.seed).unwrap();
        for p in &scanned {
            if let Surface::Pole(id) = p.surface
                && (1.0..=1.6).contains(&(p.truth[2] - ground))
            {
                *band_hits.entry(id).or_default() += 1;
            }
            if (1.0..=1.6).contains(&(p.truth[2] - ground)) {
                let kind = format!("{:?}", p.surface).split('(').next().unwrap_or("").to_owned();
                let cell = ((p.truth[0] / 0.25).floor() as i64, (p.truth[1] / 0.25).floor() as i64);
                *surfaces.entry(cell).or_default().entry(kind).or_default() += 1;
            }
        }
        let las: Vec<LasPoint> =
            scanned.iter().map(|p| LasPoint { position: p.position, gps_time: p.gps_time }).collect();
        let laz = std::sync::Arc::new(encode_las(&las, &encoding).unwrap());
        scan_s += t.elapsed().as_secs_f64();
        (points, bytes) = (points + las.len(), bytes + laz.len());
        let t = Instant::now();
        stream_las_points("strip", ArcBytes(laz.clone()), |_| {}).unwrap();
        read_s += t.elapsed().as_secs_f64();
        // The `laz` crate alone, decoding the same fields into one buffer: the floor under "LAZ read".
        let (copy, vlr) = (laz.to_vec(), las::Reader::new(Cursor::new(laz.to_vec())).unwrap().header().laz_vlr());
        let t = Instant::now();
        decode_alone(copy, vlr.unwrap());
        decode_s += t.elapsed().as_secs_f64();
        // The same strip as COPC, every node decoded (the writing is not timed).
        let copc = plumbline_poles::encode_copc(&las, &encoding).unwrap();
        copc_bytes += copc.len();
        let t = Instant::now();
        let mut source = Cursor::new(copc);
        let len = source.get_ref().len() as u64;
        let index = plumbline_poles::CopcIndex::read("strip", &mut source, len).unwrap();
        let decoded = index.stream_points("strip", &mut source, index.nodes(), |_| {}).unwrap();
        assert_eq!(decoded, las.len() as u64);
        copc_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        stream_las_points("strip", ArcBytes(laz), |b| slicer.push(b)).unwrap();
        slice_s += t.elapsed().as_secs_f64();
    }
    let t = Instant::now();
    let (inputs, counts) = slicer.finish();
    slice_s += t.elapsed().as_secs_f64();
    let t = Instant::now();
    let out = match_inputs(&inputs, &sc.features(), &PoleConfig::default());
    let match_s = t.elapsed().as_secs_f64();

    // DG error (horizontal) at a time, and a detection's pole.
    let dg_error = |t: f64| {
        let (d, r) = (dg.interpolate(t, Linear).unwrap(), truth.interpolate(t, Linear).unwrap());
        [d.position.x() - r.position.x(), d.position.y() - r.position.y()]
    };
    let pole_of = |t: f64, c: [f64; 2]| {
        let e = dg_error(t);
        sc.world_pole([c[0] - e[0], c[1] - e[1]])
    };
    let records: Vec<[f64; 2]> = truth.records().iter().map(|r| [r.position.x(), r.position.y()]).collect();
    let near = |p: &plumbline_synth::world::Pole| {
        records.iter().step_by(20).any(|r| (r[0] - p.base[0]).hypot(r[1] - p.base[1]) <= 15.0)
    };
    let by_key: HashMap<String, &plumbline_synth::cadastre::CadastreObject> =
        sc.cadastre.iter().filter_map(|o| o.cadastre_id.map(|id| (format!("0:{id}"), o))).collect();
    let (mut detected, mut matches, mut wrong) = (std::collections::BTreeSet::new(), 0usize, 0usize);
    let mut false_detections = 0usize;
    for report in &out.reports {
        let FrameReport::V1(r) = report;
        let truth_of: Vec<Option<u32>> = r.detections.iter().map(|d| pole_of(r.time, d.centre)).collect();
        false_detections += truth_of.iter().filter(|t| t.is_none()).count();
        if args.missed {
            for (d, _) in r.detections.iter().zip(&truth_of).filter(|(_, t)| t.is_none()) {
                let e = dg_error(r.time);
                let (x, y) = (d.centre[0] - e[0], d.centre[1] - e[1]);
                let mut seen: HashMap<String, usize> = HashMap::new();
                for i in -1..=1 {
                    for j in -1..=1 {
                        let cell = ((x / 0.25).floor() as i64 + i, (y / 0.25).floor() as i64 + j);
                        for (k, n) in surfaces.get(&cell).into_iter().flatten() {
                            *seen.entry(k.clone()).or_default() += n;
                        }
                    }
                }
                println!(
                    "|   off any pole: {:.1} m, {} points, extent {:.2?}, ⌀ {:.3}, surfaces {seen:?} |",
                    d.range_m, d.points, d.height_extent_m, d.diameter_m
                );
            }
        }
        detected.extend(truth_of.iter().flatten().copied());
        if args.missed {
            for (d, t) in r.detections.iter().zip(&truth_of) {
                if let (Some(id), true) = (t, (d.diameter_m - 0.08).abs() < 1e-9) {
                    println!(
                        "|   thin on pole {id}: {:.1} m, {} points, extent {:.2?} |",
                        d.range_m, d.points, d.height_extent_m
                    );
                }
            }
        }
        for m in &r.matches {
            matches += 1;
            if by_key[&m.cadastre_id].world_id != truth_of[m.detection] {
                wrong += 1;
            }
        }
    }
    println!("\n| laser scanner (roof profile scanner, {} profiles/s) | value |\n|---|---|", scanner.profile_rate_hz);
    println!("| points / LAZ bytes | {:.1} M / {:.0} MB |", points as f64 / 1e6, bytes as f64 / 1e6);
    println!("| scan + compress (simulation) | {scan_s:.1} s |");
    println!("| LAZ read | {read_s:.1} s ({:.2} M points/s) |", points as f64 / read_s / 1e6);
    println!(
        "| of which the `laz` decoder alone (same fields) | {decode_s:.1} s ({:.2} M points/s) |",
        points as f64 / decode_s / 1e6
    );
    println!(
        "| COPC read, every node ({:.0} MB against {:.0} MB of LAZ) | {copc_s:.1} s ({:.2} M points/s) |",
        copc_bytes as f64 / 1e6,
        bytes as f64 / 1e6,
        points as f64 / copc_s / 1e6
    );
    println!("| LAZ read + slices + stems | {slice_s:.1} s ({:.2} M points/s) |", points as f64 / slice_s / 1e6);
    println!("| matching | {match_s:.2} s |\n| slices searched | {} |", counts.slices);
    for (name, trees) in [("poles", false), ("trees", true)] {
        let class = |p: &&plumbline_synth::world::Pole| (p.class == plumbline_synth::world::PoleClass::Tree) == trees;
        let near: Vec<u32> = sc.world.poles.iter().filter(class).filter(|p| near(p)).map(|p| p.id).collect();
        let hit: Vec<u32> = near.iter().copied().filter(|id| band_hits.get(id).is_some_and(|&n| n >= 10)).collect();
        let found = |ids: &[u32]| ids.iter().filter(|id| detected.contains(id)).count();
        println!(
            "| {name} within 15 m: detected / all | {} / {} ({:.1} %) |",
            found(&near),
            near.len(),
            100.0 * found(&near) as f64 / near.len().max(1) as f64
        );
        println!(
            "| {name} hit ≥ 10× at 1.0–1.6 m: detected / all | {} / {} ({:.1} %) |",
            found(&hit),
            hit.len(),
            100.0 * found(&hit) as f64 / hit.len().max(1) as f64
        );
        if args.missed {
            for p in sc.world.poles.iter().filter(|p| near.contains(&p.id) && !detected.contains(&p.id)) {
                let d =
                    records.iter().map(|r| (r[0] - p.base[0]).hypot(r[1] - p.base[1])).fold(f64::INFINITY, f64::min);
                let hits = band_hits.get(&p.id).copied().unwrap_or(0);
                println!(
                    "|   missed {:?} {} ⌀ {:.3} m, {d:.1} m from the drive, {hits} band hits at {:.1},{:.1} |",
                    p.class, p.id, p.diameter, p.base[0], p.base[1]
                );
            }
        }
    }
    println!("| detections off any pole (> 0.5 m) | {false_detections} |");
    println!(
        "| matches / wrong | {matches} / {wrong} (precision {:.2} %) |",
        100.0 * (1.0 - wrong as f64 / matches.max(1) as f64)
    );
    // χ² of the CUPTs per pole (the cadastre error shared by a pole's updates), as for the depth path.
    let mut per_pole: BTreeMap<String, Vec<([f64; 2], f64, f64)>> = BTreeMap::new();
    for u in &out.updates {
        let e = dg_error(u.time);
        let r = [u.cadastre[0] - (u.observed[0] - e[0]), u.cadastre[1] - (u.observed[1] - e[1])];
        per_pole.entry(u.cadastre_id.clone()).or_default().push((r, u.sigma_camera, u.sigma_pole));
    }
    let dof = 2 * per_pole.len();
    let chi2: f64 = per_pole
        .values()
        .map(|rs| {
            let m = rs.len() as f64;
            let mean = rs.iter().fold([0.0; 2], |a, (r, _, _)| [a[0] + r[0] / m, a[1] + r[1] / m]);
            let cam = rs.iter().map(|(_, c, _)| c * c).sum::<f64>() / m;
            (mean[0].powi(2) + mean[1].powi(2)) / (rs[0].2.powi(2) + cam / m)
        })
        .sum();
    let (lo, hi) = chi2_bounds(dof);
    println!("| CUPTs / poles with CUPTs | {} / {} |", out.updates.len(), per_pole.len());
    println!("| χ² (dof {dof}) | {chi2:.1} (1 % bounds {lo:.1}–{hi:.1}) |");
}

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
