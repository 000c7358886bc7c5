//! The true motion: speed profile, stops, attitude from the path, consistency of positions and velocities.
#![allow(clippy::unwrap_used)]

use plumbline_synth::motion::routes::{self, CITY_LIMIT, DEEP_CANYON};
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::route::{Canyon, Route};

fn deg(x: f64) -> f64 {
    x.to_degrees()
}

/// Longest run of consecutive epochs at rest (speed exactly 0), seconds, and the index where it starts.
fn longest_standstill(drive: &Drive) -> (f64, usize) {
    let k = &drive.kinematics;
    let (mut best, mut best_at, mut start) = (0.0, 0, None);
    for (i, e) in k.iter().enumerate() {
        match (e.speed == 0.0, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                let d = k[i - 1].time - k[s].time;
                if d > best && s > 0 {
                    (best, best_at) = (d, s);
                }
                start = None;
            }
            _ => {}
        }
    }
    (best, best_at)
}

#[test]
fn straight_street_keeps_limits_and_bounds_acceleration() {
    let config = DriveConfig { stop_probability: 0.0, ..DriveConfig::default() };
    let drive = Drive::simulate(&routes::straight((1000.0, 2000.0), 500.0, 100.0, Canyon::OPEN), &config, 1).unwrap();
    let r = drive.trajectory.records();
    let k = &drive.kinematics;
    let dt = 1.0 / config.rate_hz;
    assert!(r.windows(2).all(|w| (w[1].time - w[0].time - dt).abs() < 1e-6));
    let vmax = k.iter().map(|e| e.speed).fold(0.0, f64::max);
    assert!(
        vmax <= CITY_LIMIT * config.cruise_factor + 1e-9 && vmax > 0.95 * CITY_LIMIT * config.cruise_factor,
        "{vmax}"
    );
    let accel: Vec<f64> = k.windows(2).map(|w| (w[1].speed - w[0].speed) / dt).collect();
    for (a, e) in accel.iter().zip(k) {
        assert!(*a <= config.max_accel + 1e-6 && *a >= -config.max_decel - 1e-6, "t {}: {a}", e.time);
    }
    // Acceleration ramps: jerk bounded by the smoothing window.
    let jerk_limit = (config.max_accel + config.max_decel) / config.jerk_window;
    for (w, e) in accel.windows(2).zip(k) {
        let jerk = (w[1] - w[0]) / dt;
        assert!(jerk.abs() <= 1.05 * jerk_limit, "t {}: jerk {jerk}", e.time);
    }
    // Start and end at rest for the dwell times; time to drive ≥ the time at cruise speed plus the dwells.
    let (t0, t1) = drive.trajectory.span();
    assert!(t1 - t0 > 500.0 / vmax + config.start_dwell + config.end_dwell);
    assert!(k[0].speed == 0.0 && k.last().unwrap().speed == 0.0);
    let end = r.last().unwrap().position;
    assert!((end.x() - 1500.0).abs() < 1e-6 && (end.y() - 2000.0).abs() < 1e-9);
    // Heading east (grid 90°), level, camber roll right side down.
    let mid = &r[r.len() / 2];
    assert!((deg(mid.attitude.heading) - 90.0).abs() < 1e-9);
    assert!(mid.attitude.pitch.abs() < 1e-9);
    assert!((mid.attitude.roll - config.camber.atan()).abs() < 1e-6);
    assert!((mid.position.z() - config.imu_height).abs() < 1e-12);
}

#[test]
fn velocities_match_positions_and_heading_follows_the_track() {
    let route = routes::block_loop((0.0, 0.0), 100.0, 60.0, 1, Canyon::OPEN);
    let drive = Drive::simulate(&route, &DriveConfig::default(), 3).unwrap();
    let r = drive.trajectory.records();
    for i in (1..r.len() - 1).step_by(7) {
        let dt = r[i + 1].time - r[i - 1].time;
        let fd = (r[i + 1].position - r[i - 1].position) * (1.0 / dt);
        let v = drive.kinematics[i].velocity;
        assert!((fd - v).norm() < 2e-3, "epoch {i}: {fd:?} vs {v:?}");
        if drive.kinematics[i].speed > 1.0 {
            // Grid heading clockwise from north: atan2(v_east, v_north).
            let h = v.x().atan2(v.y()).rem_euclid(std::f64::consts::TAU);
            let diff = (h - r[i].attitude.heading).abs();
            assert!(diff.min(std::f64::consts::TAU - diff) < 1e-6, "epoch {i}: {h} vs {}", r[i].attitude.heading);
        }
    }
}

