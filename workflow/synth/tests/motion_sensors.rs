//! Raw sensor data: IMU increments reproduce the truth under strapdown integration and carry the documented
//! errors; GNSS fixes share the DG error process and stop during outages.
#![allow(clippy::unwrap_used)]

use nalgebra::{UnitQuaternion, Vector3};
use plumbline_synth::motion::dg::{self, DgConfig, FaultKind};
use plumbline_synth::motion::gnss::{self, GnssConfig};
use plumbline_synth::motion::imu::{self, ImuData, ImuErrors};
use plumbline_synth::motion::routes::{self, DEEP_CANYON};
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::route::{Canyon, Route};

/// An L-turn with a hill and a junction stop: ~90 s.
fn short_drive() -> Drive {
    let mut route = Route {
        waypoints: vec![
            routes::waypoint(0.0, 0.0, Canyon::OPEN),
            routes::waypoint(120.0, 0.0, Canyon::OPEN),
            routes::waypoint(120.0, 150.0, Canyon::OPEN),
            routes::waypoint(60.0, 260.0, Canyon::OPEN),
        ],
    };
    route.waypoints[1].junction = true;
    route.waypoints[2].ground_height = 6.0;
    let config = DriveConfig {
        stop_probability: 1.0,
        standstill_min: 5.0,
        standstill_max: 5.0,
        start_dwell: 2.0,
        end_dwell: 2.0,
        ..DriveConfig::default()
    };
    Drive::simulate(&route, &config, 4).unwrap()
}

/// Simple strapdown in the mapping frame (ENU, flat non-rotating Earth): returns final position error (m)
/// and final attitude error (rad) against the truth.
fn strapdown(drive: &Drive, imu: &ImuData) -> (f64, f64) {
    let r = drive.trajectory.records();
    let mut q: UnitQuaternion<f64> = *r[0].attitude.to_rotation().quaternion();
    let mut v = drive.kinematics[0].velocity.v;
    let mut p = r[0].position.p;
    let g = Vector3::new(0.0, 0.0, -imu.gravity);
    for rec in &imu.records {
        let dq = UnitQuaternion::from_scaled_axis(rec.delta_theta.v);
        let mid = q * UnitQuaternion::from_scaled_axis(rec.delta_theta.v * 0.5);
        let v1 = v + mid * rec.delta_v.v + g * rec.dt;
        p += (v + v1) * (0.5 * rec.dt);
        v = v1;
        q *= dq;
    }
    let last = r.last().unwrap();
    ((p - last.position.p).norm(), q.angle_to(last.attitude.to_rotation().quaternion()))
}

#[test]
fn error_free_increments_integrate_back_to_the_truth() {
    let drive = short_drive();
    assert!(drive.trajectory.span().1 - drive.trajectory.span().0 > 60.0);
    let imu = imu::simulate(&drive, &ImuErrors::PERFECT, 1).unwrap();
    assert_eq!(imu.records.len(), drive.trajectory.len() - 1);
    let (dp, da) = strapdown(&drive, &imu);
    // ~400 m with a 90° turn, a 135° turn, a hill and a stop: a sign or frame error is off by metres.
    assert!(dp < 0.02, "position off by {dp} m");
    assert!(da < 1e-6, "attitude off by {da} rad");
    // At rest on the cambered lane (right side down by `roll`) the accelerometers read the upward specific
    // force: −g cos(roll) along body z (down), −g sin(roll) along body y (right), nothing forward.
    let rest = &imu.records[10];
    let roll = drive.trajectory.records()[10].attitude.roll;
    assert!(roll > 0.01);
    let g_dt = imu.gravity * rest.dt;
    assert!((rest.delta_v.z() + g_dt * roll.cos()).abs() < 1e-9, "{:?}", rest.delta_v);
    assert!((rest.delta_v.y() + g_dt * roll.sin()).abs() < 1e-9, "{:?}", rest.delta_v);
    assert!(rest.delta_v.x().abs() < 1e-9 && rest.delta_theta.norm() < 1e-12);
}

#[test]
fn grade_errors_make_the_integration_drift_in_proportion() {
    let drive = short_drive();
    for seed in 1..=3 {
        let (tactical, _) = strapdown(&drive, &imu::simulate(&drive, &ImuErrors::NAVIGATION, seed).unwrap());
        let (consumer, _) = strapdown(&drive, &imu::simulate(&drive, &ImuErrors::CONSUMER, seed).unwrap());
        assert!(tactical < 2.0, "seed {seed}: tactical drifted {tactical} m in ~90 s");
        assert!(consumer > 10.0 * tactical.max(0.05), "seed {seed}: consumer {consumer} m vs tactical {tactical} m");
    }
}

