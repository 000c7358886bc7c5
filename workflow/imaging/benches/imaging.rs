//! Per-primitive timings, and KAZE/AKAZE time, keypoints, repeatability and inliers on a 1 MP synthetic pair
//! beside OpenCV's, and brute-force descriptor matching (AKAZE Hamming, KAZE L2) beside OpenCV's BFMatcher.
//! Run: `cargo bench -p plumbline-imaging [-- features | matching]` (medians of repeated runs);
//! `benches/compare_opencv.sh` runs OpenCV (opencv_akaze.py) and ours interleaved and fills the OpenCV columns.
//!
//! The matching rows use a real pair when `PLUMBLINE_GRAF_DIR` names a folder holding the Oxford affine
//! "graf" images `img1.ppm` and `img2.ppm` (800 × 640, not in this repository; binary PPM, 8-bit), else the
//! synthetic pair. `-- export-descriptors DIR` writes that pair's descriptors for opencv_akaze.py `--match DIR`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use plumbline_fixtures::imaging as scene;

use std::time::Instant;

use nalgebra::Matrix3;
use plumbline_geo::camera::Equirectangular;
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::{Attitude, MapFromBody, Point3};
use plumbline_imaging::GrayImage;
use plumbline_imaging::akaze::{AkazeConfig, Features, Keypoint, akaze, match_descriptors};
use plumbline_imaging::corners::{Foerstner, Harris};
use plumbline_imaging::filter::{Wallis, gaussian_blur};
use plumbline_imaging::integral::IntegralImage;
use plumbline_imaging::kaze::{KazeConfig, KazeFeatures, kaze, match_surf};
use plumbline_imaging::lsm::{LsmConfig, least_squares_match, translation};
use plumbline_imaging::models::{Correspondence, Model};
use plumbline_imaging::ncc::NccSearcher;
use plumbline_imaging::ortho::{Exposure, GroundGrid, ortho_project};
use plumbline_imaging::ransac::{RansacConfig, ransac};
use plumbline_imaging::warp::{apply_h, resize, rotate};

/// Median wall time of `runs` calls, milliseconds.
fn time<T>(runs: usize, mut f: impl FnMut() -> T) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            std::hint::black_box(f());
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// CPU time of this process so far, all threads alive, nanoseconds: the first field of every
/// /proc/self/task/*/schedstat (Linux). A shared machine inflates wall time; CPU time much less.
fn cpu_ns() -> Option<u64> {
    let mut total = 0;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total)
}

/// Median CPU time of `runs` calls, milliseconds (0 where /proc is unavailable).
fn cpu_time<T>(runs: usize, mut f: impl FnMut() -> T) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let start = cpu_ns().unwrap_or(0);
            std::hint::black_box(f());
            cpu_ns().unwrap_or(0).saturating_sub(start) as f64 * 1e-6
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn single<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(f)
}

fn primitives(a: &GrayImage, b: &GrayImage) {
    let rows: Vec<(&str, f64)> = vec![
        ("gaussian blur σ=2, 1 MP", time(5, || gaussian_blur(a, 2.0).unwrap())),
        ("Wallis 31×31, 1 MP", time(5, || Wallis::default().apply(a).unwrap())),
        ("resize ×0.25 (3 → 12 cm), 1 MP", time(5, || resize(a, 0.25).unwrap())),
        ("rotate 0.3 rad, 1 MP", time(5, || rotate(a, 0.3).unwrap())),
        ("integral images (sum, sum²), 1 MP", time(5, || IntegralImage::new(a))),
        ("zero-mean NCC: 200 × (15² template, ±10 px)", time(5, || ncc_batch(a, b))),
        ("LSM: 200 × 17² template", time(5, || lsm_batch(a))),
        ("Förstner detect + locate, 1 MP", time(3, || Foerstner::default().detect(a).unwrap().len())),
        ("Harris detect, 1 MP", time(3, || Harris::default().detect(a).unwrap().len())),
        ("RANSAC homography, 2000 pairs, 50 % out", time(5, ransac_batch)),
        ("ortho 4096×2048 pano → 400² at 3 cm", ortho_bench()),
    ];
    println!("| primitive (rayon, all cores) | median ms |\n|---|---|");
    for (name, ms) in rows {
        println!("| {name} | {ms:.1} |");
    }
}

