//! The `city` preset's navigation data end to end: raw GNSS and IMU streamed leg by leg run through the joins
//! and `plumbline navigate` fuses them back to the truth, with an overview map drawn leg by leg; `--length` is met to within a panorama spacing
//! without changing the legs before the cut; a campaign streamed to S3 (moto, multipart uploads) reads back
//! byte for byte as a local run wrote it.
#![allow(clippy::unwrap_used)]

use crate::support;

use std::path::Path;

use plumbline_fixtures::services::s3_files;
use plumbline_testkit::MotoServer;
use support::plumbline;

/// `plumbline simulate --preset city --navigation-only` of `length` into `out`; returns stderr.
fn simulate(length: &str, seed: &str, out: &str, extra: &[&str]) -> String {
    let args = ["simulate", "--preset", "city", "--navigation-only", "--length", length, "--seed", seed];
    let run = plumbline(&args).args(extra.iter().copied()).args(["--out", out]).run();
    run.success();
    run.stderr
}

/// The numeric columns of a CSV file (header skipped), `take` columns per row.
fn columns(path: &Path, take: usize) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines().skip(1).map(|l| l.split(',').take(take).map(|x| x.parse().unwrap()).collect()).collect()
}

/// Horizontal length of a trajectory's track, metres.
fn track_length(rows: &[Vec<f64>]) -> f64 {
    rows.windows(2).map(|w| (w[1][1] - w[0][1]).hypot(w[1][2] - w[0][2])).sum()
}

#[test]
fn raw_gnss_and_imu_run_through_the_joins_and_navigate_back_to_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    let stderr = simulate("1.1km", "2", sim.to_str().unwrap(), &["--profile", "open"]);
    assert!(stderr.matches("city leg").count() >= 3, "{stderr}");
    let manifest = std::fs::read_to_string(sim.join("campaign.toml")).unwrap();
    assert!(manifest.contains("gnss = \"nav/gnss.csv\"\nimu = \"nav/imu.csv\""), "{manifest}");
    plumbline(&["validate", sim.join("campaign.toml").to_str().unwrap()]).run().success();
    // One 200 Hz IMU series from the first epoch to the last: no gap at a join, no increment twice.
    let truth = columns(&sim.join("truth/trajectory.csv"), 4);
    let imu = columns(&sim.join("nav/imu.csv"), 2);
    assert_eq!(imu.len(), truth.len() - 1);
    for (w, t) in imu.windows(2).zip(&truth[1..]) {
        assert!((w[1][0] - w[0][0] - 0.005).abs() < 1e-6 && (w[0][0] - t[0]).abs() < 1e-6, "IMU at {}", w[0][0]);
    }
    // Open sky has no outage: one 5 Hz fix clock through the joins.
    let gnss = columns(&sim.join("nav/gnss.csv"), 4);
    for w in gnss.windows(2) {
        assert!((w[1][0] - w[0][0] - 0.2).abs() < 1e-6, "GNSS fixes at {} and {}", w[0][0], w[1][0]);
    }
    assert!((gnss.last().unwrap()[0] - truth.last().unwrap()[0]).abs() < 0.2 + 1e-6);
    // The overview map, drawn leg by leg: the longer side 1600 px, the track in the error ramp's greens (open
    // sky: centimetres) and the standstills in black.
    let overview = image::open(sim.join("overview.png")).unwrap().to_rgb8();
    assert_eq!(overview.width().max(overview.height()), 1600);
    let count = |f: &dyn Fn(&image::Rgb<u8>) -> bool| overview.pixels().filter(|p| f(p)).count();
    let (green, black) = (count(&|p| p.0[2] == 0 && p.0[1] > 150 && p.0[0] < 60), count(&|p| p.0 == [0, 0, 0]));
    assert!(green > 1000 && black >= 49 * 4, "{green} green, {black} black pixels");
    // The fusion of the raw data follows the truth through every join (GNSS white noise 5 mm, drift 1.5 cm):
    // a missing increment or restarted biases at a join would throw the filter off by decimetres.
    let nav = dir.path().join("nav");
    let (g, i) = (sim.join("nav/gnss.csv"), sim.join("nav/imu.csv"));
    plumbline(&["navigate", "--gnss", g.to_str().unwrap(), "--imu", i.to_str().unwrap(), "--lever-arm", "0,0,-0.4"])
        .args(["--imu-model", "navigation", "--out", nav.to_str().unwrap()])
        .run()
        .success();
    let smoothed = columns(&nav.join("trajectory.csv"), 4);
    assert_eq!(smoothed.len(), truth.len());
    let errors: Vec<f64> = smoothed
        .iter()
        .zip(&truth)
        .map(|(s, t)| {
            assert!((s[0] - t[0]).abs() < 1e-6);
            (s[1] - t[1]).hypot(s[2] - t[2])
        })
        .collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    let max = errors.iter().fold(0.0f64, |m, e| m.max(*e));
    assert!(rms < 0.05 && max < 0.12, "navigated horizontal error RMS {rms} m, max {max} m");
}

