//! End-to-end tests of `plumbline simulate`: the written campaign validates, its trajectories parse back,
//! and `trajectory compare` of DG against truth reports the DG error series and the profile's error level.

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

mod support;

use support::plumbline;

/// Simulate a tiny campaign with `profile` into a fresh temp dir; returns the dir and the campaign prefix.
fn simulate(profile: &str, seed: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("camp").to_str().unwrap().to_owned();
    plumbline(&["simulate", "--preset", "tiny", "--seed", seed, "--profile", profile, "--out", &out]).run().success();
    (dir, out)
}

/// `trajectory compare ESTIMATE truth/trajectory.csv --json` in EPSG 25832.
fn compare(out: &str, estimate: &str) -> serde_json::Value {
    let truth = format!("{out}/truth/trajectory.csv");
    let r =
        plumbline(&["trajectory", "compare", &format!("{out}/{estimate}"), &truth, "--epsg", "25832", "--json"]).run();
    r.success();
    serde_json::from_str(&r.stdout).unwrap()
}

/// 3D RMS of the DG error series file.
fn error_series_rms(out: &str) -> (f64, usize) {
    let text = std::fs::read_to_string(format!("{out}/truth/dg_errors.csv")).unwrap();
    let mut sum = 0.0;
    let mut n = 0;
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line.split(',').skip(1).take(3).map(|x| x.parse().unwrap()).collect();
        sum += f.iter().map(|x| x * x).sum::<f64>();
        n += 1;
    }
    ((sum / n as f64).sqrt(), n)
}

#[test]
fn simulated_campaign_validates_and_compares_like_its_error_series() {
    let (_dir, out) = simulate("open", "5");
    plumbline(&["validate", &format!("{out}/campaign.toml")]).run().success();
    let png = std::fs::read(format!("{out}/overview.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let csv = compare(&out, "nav/dg.csv");
    let (series_rms, epochs) = error_series_rms(&out);
    // Same epochs as the truth: the comparison's 3D RMSE is the error series' RMS.
    let rmse_3d = csv["rmse_3d"].as_f64().unwrap();
    assert!((rmse_3d - series_rms).abs() < 1e-4, "compare {rmse_3d} vs series {series_rms}");
    assert_eq!(csv["cross"]["count"].as_u64().unwrap() as usize, epochs);
    // The SBET (WGS 84, through the CRS round trip) compares the same to 1 mm.
    let sbet = compare(&out, "nav/dg.sbet");
    assert!((sbet["rmse_3d"].as_f64().unwrap() - rmse_3d).abs() < 1e-3, "{sbet}");
    // Open sky: centimetre level (module doc of `motion::dg`: horizontal RMS 1–3.5 cm, 99 % 3–7 cm).
    let rmse_2d = csv["rmse_2d"].as_f64().unwrap();
    assert!(rmse_2d < 0.07 && csv["cross"]["p99"].as_f64().unwrap() < 0.12, "{csv}");
}

#[test]
fn canyon_campaigns_are_worse_than_open_sky_and_bad_arguments_exit_2() {
    let (_open_dir, open) = simulate("open", "6");
    let open_2d = compare(&open, "nav/dg.csv")["rmse_2d"].as_f64().unwrap();
    // A tiny drive holds only a few multipath jumps, so pool three seeds (module doc of `motion::dg`:
    // canyon RMS 25–60 cm over an hour, 1–3.5 cm in the open).
    let mut sum_sq = 0.0;
    let mut worst: f64 = 0.0;
    for seed in ["6", "7", "8"] {
        let (_dir, canyon) = simulate("canyon", seed);
        let c = compare(&canyon, "nav/dg.csv");
        sum_sq += c["rmse_2d"].as_f64().unwrap().powi(2);
        worst = worst.max(c["cross"]["max"].as_f64().unwrap());
    }
    let canyon_2d = (sum_sq / 3.0).sqrt();
    assert!(canyon_2d > 0.1 && canyon_2d > 3.0 * open_2d, "canyon {canyon_2d} vs open {open_2d}");
    assert!(worst > 0.2, "largest canyon cross-track difference {worst}");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    plumbline(&["simulate", "--preset", "huge", "--out", out]).run().failure_with(2);
}