fn ncc_batch(a: &GrayImage, b: &GrayImage) -> f64 {
    let s = NccSearcher::new(b);
    (0..200)
        .map(|i| {
            let (c, r) = (40 + (i * 37) % 940, 40 + (i * 91) % 940);
            s.search(&a.patch(c, r, 7).unwrap(), c, r, 10).map_or(0.0, |m| m.score)
        })
        .sum()
}

fn lsm_batch(a: &GrayImage) -> usize {
    let blurred = gaussian_blur(a, 1.0).unwrap();
    (0..200)
        .filter(|i| {
            let (c, r) = (40 + (i * 37) % 940, 40 + (i * 91) % 940);
            let t = blurred.patch(c, r, 8).unwrap();
            least_squares_match(&t, &blurred, translation(c as f64 + 0.8, r as f64 + 0.3), &LsmConfig::default())
                .is_ok()
        })
        .count()
}

fn ransac_batch() -> usize {
    let h = Matrix3::new(0.9, 0.1, 50.0, -0.05, 1.1, -20.0, 2e-4, -1e-4, 1.0);
    let mut rng = scene::SplitMix(7);
    let pairs: Vec<Correspondence> = (0..2000)
        .map(|i| {
            let a = [rng.uniform(0.0, 1000.0), rng.uniform(0.0, 1000.0)];
            let (u, v) = apply_h(&h, a[0], a[1]).unwrap();
            let b = if i % 2 == 0 {
                [u + rng.uniform(-0.2, 0.2), v + rng.uniform(-0.2, 0.2)]
            } else {
                [rng.uniform(0.0, 1000.0), rng.uniform(0.0, 1000.0)]
            };
            Correspondence { a, b }
        })
        .collect();
    ransac(Model::Homography, &pairs, &RansacConfig::default()).unwrap().inlier_count()
}

fn ortho_bench() -> f64 {
    let cam = Equirectangular::new(4096, 2048).unwrap();
    let pano = GrayImage::from_fn(4096, 2048, |c, r| ((c / 16 + r / 16) % 2) as f32 * 200.0);
    let pose = MapFromBody::new(Attitude::from_degrees(0.5, -1.0, 30.0).to_rotation(), Point3::new(100.0, 200.0, 0.5));
    let mount = CameraMount::new([0.0, 0.0, -2.0], &Boresight::default());
    let grid = GroundGrid::new([100.0, 200.0], 0.03, 400, 400, 0.0).unwrap();
    let exposure = Exposure { camera: &cam, mount: &mount, pose: &pose, sub_cameras: None, rolling: None };
    time(5, || ortho_project(&pano, None, &exposure, &grid, |_, _| 0.0).unwrap())
}

/// Keypoint positions of A and B, and the correspondences of their mutual ratio-test matches.
struct Detected {
    a: Vec<(f64, f64)>,
    b: Vec<(f64, f64)>,
    pairs: Vec<Correspondence>,
}

/// Detection and matching on an image pair.
type PairRun = Box<dyn Fn(&GrayImage, &GrayImage) -> Detected>;

/// OpenCV's figures for one detector: wall and CPU ms (1 thread), keypoints A, repeatability, inliers.
#[derive(Clone, Copy)]
struct OpenCv {
    ms: f64,
    cpu_ms: f64,
    keypoints: usize,
    repeatability: f64,
    inliers: usize,
}

/// One detector of the table: its name and how to detect and match on an image pair.
struct Detector {
    name: &'static str,
    run: Box<dyn Fn(&GrayImage) -> usize + Sync>,
    pair: PairRun,
}