#[test]
fn noise_and_bias_at_rest_match_the_parameters() {
    // Five minutes at rest: a one-waypoint-long street with a long start dwell.
    let config = DriveConfig { start_dwell: 300.0, end_dwell: 0.0, ..DriveConfig::default() };
    let drive = Drive::simulate(&routes::straight((0.0, 0.0), 5.0, 5.0, Canyon::OPEN), &config, 0).unwrap();
    let e = ImuErrors { gyro_bias_instability: 0.0, accel_bias_instability: 0.0, ..ImuErrors::CONSUMER };
    for seed in [2, 9] {
        let imu = imu::simulate(&drive, &e, seed).unwrap();
        let rest: Vec<_> = imu.records.iter().take(50_000).collect();
        let n = rest.len() as f64;
        let dt = rest[0].dt;
        let xs: Vec<f64> = rest.iter().map(|r| r.delta_theta.x()).collect();
        let mean = xs.iter().sum::<f64>() / n;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        let expected_sd = e.gyro_random_walk * dt.sqrt();
        assert!((sd / expected_sd - 1.0).abs() < 0.03, "seed {seed}: per-sample σ {sd} vs {expected_sd}");
        let bias = imu.errors.gyro_bias[0];
        assert!(
            (mean / dt - bias).abs() < 4.0 * expected_sd / n.sqrt() / dt,
            "seed {seed}: mean rate {} vs bias {bias}",
            mean / dt
        );
        // Accelerometer z: (1 + s)(−g cos(roll) dt) + b dt (roll: the lane's camber).
        let roll = drive.trajectory.records()[0].attitude.roll;
        let mz = rest.iter().map(|r| r.delta_v.z()).sum::<f64>() / n;
        let want =
            (1.0 + imu.errors.accel_scale_factor[2]) * (-imu.gravity * roll.cos() * dt) + imu.errors.accel_bias[2] * dt;
        let tol = 4.0 * e.accel_random_walk * dt.sqrt() / n.sqrt();
        assert!((mz - want).abs() < tol, "seed {seed}: {mz} vs {want}");
    }
    let bad = ImuErrors { bias_correlation_time: 0.0, ..ImuErrors::NAVIGATION };
    assert!(imu::simulate(&drive, &bad, 1).unwrap_err().to_string().contains("bias_correlation_time"));
}

#[test]
fn gnss_fixes_follow_the_dg_error_and_stop_in_outages() {
    let config = DriveConfig { stop_probability: 0.0, ..DriveConfig::default() };
    let drive = Drive::simulate(&routes::straight((0.0, 0.0), 6000.0, 500.0, DEEP_CANYON), &config, 0).unwrap();
    let dg_config = DgConfig::default();
    let dg = dg::simulate(&drive, &dg_config, 8).unwrap();
    let gnss_config = GnssConfig::default();
    let fixes = gnss::simulate(&drive, &dg, &dg_config, &gnss_config, 8).unwrap();
    let records = drive.trajectory.records();
    let step = (config.rate_hz / gnss_config.rate_hz).round() as usize;
    let outage_epochs =
        (0..records.len()).step_by(step).filter(|&i| dg.errors[i].fault == Some(FaultKind::Outage)).count();
    assert!(outage_epochs > 0, "no outage in 6 km of canyon");
    assert_eq!(fixes.len() + outage_epochs, records.len().div_ceil(step));
    let (wh, wv) = (gnss_config.white_horizontal[2], gnss_config.white_height[2]);
    for f in &fixes {
        let i = records.partition_point(|r| r.time < f.time - 1e-9);
        assert!((records[i].time - f.time).abs() < 1e-9);
        assert_ne!(dg.errors[i].fault, Some(FaultKind::Outage));
        // Antenna 0.4 m above the IMU (body z down), tilted by the camber by ~1 cm sideways.
        let d = f.position - records[i].position - dg.errors[i].position;
        assert!(d.x().abs() < 5.0 * wh + 0.02 && d.y().abs() < 5.0 * wh + 0.02, "{d:?}");
        assert!((d.z() - 0.4).abs() < 5.0 * wv, "{d:?}");
    }
}
