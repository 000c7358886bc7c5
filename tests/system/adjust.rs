//! End-to-end tests of `plumbline adjust`: a seeded street drive whose DG trajectory is the truth shifted by
//! a known, slowly varying offset, pole coordinate updates made from the truth (two files, one pole 1 m off,
//! one broken), the corrected trajectory (CSV and SBET) checked against the truth, and bad input.

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

use crate::support;

use std::path::Path;

use support::{plumbline, write};

const HEADER: &str = "time[s],easting[m],northing[m],height[m],roll[deg],pitch[deg],heading[deg],\
    std_easting[m],std_northing[m],std_height[m],std_roll[deg],std_pitch[deg],std_heading[deg]\n";
const T0: f64 = 345_600.0;
const HEADING: f64 = 60.0;

/// The true body origin at time t: 10 m/s on a straight street, heading 60° (Hamburg, EPSG:25832).
fn truth(t: f64) -> [f64; 2] {
    let (s, c) = HEADING.to_radians().sin_cos();
    let d = 10.0 * (t - T0);
    [565_800.0 + d * s, 5_933_900.0 + d * c]
}

/// DG − truth (east, north), metres: what the adjustment must remove.
fn offset(t: f64) -> [f64; 2] {
    let u = t - T0;
    [0.25 + 0.1 * (u / 8.0).sin(), -0.15 + 0.05 * (u / 11.0).cos()]
}

fn trajectory_csv(duration: f64) -> String {
    let mut s = String::from(HEADER);
    for i in 0..=(duration * 10.0) as usize {
        let t = T0 + i as f64 * 0.1;
        let (p, o) = (truth(t), offset(t));
        s +=
            &format!("{t:.3},{:.4},{:.4},12.5,0,0,{HEADING},0.05,0.05,0.08,0.01,0.01,0.02\n", p[0] + o[0], p[1] + o[1]);
    }
    s
}

/// Deterministic standard normal draws (xorshift + Box–Muller).
struct Normal(u64);

impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn draw(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// A pole 8 m to the right of the vehicle every 3 s: observed with the DG pose, cadastre = truth + 2 cm noise.
fn poles(duration: f64, rng: &mut Normal) -> Vec<String> {
    let (s, c) = HEADING.to_radians().sin_cos();
    let right = [c * 8.0, -s * 8.0];
    (1..(duration / 3.0) as usize)
        .map(|k| {
            let t = T0 + 3.0 * k as f64;
            let (p, o) = (truth(t), offset(t));
            let pole = [p[0] + right[0], p[1] + right[1]];
            let cad = [pole[0] + 0.02 * rng.draw(), pole[1] + 0.02 * rng.draw()];
            format!(
                r#"{{"cadastre_id":"p{k}","time":{t},"cadastre":[{},{}],"observed":[{},{}],"sigma_camera":0.03,"sigma_pole":0.02}}"#,
                cad[0],
                cad[1],
                pole[0] + o[0],
                pole[1] + o[1]
            )
        })
        .collect()
}

fn set(poles: &[String]) -> String {
    format!(r#"{{"version":"1","poles":[{}]}}"#, poles.join(","))
}

fn rows(path: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines().skip(1).map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect()
}

/// Two observation files (the second holding one pole 1 m off and one with a negative σ).
fn observation_files(dir: &tempfile::TempDir, duration: f64) -> (String, String) {
    let mut all = poles(duration, &mut Normal(0x9e37_79b9_7f4a_7c15));
    let n = all.len();
    all[n - 5] = all[n - 5].replace(r#""sigma_pole":0.02"#, r#""sigma_pole":-0.02"#);
    let k = n - 8;
    let bad: serde_json::Value = serde_json::from_str(&all[k]).unwrap();
    let cad = bad["cadastre"].as_array().unwrap();
    let moved = format!("[{},{}]", cad[0].as_f64().unwrap() + 0.6, cad[1].as_f64().unwrap() + 0.8);
    all[k] = all[k].replace(&serde_json::to_string(&bad["cadastre"]).unwrap(), &moved);
    let (a, b) = all.split_at(n / 2);
    (write(dir, "first.json", &set(a)), write(dir, "second.json", &set(b)))
}

#[test]
fn the_corrected_csv_trajectory_lands_on_the_truth_and_the_summary_names_what_was_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let duration = 90.0;
    let traj = write(&dir, "dg.csv", &trajectory_csv(duration));
    let (first, second) = observation_files(&dir, duration);
    let out = dir.path().join("out");
    plumbline(&["adjust", "--trajectory", &traj, "--observations", &first, &second])
        .args(["--epsg", "25832", "--out", out.to_str().unwrap()])
        .run()
        .success();
    let corrected = rows(&out.join("trajectory.csv"));
    assert_eq!(corrected.len(), 901);
    let mut errors = Vec::new();
    for r in corrected.iter().filter(|r| r[0] > T0 + 3.0 && r[0] < T0 + duration - 3.0) {
        let p = truth(r[0]);
        errors.push((r[1] - p[0]).hypot(r[2] - p[1]));
        // Posterior σ: smaller than the DG's 5 cm, larger than nothing.
        assert!(r[7] > 0.003 && r[7] < 0.05, "σ east {}", r[7]);
    }
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    let worst = errors.iter().fold(0.0f64, |m, e| m.max(*e));
    eprintln!("corrected vs truth: rms {rms:.4} m, max {worst:.4} m (DG offset ~0.3 m)");
    // CUPTs with σ ≈ 3.6 cm every 30 m: ~1.5 cm expected; the 1 m blunder left in would bend it by decimetres.
    assert!(rms < 0.025 && worst < 0.07, "rms {rms}, max {worst}");
    // corrections.csv: the correction is minus the DG offset.
    let corrections = rows(&out.join("corrections.csv"));
    assert_eq!(corrections.len(), 901);
    let mid = &corrections[450];
    let o = offset(mid[0]);
    assert!((mid[1] + o[0]).abs() < 0.05 && (mid[2] + o[1]).abs() < 0.05, "{mid:?} vs {o:?}");

    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let rejected = summary["rejected"].as_array().unwrap();
    assert_eq!(rejected.len(), 1, "{rejected:?}");
    let n = summary["observations"]["poles"].as_u64().unwrap() as usize;
    let local = n - 8 - n / 2;
    assert_eq!(rejected[0]["observation"], format!("second.json: poles[{local}] (p{})", n - 7));
    assert!(rejected[0]["w"].as_f64().unwrap() > 10.0);
    let skipped = summary["skipped"].as_array().unwrap();
    assert_eq!(skipped.len(), 1, "{skipped:?}");
    assert_eq!(skipped[0]["field"], "sigma_pole");
    assert!(skipped[0]["observation"].as_str().unwrap().starts_with("second.json: poles["));
    assert!(summary["iterations"].as_u64().unwrap() >= 1 && summary["sigma0"].as_f64().unwrap() < 2.0);
    let flagged = summary["flagged_epochs"].as_array().unwrap();
    assert!(flagged.iter().any(|f| f["reason"] == "rejected_observation"));
}

#[test]
fn an_sbet_trajectory_comes_back_as_sbet_with_smrmsg() {
    let dir = tempfile::tempdir().unwrap();
    let duration = 45.0;
    let csv = write(&dir, "dg.csv", &trajectory_csv(duration));
    let sbet = dir.path().join("dg.sbet");
    let smrmsg = dir.path().join("dg.smrmsg");
    plumbline(&["trajectory", "convert", &csv, sbet.to_str().unwrap(), "--from-epsg", "25832"])
        .args(["--out-smrmsg", smrmsg.to_str().unwrap()])
        .run()
        .success();
    let obs = write(&dir, "poles.json", &set(&poles(duration, &mut Normal(7))));
    let out = dir.path().join("out");
    plumbline(&["adjust", "--trajectory", sbet.to_str().unwrap(), "--smrmsg", smrmsg.to_str().unwrap()])
        .args(["--observations", &obs, "--epsg", "25832", "--out", out.to_str().unwrap()])
        .run()
        .success();
    assert!(out.join("trajectory.smrmsg").exists());
    let back = dir.path().join("back.csv");
    plumbline(&["trajectory", "convert", out.join("trajectory.sbet").to_str().unwrap(), back.to_str().unwrap()])
        .args(["--smrmsg", out.join("trajectory.smrmsg").to_str().unwrap(), "--to-epsg", "25832"])
        .run()
        .success();
    let corrected = rows(&back);
    let inner = corrected.iter().filter(|r| r[0] > T0 + 3.0 && r[0] < T0 + duration - 3.0);
    let worst = inner.map(|r| (r[1] - truth(r[0])[0]).hypot(r[2] - truth(r[0])[1])).fold(0.0f64, f64::max);
    assert!(worst < 0.1, "max {worst} (DG offset ~0.3 m)");
    // The same adjustment from the CSV: the SBET path changes nothing but the encoding.
    let out_csv = dir.path().join("out_csv");
    plumbline(&["adjust", "--trajectory", &csv, "--observations", &obs, "--epsg", "25832"])
        .args(["--out", out_csv.to_str().unwrap()])
        .run()
        .success();
    let from_csv = rows(&out_csv.join("trajectory.csv"));
    assert_eq!(from_csv.len(), corrected.len());
    for (a, b) in corrected.iter().zip(&from_csv) {
        assert!((a[1] - b[1]).abs() < 1e-3 && (a[2] - b[2]).abs() < 1e-3, "{a:?} vs {b:?}");
        assert!((a[7] - b[7]).abs() < 1e-4, "σ east {} vs {}", a[7], b[7]);
        // The heading survives the round trip through true heading and meridian convergence.
        assert!((a[6] - b[6]).abs() < 1e-6, "heading {} vs {}", a[6], b[6]);
    }
}

#[test]
fn bad_input_exits_2_naming_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let traj = write(&dir, "dg.csv", &trajectory_csv(10.0));
    let out = dir.path().join("out");
    let bad = write(&dir, "bad.json", r#"{"version":"1","poles":[{"cadastre_id":"a","time":"noon"}]}"#);
    let r = plumbline(&["adjust", "--trajectory", &traj, "--observations", &bad, "--out", out.to_str().unwrap()]).run();
    r.failure_with(2);
    assert!(r.stderr.contains("bad.json") && r.stderr.contains("poles[0].time"), "{}", r.stderr);
    let broken = write(&dir, "broken.csv", &trajectory_csv(10.0).replacen("12.5", "x", 3));
    let good = write(&dir, "good.json", r#"{"version":"1"}"#);
    let r =
        plumbline(&["adjust", "--trajectory", &broken, "--observations", &good, "--out", out.to_str().unwrap()]).run();
    r.failure_with(2);
    assert!(r.stderr.contains("broken.csv"), "{}", r.stderr);
    let missing = dir.path().join("missing.json");
    let r = plumbline(&["adjust", "--trajectory", &traj, "--observations", missing.to_str().unwrap()])
        .args(["--out", out.to_str().unwrap()])
        .run();
    r.failure_with(2);
    assert!(r.stderr.contains("missing.json"), "{}", r.stderr);
}