fn akaze_detector(name: &'static str, upright: bool) -> Detector {
    let cfg = AkazeConfig { upright, ..AkazeConfig::default() };
    Detector {
        name,
        run: Box::new(move |img| akaze(img, &cfg).unwrap().keypoints.len()),
        pair: Box::new(move |a, b| {
            let (fa, fb): (Features, Features) = (akaze(a, &cfg).unwrap(), akaze(b, &cfg).unwrap());
            let m = match_descriptors(&fa.descriptors, &fb.descriptors, 0.8, true);
            let pairs = m.iter().map(|m| corr(&fa.keypoints[m.a], &fb.keypoints[m.b])).collect();
            Detected { a: positions(&fa.keypoints), b: positions(&fb.keypoints), pairs }
        }),
    }
}

fn kaze_detector() -> Detector {
    let cfg = KazeConfig::default();
    Detector {
        name: "KAZE",
        run: Box::new(move |img| kaze(img, &cfg).unwrap().keypoints.len()),
        pair: Box::new(move |a, b| {
            let (fa, fb): (KazeFeatures, KazeFeatures) = (kaze(a, &cfg).unwrap(), kaze(b, &cfg).unwrap());
            let m = match_surf(&fa.descriptors, &fb.descriptors, 0.8, true);
            let pairs = m.iter().map(|&(i, j, _)| corr(&fa.keypoints[i], &fb.keypoints[j])).collect();
            Detected { a: positions(&fa.keypoints), b: positions(&fb.keypoints), pairs }
        }),
    }
}

fn positions(kps: &[Keypoint]) -> Vec<(f64, f64)> {
    kps.iter().map(|k| (k.u, k.v)).collect()
}

fn corr(a: &Keypoint, b: &Keypoint) -> Correspondence {
    Correspondence { a: [a.u, a.v], b: [b.u, b.v] }
}

/// (repeatability, inliers) of A → B under the known similarity: the share of A's keypoints projected
/// inside B (16 px margin) with a B keypoint within 2.5 px; RANSAC similarity inliers at 2.5 px.
fn quality(d: &Detected, truth: &Matrix3<f64>, size: f64) -> (f64, usize) {
    let inside: Vec<(f64, f64)> =
        d.a.iter()
            .filter_map(|&(u, v)| apply_h(truth, u, v))
            .filter(|(u, v)| *u > 16.0 && *v > 16.0 && *u < size - 16.0 && *v < size - 16.0)
            .collect();
    let hits = inside.iter().filter(|(u, v)| d.b.iter().any(|k| (k.0 - u).hypot(k.1 - v) < 2.5)).count();
    let inliers = ransac(Model::Similarity, &d.pairs, &RansacConfig { threshold: 2.5, ..RansacConfig::default() })
        .map_or(0, |f| f.inlier_count());
    (hits as f64 / inside.len().max(1) as f64, inliers)
}

/// OpenCV's row for a detector from the file `OPENCV_RESULTS` names (written by `opencv_akaze.py --tsv`).
fn opencv_row(name: &str) -> Option<OpenCv> {
    let text = std::fs::read_to_string(std::env::var("OPENCV_RESULTS").ok()?).ok()?;
    let line = text.lines().find(|l| l.split('\t').next() == Some(name))?;
    let f: Vec<&str> = line.split('\t').collect();
    Some(OpenCv {
        ms: f.get(1)?.parse().ok()?,
        cpu_ms: f.get(8)?.parse().ok()?,
        keypoints: f.get(3)?.parse().ok()?,
        repeatability: f.get(5)?.parse().ok()?,
        inliers: f.get(7)?.parse().ok()?,
    })
}

