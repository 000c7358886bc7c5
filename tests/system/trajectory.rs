//! End-to-end tests of `plumbline trajectory convert|compare`, running the real binary on files in a temp dir.

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

use crate::support;

use support::{plumbline, write};

/// A trajectory driving a curve in Hamburg (EPSG:25832), east of the zone's central meridian (γ ≈ 0.8°).
fn hamburg_csv(n: usize) -> String {
    let mut s = String::from(
        "time[s],easting[m],northing[m],height[m],roll[deg],pitch[deg],heading[deg],\
         std_easting[m],std_northing[m],std_height[m],std_roll[deg],std_pitch[deg],std_heading[deg]\n",
    );
    for i in 0..n {
        let t = 345_600.0 + i as f64 * 0.1;
        let a = i as f64 * 0.01;
        let (e, north) = (565_800.0 + 30.0 * a.sin(), 5_933_900.0 + 30.0 * (1.0 - a.cos()));
        let heading = (90.0 - a.to_degrees()).rem_euclid(360.0);
        s += &format!("{t:.3},{e:.4},{north:.4},12.5,0.5,-1.25,{heading:.6},0.03,0.03,0.05,0.01,0.01,0.02\n");
    }
    s
}

fn parse_csv_rows(text: &str) -> Vec<Vec<f64>> {
    text.lines().skip(1).map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect()).collect()
}

#[test]
fn csv_to_sbet_and_back_preserves_the_trajectory() {
    let dir = tempfile::tempdir().unwrap();
    let input = write(&dir, "in.csv", &hamburg_csv(50));
    let sbet = dir.path().join("out.sbet");
    let smrmsg = dir.path().join("out.smrmsg");
    let back = dir.path().join("back.csv");
    let r = plumbline(&["trajectory", "convert", &input, sbet.to_str().unwrap(), "--from-epsg", "25832"])
        .args(["--out-smrmsg", smrmsg.to_str().unwrap()])
        .run();
    r.success();
    assert_eq!(std::fs::metadata(&sbet).unwrap().len(), 50 * 136);
    let r = plumbline(&["trajectory", "convert", sbet.to_str().unwrap(), back.to_str().unwrap()])
        .args(["--smrmsg", smrmsg.to_str().unwrap(), "--to-epsg", "25832"])
        .run();
    r.success();
    let a = parse_csv_rows(&hamburg_csv(50));
    let b = parse_csv_rows(&std::fs::read_to_string(&back).unwrap());
    assert_eq!(a.len(), b.len());
    for (ra, rb) in a.iter().zip(&b) {
        assert!((ra[0] - rb[0]).abs() < 1e-9, "time");
        for k in 1..4 {
            assert!((ra[k] - rb[k]).abs() < 1e-3, "position column {k}: {} vs {}", ra[k], rb[k]);
        }
        for k in 4..7 {
            let d = (ra[k] - rb[k] + 180.0).rem_euclid(360.0) - 180.0;
            assert!(d.abs() < 1e-6, "angle column {k}: {} vs {}", ra[k], rb[k]);
        }
        for k in 7..13 {
            assert!((ra[k] - rb[k]).abs() < 1e-9, "std column {k}: {} vs {}", ra[k], rb[k]);
        }
    }
}

#[test]
fn geographic_output_carries_true_heading() {
    // At 10°E (1° east of the central meridian of EPSG:25832) γ = atan(tan 1° · sin φ) ≈ 0.80°: a grid heading
    // of 90° is a true heading of ≈ 90.80°.
    let dir = tempfile::tempdir().unwrap();
    let header = "time,easting,northing,height,roll,pitch,heading\n";
    let (e, n) = (566_300.0, 5_933_000.0);
    let body = format!("0,{e},{n},10,0,0,90\n1,{},{n},10,0,0,90\n", e + 10.0);
    let input = write(&dir, "in.csv", &format!("{header}{body}"));
    let out = dir.path().join("geo.csv");
    plumbline(&["trajectory", "convert", &input, out.to_str().unwrap(), "--from-epsg", "25832", "--to-epsg", "4326"])
        .run()
        .success();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("time[s],latitude[deg],longitude[deg]") || text.contains("latitude"), "{text}");
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| h.starts_with(name)).unwrap();
    let row: Vec<f64> = text.lines().nth(1).unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    let (lon, lat) = (row[col("longitude")], row[col("latitude")]);
    let expected = ((lon - 9.0).to_radians().tan() * lat.to_radians().sin()).atan().to_degrees();
    assert!((lon - 10.0).abs() < 0.05 && (lat - 53.54).abs() < 0.05, "{lon} {lat}");
    assert!((row[col("heading")] - (90.0 + expected)).abs() < 1e-6, "{} vs {}", row[col("heading")], 90.0 + expected);
}