#[test]
fn corners_slow_to_curve_speed_and_roll_outwards() {
    let config = DriveConfig { stop_probability: 0.0, turn_radius: 10.0, ..DriveConfig::default() };
    // East, then a left turn to the north.
    let route = Route {
        waypoints: vec![
            routes::waypoint(0.0, 0.0, Canyon::OPEN),
            routes::waypoint(150.0, 0.0, Canyon::OPEN),
            routes::waypoint(150.0, 150.0, Canyon::OPEN),
        ],
    };
    let drive = Drive::simulate(&route, &config, 5).unwrap();
    let r = drive.trajectory.records();
    assert!((deg(r[0].attitude.heading) - 90.0).abs() < 1e-9);
    assert!(deg(r.last().unwrap().attitude.heading).abs() < 1e-9);
    let curve_speed = (config.max_lateral_accel * 10.0).sqrt();
    let mut in_curve = 0;
    for (rec, k) in r.iter().zip(&drive.kinematics) {
        let (e, n) = (rec.position.x(), rec.position.y());
        if e > 140.0 + 1e-6 && n < 10.0 - 1e-6 {
            in_curve += 1;
            assert!(k.speed <= curve_speed + 1e-6, "{} m/s in the curve", k.speed);
        }
    }
    assert!(in_curve > 100);
    // At the middle of the arc the body has settled to camber + outward roll (positive for a left turn).
    let mid = r
        .iter()
        .zip(&drive.kinematics)
        .filter(|(p, _)| p.position.x() > 145.0 && p.position.y() < 5.0)
        .max_by(|a, b| a.0.attitude.roll.total_cmp(&b.0.attitude.roll))
        .unwrap();
    let expected = config.camber.atan() + config.roll_per_accel * curve_speed.powi(2) / 10.0;
    assert!(
        mid.0.attitude.roll > config.camber.atan() + 0.5 * (expected - config.camber.atan()),
        "{}",
        deg(mid.0.attitude.roll)
    );
    assert!(mid.0.attitude.roll <= expected + 1e-9);
}

#[test]
fn junction_stops_last_as_drawn_and_stand_still() {
    let config =
        DriveConfig { stop_probability: 1.0, standstill_min: 38.0, standstill_max: 38.0, ..DriveConfig::default() };
    let route = routes::straight((0.0, 0.0), 300.0, 150.0, DEEP_CANYON);
    let drive = Drive::simulate(&route, &config, 9).unwrap();
    let (duration, at) = longest_standstill(&drive);
    // Exactly at rest for the drawn 38 s less the smoothing window (half of it at each end).
    assert!((duration - (38.0 - config.jerk_window)).abs() < 0.05, "{duration}");
    let p = drive.trajectory.records()[at].position;
    assert!((p.x() - (150.0 - config.stop_before_junction)).abs() < 0.3, "{p:?}");
    let during: Vec<_> = drive.trajectory.records()[at..at + 1000].iter().map(|r| r.position).collect();
    assert!(during.iter().all(|q| (*q - p).norm() < 1e-3));
    assert_eq!(drive.stops.len(), 3);
}

#[test]
fn stops_are_deterministic_from_the_seed() {
    let config = DriveConfig { rate_hz: 100.0, ..DriveConfig::default() };
    let route = routes::straight((0.0, 0.0), 1000.0, 100.0, Canyon::OPEN);
    let a = Drive::simulate(&route, &config, 11).unwrap();
    let b = Drive::simulate(&route, &config, 11).unwrap();
    assert_eq!(a.trajectory, b.trajectory);
    let differs = (12..20).any(|seed| Drive::simulate(&route, &config, seed).unwrap().stops != a.stops);
    assert!(differs);
    // About half of 9 junctions stop; every standstill within the configured range.
    for seed in 0..5 {
        let d = Drive::simulate(&route, &config, seed).unwrap();
        let junction_stops = &d.stops[1..d.stops.len() - 1];
        assert!(junction_stops.len() <= 9);
        assert!(junction_stops.iter().all(|s| (config.standstill_min..=config.standstill_max).contains(&s.duration)));
    }
    let total: usize = (0..20).map(|seed| Drive::simulate(&route, &config, seed).unwrap().stops.len() - 2).sum();
    assert!((50..=130).contains(&total), "{total} junction stops in 20 drives of 9 junctions at p = 0.5");
}

#[test]
fn grade_gives_pitch_and_bad_config_is_named() {
    let mut route = routes::straight((0.0, 0.0), 200.0, 200.0, Canyon::OPEN);
    route.waypoints[1].ground_height = 10.0;
    let drive = Drive::simulate(&route, &DriveConfig::default(), 2).unwrap();
    let r = drive.trajectory.records();
    let k = &drive.kinematics;
    let cruising = r.iter().zip(k).find(|(_, k)| k.distance > 100.0).unwrap();
    assert!((cruising.0.attitude.pitch - 0.05f64.atan()).abs() < 1e-4, "{}", deg(cruising.0.attitude.pitch));
    let bad = DriveConfig { rate_hz: 0.0, ..DriveConfig::default() };
    let err = Drive::simulate(&route, &bad, 2).unwrap_err();
    assert!(err.to_string().contains("rate_hz"), "{err}");
}