fn features(a: &GrayImage, b: &GrayImage, truth: &Matrix3<f64>) {
    println!(
        "\n| 1024² pair (0.2 rad, ×0.8, gain 0.7) | ours ms (1 thread) | ours ms (all threads) | OpenCV ms (1 thread) | ratio ours/OpenCV | CPU ms 1 thread (ours / OpenCV) | CPU ratio | keypoints A (ours / OpenCV) | repeatability (ours / OpenCV) | inliers (ours / OpenCV) |\n|---|---|---|---|---|---|---|---|---|---|"
    );
    for det in [akaze_detector("AKAZE", false), akaze_detector("AKAZE upright", true), kaze_detector()] {
        let one = single(|| time(5, || (det.run)(a)));
        let cpu = single(|| cpu_time(5, || (det.run)(a)));
        let all = time(5, || (det.run)(a));
        let detected = (det.pair)(a, b);
        let (rep, inl) = quality(&detected, truth, 1024.0);
        let cv = opencv_row(det.name);
        let show = |f: fn(OpenCv, [f64; 2]) -> String| cv.map_or("–".to_string(), |c| f(c, [one, cpu]));
        println!(
            "| {} | {one:.0} | {all:.0} | {} | {} | {cpu:.0} / {} | {} | {} / {} | {rep:.3} / {} | {inl} / {} |",
            det.name,
            show(|c, _| format!("{:.0}", c.ms)),
            show(|c, t| format!("{:.2}", t[0] / c.ms)),
            show(|c, _| format!("{:.0}", c.cpu_ms)),
            show(|c, t| format!("{:.2}", t[1] / c.cpu_ms)),
            detected.a.len(),
            show(|c, _| c.keypoints.to_string()),
            show(|c, _| format!("{:.3}", c.repeatability)),
            show(|c, _| c.inliers.to_string()),
        );
    }
}

/// `imaging profile akaze|akaze-upright|kaze`: one detection on image A, nothing else, inside a one-thread
/// pool so that callgrind's `--toggle-collect='*akaze::akaze*'` (or `'*kaze::kaze*'`) sees all its work.
fn profile(which: &str, a: &GrayImage) {
    let n = single(|| match which {
        "akaze" => akaze(a, &AkazeConfig::default()).unwrap().keypoints.len(),
        "akaze-upright" => akaze(a, &AkazeConfig { upright: true, ..AkazeConfig::default() }).unwrap().keypoints.len(),
        "kaze" => kaze(a, &KazeConfig::default()).unwrap().keypoints.len(),
        other => panic!("unknown detector {other}"),
    });
    println!("{which}: {n} keypoints");
}

/// The pair of the matching rows: the "graf" images 1 and 2 from `PLUMBLINE_GRAF_DIR`, else the synthetic pair.
fn matching_pair(a: &GrayImage, b: &GrayImage) -> (String, GrayImage, GrayImage) {
    let Some(dir) = std::env::var_os("PLUMBLINE_GRAF_DIR") else {
        return ("synthetic 1024² pair".to_string(), a.clone(), b.clone());
    };
    let dir = std::path::PathBuf::from(dir);
    let read = |name: &str| {
        let path = dir.join(name);
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        read_ppm(&bytes).unwrap_or_else(|| panic!("{}: not an 8-bit binary PPM/PGM", path.display()))
    };
    ("graf 1 → 2 (800×640)".to_string(), read("img1.ppm"), read("img2.ppm"))
}

/// A binary PGM (P5) or PPM (P6) with maxval 255, as grey; colour by OpenCV's integer weights (BT.601 in
/// 14-bit fixed point, rounded), so that both sides see the same grey image.
fn read_ppm(bytes: &[u8]) -> Option<GrayImage> {
    let mut fields = Vec::new();
    let mut at = 0;
    while fields.len() < 4 {
        while bytes.get(at)?.is_ascii_whitespace() || *bytes.get(at)? == b'#' {
            if bytes[at] == b'#' {
                while *bytes.get(at)? != b'\n' {
                    at += 1;
                }
            }
            at += 1;
        }
        let start = at;
        while !bytes.get(at)?.is_ascii_whitespace() {
            at += 1;
        }
        fields.push(std::str::from_utf8(&bytes[start..at]).ok()?);
    }
    let channels = match fields[0] {
        "P5" => 1,
        "P6" => 3,
        _ => return None,
    };
    let (w, h): (usize, usize) = (fields[1].parse().ok()?, fields[2].parse().ok()?);
    let pixels = bytes.get(at + 1..at + 1 + w * h * channels)?;
    if fields[3] != "255" {
        return None;
    }
    let data = pixels
        .chunks_exact(channels)
        .map(|p| match p {
            [g] => f32::from(*g),
            [r, g, b] => ((u32::from(*r) * 4899 + u32::from(*g) * 9617 + u32::from(*b) * 1868 + 8192) >> 14) as f32,
            _ => 0.0,
        })
        .collect();
    GrayImage::new(w, h, data).ok()
}