/// The metres driven after each leg, from `simulate`'s progress lines.
fn leg_ends(stderr: &str) -> Vec<f64> {
    stderr
        .lines()
        .filter_map(|l| l.strip_prefix("city leg ")?.split_once(": ")?.1.strip_suffix(" m driven")?.parse().ok())
        .collect()
}

#[test]
fn the_length_is_met_by_cutting_the_last_leg_only() {
    let dir = tempfile::tempdir().unwrap();
    let long = dir.path().join("long");
    simulate("1.6km", "3", long.to_str().unwrap(), &[]);
    let long_rows = columns(&long.join("truth/trajectory.csv"), 4);
    for (request, spacing) in [(640.0, "5"), (1111.0, "5"), (1270.0, "20")] {
        let out = dir.path().join(format!("cut{request}"));
        let args = ["--panorama-spacing", spacing];
        let stderr = simulate(&request.to_string(), "3", out.to_str().unwrap(), &args);
        let rows = columns(&out.join("truth/trajectory.csv"), 4);
        let driven = track_length(&rows);
        let spacing: f64 = spacing.parse().unwrap();
        assert!((driven - request).abs() <= spacing, "{driven} m driven for {request} m");
        // It ends standing: the last 5 s do not move.
        let still = &rows[rows.len() - 1000..];
        assert!(track_length(still) < 1e-3, "moves {} m in its last 5 s", track_length(still));
        // The legs before the cut one are the long run's, epoch for epoch.
        let ends = leg_ends(&stderr);
        assert!(ends.len() >= 2, "{stderr}");
        let kept = ends[ends.len() - 2];
        let same = rows.iter().zip(&long_rows).take_while(|(a, b)| a == b).count();
        assert!(track_length(&rows[..same]) >= kept - 1.0, "{same} epochs shared; legs before the cut {kept} m");
        assert!(same < rows.len(), "the cut leg is the long run's whole leg");
    }
}

/// Every file under `dir`, relative paths with `/`.
fn files_under(dir: &Path, base: &Path, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files_under(&path, base, out);
        } else {
            out.push(path.strip_prefix(base).unwrap().to_string_lossy().replace('\\', "/"));
        }
    }
}

#[test]
fn a_city_streamed_to_s3_reads_back_as_the_local_run_wrote_it() {
    let dir = tempfile::tempdir().unwrap();
    let local = dir.path().join("local");
    simulate("0.8km", "4", local.to_str().unwrap(), &["--imu", "consumer"]);
    let moto = MotoServer::start();
    moto.create_bucket("bucket");
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_plumbline"));
    cmd.args(["simulate", "--preset", "city", "--navigation-only", "--length", "0.8km", "--seed", "4"]).args([
        "--imu",
        "consumer",
        "--out",
        "s3://bucket/city",
    ]);
    for (key, _) in std::env::vars().filter(|(k, _)| k.starts_with("PLUMBLINE_")) {
        cmd.env_remove(key);
    }
    cmd.env("PLUMBLINE_S3_ENDPOINT", moto.endpoint())
        .env("PLUMBLINE_S3_ACCESS_KEY_ID", "test")
        .env("PLUMBLINE_S3_SECRET_ACCESS_KEY", "test");
    let run = cmd.output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success(), "{stderr}");
    assert_eq!(stdout.trim(), "s3://bucket/city/campaign.toml");
    let mut names = Vec::new();
    files_under(&local, &local, &mut names);
    assert!(names.len() >= 8, "{names:?}");
    let files = s3_files(moto.endpoint());
    let runtime = tokio::runtime::Runtime::new().unwrap();
    let mut largest = 0;
    for name in &names {
        let want = std::fs::read(local.join(name)).unwrap();
        let got = runtime.block_on(files.read(&format!("s3://bucket/city/{name}"))).unwrap();
        assert!(got.as_ref() == want.as_slice(), "{name}: {} bytes from S3, {} local", got.len(), want.len());
        largest = largest.max(want.len());
    }
    // Several 5 MiB parts went into the largest file (the IMU increments, ~12 MB).
    assert!(largest > 2 * plumbline_runtime::PART_SIZE, "largest file {largest} bytes");
}