#[test]
fn compare_prints_the_hand_checked_table() {
    // Reference drives north at 1 m/s; the estimate is 0.00, 0.02, …, 0.38 m east (right of travel),
    // 0.05 m ahead and 0.10 m low. Hand-computed type-7 quantiles of the 20 values: median (0.18 + 0.20)/2
    // = 0.19; q95 at h = 0.95·19 = 18.05 → 0.36 + 0.05·0.02 = 0.361; q99 at 18.81 → 0.3762; max 0.38.
    let dir = tempfile::tempdir().unwrap();
    let header = "time,easting,northing,height,roll,pitch,heading\n";
    let reference: String = (0..=20).map(|i| format!("{i},1000,{},50,0,0,0\n", 2000 + i)).collect();
    let estimate: String = (0..20)
        .map(|i| format!("{i},{},{},49.9,0,0,0\n", 1000.0 + 0.02 * f64::from(i), 2000.05 + f64::from(i)))
        .collect();
    let reference = write(&dir, "ref.csv", &format!("{header}{reference}"));
    let estimate = write(&dir, "est.csv", &format!("{header}{estimate}"));
    let r = plumbline(&["trajectory", "compare", &estimate, &reference]).run();
    r.success();
    let line = |name: &str| r.stdout.lines().find(|l| l.starts_with(name)).unwrap().to_owned();
    let numbers = |l: String| -> Vec<f64> { l.split_whitespace().skip(1).map(|v| v.parse().unwrap()).collect() };
    let cross = numbers(line("cross-track"));
    assert_eq!(&cross[..4], &[0.190, 0.361, 0.376, 0.380], "{}", r.stdout);
    let along = numbers(line("along-track"));
    assert_eq!(&along[..4], &[0.050, 0.050, 0.050, 0.050], "{}", r.stdout);
    let height = numbers(line("height"));
    assert_eq!(&height[..4], &[0.100, 0.100, 0.100, 0.100], "{}", r.stdout);

    let r = plumbline(&["trajectory", "compare", &estimate, &reference, "--json"]).run();
    r.success();
    let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    assert!((v["cross"]["p95"].as_f64().unwrap() - 0.361).abs() < 1e-9);
    assert!((v["cross"]["p99"].as_f64().unwrap() - 0.3762).abs() < 1e-9);
    assert_eq!(v["cross"]["count"], 20);
    assert!(v.get("differences").is_none());
}

#[test]
fn bad_inputs_exit_2_naming_file_record_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let header = "time,easting,northing,height,roll,pitch,heading\n";
    let check = |name: &str, content: &[u8], args: &[&str], expect: &[&str]| {
        let path = dir.path().join(name);
        std::fs::write(&path, content).unwrap();
        let out = dir.path().join("out.csv");
        let mut all = vec!["trajectory", "convert", path.to_str().unwrap(), out.to_str().unwrap()];
        all.extend_from_slice(args);
        let r = plumbline(&all).run();
        r.failure_with(2);
        for e in expect {
            assert!(r.stderr.contains(e), "expected `{e}` in:\n{}", r.stderr);
        }
    };
    check(
        "nan.csv",
        format!("{header}0,1,2,3,0,0,0\n1,1,2,NaN,0,0,0\n").as_bytes(),
        &[],
        &["nan.csv", "line 3", "height"],
    );
    check(
        "unsorted.csv",
        format!("{header}0,1,2,3,0,0,0\n2,1,2,3,0,0,0\n1,1,2,3,0,0,0\n").as_bytes(),
        &[],
        &["unsorted.csv", "record 2", "time"],
    );
    check(
        "fast.csv",
        format!("{header}0,1,2,3,0,0,0\n1,500,2,3,0,0,0\n").as_bytes(),
        &[],
        &["fast.csv", "record 1", "speed"],
    );
    let mut sbet = vec![0u8; 136 * 3 + 40];
    sbet[..8].copy_from_slice(&1.0f64.to_le_bytes());
    check("cut.sbet", &sbet, &[], &["cut.sbet", "408"]);
    check(
        "epsg.csv",
        format!("{header}0,1,2,3,0,0,0\n").as_bytes(),
        &["--from-epsg", "25832", "--to-epsg", "999999"],
        &["999999"],
    );
    check(
        "units.csv",
        b"time,easting[deg],northing,height,roll,pitch,heading\n0,1,2,3,0,0,0\n",
        &[],
        &["units.csv", "easting"],
    );
}

#[test]
fn a_missing_input_is_invalid_input() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.csv");
    let out = dir.path().join("out.csv");
    let r = plumbline(&["trajectory", "convert", missing.to_str().unwrap(), out.to_str().unwrap()]).run();
    r.failure_with(2);
    assert!(r.stderr.contains("nope.csv"), "{}", r.stderr);
}