/// AKAZE and KAZE features (default settings) of both images of the matching pair.
fn matching_features(a: &GrayImage, b: &GrayImage) -> ([Features; 2], [KazeFeatures; 2]) {
    let (ac, kc) = (AkazeConfig::default(), KazeConfig::default());
    ([akaze(a, &ac).unwrap(), akaze(b, &ac).unwrap()], [kaze(a, &kc).unwrap(), kaze(b, &kc).unwrap()])
}

/// `imaging export-descriptors DIR`: the matching pair's descriptors as raw little-endian files for
/// `opencv_akaze.py --match DIR`: akaze_{a,b}.u8 (64 bytes a descriptor: the 8 words' bytes) and
/// kaze_{a,b}.f32 (64 floats a descriptor).
fn export_descriptors(dir: &str, a: &GrayImage, b: &GrayImage) {
    let (name, a, b) = matching_pair(a, b);
    let ([fa, fb], [ka, kb]) = matching_features(&a, &b);
    std::fs::create_dir_all(dir).unwrap();
    let path = |f: &str| std::path::Path::new(dir).join(f);
    for (file, f) in [("akaze_a.u8", &fa), ("akaze_b.u8", &fb)] {
        let bytes: Vec<u8> = f.descriptors.iter().flatten().flat_map(|w| w.to_le_bytes()).collect();
        std::fs::write(path(file), bytes).unwrap();
    }
    for (file, f) in [("kaze_a.f32", &ka), ("kaze_b.f32", &kb)] {
        let bytes: Vec<u8> = f.descriptors.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        std::fs::write(path(file), bytes).unwrap();
    }
    println!(
        "{name}: AKAZE {} × {}, KAZE {} × {} descriptors written to {dir}",
        fa.descriptors.len(),
        fb.descriptors.len(),
        ka.descriptors.len(),
        kb.descriptors.len()
    );
}

/// OpenCV BFMatcher's figures on our exported descriptors (`opencv_akaze.py --match`): knnMatch k = 2 wall ms
/// with 1 thread and with all, CPU ms 1 thread, knnMatch k = 2 plus the backward k = 1 match of a mutual
/// check (1 thread), and its ratio-0.8 mutual matches.
#[derive(Clone, Copy)]
struct OpenCvMatch {
    one: f64,
    all: f64,
    cpu: f64,
    mutual: f64,
    matches: usize,
}

/// OpenCV's matching row `match NAME` from the file `OPENCV_RESULTS` names, if its counts are `na` × `nb`.
fn opencv_match_row(name: &str, na: usize, nb: usize) -> Option<OpenCvMatch> {
    let text = std::fs::read_to_string(std::env::var("OPENCV_RESULTS").ok()?).ok()?;
    let key = format!("match {name}");
    let f: Vec<&str> = text.lines().find(|l| l.split('\t').next() == Some(key.as_str()))?.split('\t').collect();
    let counts: (usize, usize) = (f.get(1)?.parse().ok()?, f.get(2)?.parse().ok()?);
    if counts != (na, nb) {
        eprintln!("OpenCV's {name} descriptors are {} × {}, ours {na} × {nb}: not shown", counts.0, counts.1);
        return None;
    }
    Some(OpenCvMatch {
        one: f.get(3)?.parse().ok()?,
        all: f.get(4)?.parse().ok()?,
        cpu: f.get(5)?.parse().ok()?,
        mutual: f.get(6)?.parse().ok()?,
        matches: f.get(7)?.parse().ok()?,
    })
}

