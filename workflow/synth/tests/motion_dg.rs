//! The DG error process: statistics per environment over several seeds, faults only where the street is
//! enclosed, smooth errors between faults, optimistic reported σ in canyons.
#![allow(clippy::unwrap_used)]

use plumbline_synth::motion::dg::{self, DgConfig, DgSolution, Environment, FaultKind};
use plumbline_synth::motion::routes::{self, DEEP_CANYON, URBAN_STREET};
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::route::{Canyon, Route};

/// One hour of driving at cruise speed without stops, at 50 Hz (the process is rate-independent).
fn hour_drive(canyon: Canyon) -> Drive {
    let config = DriveConfig { rate_hz: 50.0, stop_probability: 0.0, ..DriveConfig::default() };
    Drive::simulate(&routes::straight((0.0, 0.0), 45_000.0, 1000.0, canyon), &config, 0).unwrap()
}

fn quantile(mut xs: Vec<f64>, q: f64) -> f64 {
    plumbline_geo::metrics::quantile(&mut xs, q).unwrap_or(f64::NAN)
}

struct Stats {
    rms: f64,
    q99: f64,
    axis_rms: f64,
    reported: f64,
}

fn stats(dg: &DgSolution) -> Stats {
    let h: Vec<f64> = dg.errors.iter().map(|e| e.position.x().hypot(e.position.y())).collect();
    let n = h.len() as f64;
    let rms = (h.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    let reported = dg.trajectory.records().iter().map(|r| r.std.unwrap().east).sum::<f64>() / n;
    Stats { rms, q99: quantile(h, 0.99), axis_rms: rms / 2f64.sqrt(), reported }
}

#[test]
fn error_statistics_match_each_environment_over_several_seeds() {
    // The ranges documented in `motion::dg`: (environment, street, RMS range, 99 % range).
    let cases = [
        (Environment::Open, Canyon::OPEN, (0.010, 0.035), (0.03, 0.07)),
        (Environment::Urban, URBAN_STREET, (0.06, 0.16), (0.25, 0.65)),
        (Environment::Canyon, DEEP_CANYON, (0.25, 0.60), (0.9, 2.0)),
    ];
    for (env, street, rms_range, q99_range) in cases {
        let drive = hour_drive(street);
        for seed in 1..=4 {
            let dg = dg::simulate(&drive, &DgConfig::default(), seed).unwrap();
            assert!(dg.errors.iter().all(|e| e.environment == env));
            let s = stats(&dg);
            let name = env.name();
            println!(
                "{name} seed {seed}: RMS {:.3} m, 99 % {:.3} m, RMS/σ {:.2}",
                s.rms,
                s.q99,
                s.axis_rms / s.reported
            );
            assert!((rms_range.0..=rms_range.1).contains(&s.rms), "{name} seed {seed}: RMS {:.3}", s.rms);
            assert!((q99_range.0..=q99_range.1).contains(&s.q99), "{name} seed {seed}: 99 % {:.3}", s.q99);
            let honesty = s.axis_rms / s.reported;
            match env {
                Environment::Open => assert!((0.6..=1.6).contains(&honesty), "open seed {seed}: {honesty:.2}"),
                _ => assert!(honesty > 2.0, "{name} seed {seed}: reported σ not optimistic ({honesty:.2})"),
            }
            let faults = dg.faults.len();
            match env {
                Environment::Open => assert_eq!(faults, 0),
                _ => assert!(faults > 10, "{name} seed {seed}: {faults} faults in an hour"),
            }
        }
    }
}

/// Sections of 2 km: open, canyon, open, urban, open, canyon.
fn mixed_route() -> Route {
    let sections = [Canyon::OPEN, DEEP_CANYON, Canyon::OPEN, URBAN_STREET, Canyon::OPEN, DEEP_CANYON];
    let mut waypoints = Vec::new();
    for (i, c) in sections.iter().enumerate() {
        for j in 0..=4 {
            // Sections meet over 1 m, so the environment changes at a known place.
            let e = i as f64 * 2000.0 + if j == 0 && i > 0 { 1.0 } else { j as f64 * 499.75 };
            waypoints.push(routes::waypoint(e, 0.0, *c));
        }
    }
    Route { waypoints }
}

#[test]
fn jumps_only_where_enclosed_and_errors_smooth_between_faults() {
    let config = DriveConfig { rate_hz: 100.0, stop_probability: 0.0, ..DriveConfig::default() };
    let drive = Drive::simulate(&mixed_route(), &config, 0).unwrap();
    for seed in [3, 17, 40] {
        let dg = dg::simulate(&drive, &DgConfig::default(), seed).unwrap();
        let mut jumps_in_canyon = 0;
        for f in &dg.faults {
            assert_ne!(dg.errors[f.first].environment, Environment::Open, "seed {seed}: fault {f:?} began in the open");
            // A fault ends within its fall time once the street opens up.
            let last_enclosed =
                (f.first..f.end).rev().find(|&i| dg.errors[i].environment != Environment::Open).unwrap();
            let tail = dg.errors[f.end - 1].time - dg.errors[last_enclosed].time;
            assert!(tail <= f.transition + 0.011, "seed {seed}: fault lasted {tail} s into the open");
            if f.kind == FaultKind::Jump {
                jumps_in_canyon += usize::from(dg.errors[f.first].environment == Environment::Canyon);
            }
        }
        assert!(jumps_in_canyon >= 3, "seed {seed}: {jumps_in_canyon} jumps in 4 km of canyon");
        let transition = |t: f64| dg.faults.iter().any(|f| f.in_transition(t));
        let mut steps = 0;
        for i in 1..dg.errors.len() {
            let d = (dg.errors[i].position - dg.errors[i - 1].position).norm();
            if d > 0.01 {
                assert!(
                    transition(dg.errors[i].time),
                    "seed {seed}: {d:.3} m step at epoch {i} outside a jump's rise or fall"
                );
                steps += 1;
            }
        }
        assert!(steps > 0, "seed {seed}: no jump rose or fell by more than 1 cm per epoch");
        // Each holding jump shifts the solution by its offset (plus what the slow drift does meanwhile).
        for f in dg.faults.iter().filter(|f| f.kind == FaultKind::Jump && f.duration > 3.0 * f.transition) {
            let (before, mid) = (&dg.errors[f.first.saturating_sub(1)], &dg.errors[(f.first + f.end) / 2]);
            let shift = mid.position - before.position;
            let miss = (shift.x() - f.offset.x()).hypot(shift.y() - f.offset.y());
            assert!(miss < 0.15, "seed {seed}: jump {f:?} shifted by {shift:?}");
        }
        // Away from the jumps' rises and falls, consecutive epochs differ by millimetres.
        let quiet: Vec<f64> = (1..dg.errors.len())
            .filter(|&i| !transition(dg.errors[i].time))
            .map(|i| (dg.errors[i].position - dg.errors[i - 1].position).norm())
            .collect();
        assert!(quantile(quiet, 0.99) < 0.004);
    }
}

#[test]
fn dg_is_truth_plus_error_with_growing_sigma_in_outages() {
    let config = DriveConfig { rate_hz: 100.0, stop_probability: 0.0, ..DriveConfig::default() };
    let drive = Drive::simulate(&routes::straight((0.0, 0.0), 8000.0, 500.0, DEEP_CANYON), &config, 0).unwrap();
    let dg = dg::simulate(&drive, &DgConfig::default(), 5).unwrap();
    for ((t, d), e) in drive.trajectory.records().iter().zip(dg.trajectory.records()).zip(&dg.errors) {
        assert!(((d.position - t.position) - e.position).norm() < 1e-9);
        assert!((d.attitude.roll - t.attitude.roll - e.attitude[0]).abs() < 1e-12);
    }
    let outage = dg
        .faults
        .iter()
        .filter(|f| f.kind == FaultKind::Outage)
        .max_by(|a, b| a.duration.total_cmp(&b.duration))
        .unwrap();
    let reported = DgConfig::default().environments[Environment::Canyon.index()].reported_horizontal;
    let start = dg.trajectory.records()[outage.first].std.unwrap().east;
    let middle = dg.trajectory.records()[(outage.first + outage.end) / 2].std.unwrap().east;
    assert!((start - reported).abs() < 1e-3 && middle > reported, "{start} {middle} {outage:?}");
    assert_eq!(dg::simulate(&drive, &DgConfig::default(), 5).unwrap().errors, dg.errors);
    let bad = DgConfig { drift_correlation_time: -1.0, ..DgConfig::default() };
    assert!(dg::simulate(&drive, &bad, 5).unwrap_err().to_string().contains("drift_correlation_time"));
}

#[test]
fn jumps_persist_longer_when_they_begin_at_a_standstill() {
    // A canyon street with a 30–40 s stop at each of 39 junctions (Meyer et al. 2023, Fig. 7).
    let config = DriveConfig {
        rate_hz: 50.0,
        stop_probability: 1.0,
        standstill_min: 30.0,
        standstill_max: 40.0,
        ..DriveConfig::default()
    };
    let drive = Drive::simulate(&routes::straight((0.0, 0.0), 8000.0, 200.0, DEEP_CANYON), &config, 0).unwrap();
    let durations = |drive: &Drive, seed, standing: bool| {
        let dg = dg::simulate(drive, &DgConfig::default(), seed).unwrap();
        let jumps = dg.faults.into_iter().filter(|f| f.kind == FaultKind::Jump && f.end < drive.kinematics.len());
        let picked = jumps.filter(|f| (drive.kinematics[f.first].speed == 0.0) == standing);
        picked.map(|f| f.duration).collect::<Vec<f64>>()
    };
    let standing: Vec<f64> = (1..=4).flat_map(|seed| durations(&drive, seed, true)).collect();
    // The baseline: the same street driven without stops.
    let cruise = hour_drive(DEEP_CANYON);
    let moving: Vec<f64> = (1..=2).flat_map(|seed| durations(&cruise, seed, false)).collect();
    let mean = |xs: &[f64]| xs.iter().sum::<f64>() / xs.len() as f64;
    assert!(standing.len() >= 20 && moving.len() >= 10, "{} standing, {} moving", standing.len(), moving.len());
    // Moving: uniform 5–40 s plus the 1 s fall ≈ 23.5 s; standing, multipath decorrelates 5× slower.
    let (s, m) = (mean(&standing), mean(&moving));
    println!(
        "jumps beginning at a standstill: {} lasting {s:.1} s on average; moving: {} lasting {m:.1} s",
        standing.len(),
        moving.len()
    );
    assert!((18.0..=29.0).contains(&m), "moving jumps last {m:.1} s on average");
    assert!(s > 1.3 * m, "standing {s:.1} s vs moving {m:.1} s");
}