/// Matching rows: `match_descriptors` (AKAZE, Hamming) and `match_surf` (KAZE, L2), ratio 0.8, mutual, as the
/// features rows use them; times per call and per descriptor pair (|A| · |B| distances), beside OpenCV.
fn matching(a: &GrayImage, b: &GrayImage) {
    let (name, a, b) = matching_pair(a, b);
    let ([fa, fb], [ka, kb]) = matching_features(&a, &b);
    println!(
        "\n| matching, {name}, ratio 0.8, mutual | descriptors A × B | matches (ours / OpenCV) | ours ms (all threads) | ours ms (1 thread) | CPU ms 1 thread | ns per pair (1 thread) | OpenCV knnMatch ms (1 thread / all) | OpenCV CPU ms 1 thread | OpenCV ns per pair (1 thread) | OpenCV knn + back ms (1 thread) | ratio ours/OpenCV knn (1 thread) |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    type Run<'a> = Box<dyn Fn() -> usize + Sync + 'a>;
    let rows: [(&str, usize, usize, Run); 2] = [
        (
            "AKAZE",
            fa.descriptors.len(),
            fb.descriptors.len(),
            Box::new(|| match_descriptors(&fa.descriptors, &fb.descriptors, 0.8, true).len()),
        ),
        (
            "KAZE",
            ka.descriptors.len(),
            kb.descriptors.len(),
            Box::new(|| match_surf(&ka.descriptors, &kb.descriptors, 0.8, true).len()),
        ),
    ];
    for (det, na, nb, run) in rows {
        let matches = run();
        let all = time(5, &run);
        let one = single(|| time(5, &run));
        let cpu = single(|| cpu_time(5, &run));
        let pairs = (na * nb).max(1) as f64;
        let cv = opencv_match_row(det, na, nb);
        let show = |f: &dyn Fn(OpenCvMatch) -> String| cv.map_or("–".to_string(), f);
        println!(
            "| {det} | {na} × {nb} | {matches} / {} | {all:.1} | {one:.1} | {cpu:.1} | {:.2} | {} | {} | {} | {} | {} |",
            show(&|c| c.matches.to_string()),
            one * 1e6 / pairs,
            show(&|c| format!("{:.1} / {:.1}", c.one, c.all)),
            show(&|c| format!("{:.1}", c.cpu)),
            show(&|c| format!("{:.2}", c.one * 1e6 / pairs)),
            show(&|c| format!("{:.1}", c.mutual)),
            show(&|c| format!("{:.2}", one / c.one)),
        );
    }
}

fn main() {
    let blobs = scene::blobs(42, 3000, 1024.0);
    let truth = scene::truth(1024.0);
    let a = scene::render(1024, &blobs, &Matrix3::identity(), 1.0, 1.0, 128.0);
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|x| x == "profile") {
        return profile(args.get(i + 1).map_or("akaze", String::as_str), &a);
    }
    let b = scene::render(1024, &blobs, &truth, 0.8, 0.7, 0.7 * 128.0 + 25.0);
    if let Some(i) = args.iter().position(|x| x == "export-descriptors") {
        return export_descriptors(args.get(i + 1).map_or("descriptors", String::as_str), &a, &b);
    }
    println!("threads: {}", rayon::current_num_threads());
    // Sections named on the command line (`features`, `matching`), or all of them.
    let named = |what: &str| args.iter().any(|x| x == what);
    let all = !named("features") && !named("matching");
    if all {
        primitives(&a, &b);
    }
    if all || named("features") {
        features(&a, &b, &truth);
    }
    if all || named("matching") {
        matching(&a, &b);
    }
}
