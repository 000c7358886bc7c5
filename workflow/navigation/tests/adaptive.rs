#![allow(clippy::unwrap_used)]
//! The filter acting on its own tests: a GNSS jump is excluded instead of absorbed; after an IMU bias step the
//! filter re-estimates the bias and stops flagging; coarse alignment from the data.

mod common;

use plumbline_geo::Vec3;
use plumbline_navigation::{
    Adaptation, AlignmentConfig, Decision, Flag, ForwardPass, IntegrityConfig, Sensor, align, filter, filter_adaptive,
    smooth, test_innovations,
};
use plumbline_synth::motion::imu::ImuErrors;

/// Largest horizontal error of the filtered positions against the truth within [a, b).
fn worst(fw: &ForwardPass, s: &common::Scenario, a: f64, b: f64) -> f64 {
    let truth = s.drive.trajectory.records();
    fw.filtered()
        .zip(truth)
        .filter(|(f, _)| f.time >= a && f.time < b)
        .map(|(f, t)| (f.position.p - t.position.p).xy().norm())
        .fold(0.0, f64::max)
}

#[test]
fn a_gnss_jump_is_excluded_instead_of_absorbed() {
    let mut s = common::scenario(5, &common::block_route(1), &ImuErrors::TACTICAL, 100.0, 5.0);
    let t0 = s.drive.trajectory.records()[0].time;
    let (a, b) = (t0 + 80.0, t0 + 90.0);
    for f in s.gnss.iter_mut().filter(|f| f.time >= a && f.time < b) {
        f.position.p.y += 1.0;
    }
    let plain = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
    let adaptive = filter_adaptive(&s.imu, &s.gnss, &s.initial, &s.config, &Adaptation::default()).unwrap();
    let in_jump: Vec<Decision> =
        adaptive.innovations.iter().filter(|i| i.time >= a && i.time < b).map(|i| i.decision).collect();
    assert_eq!(in_jump.len(), 50);
    assert!(in_jump.iter().all(|d| *d == Decision::Excluded), "{in_jump:?}");
    let (e_plain, e_adaptive) = (worst(&plain, &s, a, b + 5.0), worst(&adaptive, &s, a, b + 5.0));
    println!("error during the jump: absorbed {e_plain:.3} m, excluded {e_adaptive:.3} m");
    assert!(e_plain > 0.5, "the plain filter follows the jump: {e_plain}");
    // 10 s of free inertial navigation with a tactical IMU: centimetres.
    assert!(e_adaptive < 0.05, "the adaptive filter stays on the IMU: {e_adaptive}");
    // Outside the jump almost every fix is used (local test at α = 0.001).
    let outside = adaptive.innovations.iter().filter(|i| i.time < a || i.time >= b);
    let excluded = outside.filter(|i| i.decision != Decision::Used).count();
    assert!(excluded <= 6, "{excluded} fixes outside the jump not used plainly");
}

/// Flags after `from` of the tests at their default α over the innovations the filter used.
fn late_flags(fw: &ForwardPass, from: f64) -> Vec<Flag> {
    let used: Vec<_> = fw.innovations.iter().filter(|i| i.decision != Decision::Excluded).copied().collect();
    test_innovations(&used, &IntegrityConfig::default()).unwrap().into_iter().filter(|f| f.time > from).collect()
}

#[test]
fn after_an_imu_bias_step_the_filter_recovers_instead_of_flagging_forever() {
    let mut s = common::scenario(6, &common::block_route(1), &ImuErrors::TACTICAL, 100.0, 5.0);
    let t0 = s.drive.trajectory.records()[0].time;
    let step_at = t0 + 100.0;
    let step = 0.01; // ~1 mg on the forward axis
    common::add_bias_step(&mut s.imu, step_at, step);
    let plain = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
    let adaptive = filter_adaptive(&s.imu, &s.gnss, &s.initial, &s.config, &Adaptation::default()).unwrap();
    let reopened = |i: &&plumbline_navigation::Innovation| {
        i.time > step_at && matches!(i.decision, Decision::BiasReset | Decision::Reinitialised)
    };
    let reset = adaptive.innovations.iter().find(reopened).unwrap();
    println!("first re-opening {:?} {:.2} s after the step", reset.decision, reset.time - step_at);
    assert!(reset.time - step_at < 10.0, "acted {} s after the step", reset.time - step_at);
    let settle = step_at + 20.0;
    let (n_plain, n_adaptive) = (late_flags(&plain, settle).len(), late_flags(&adaptive, settle).len());
    let fixes = adaptive.innovations.iter().filter(|i| i.time > settle).count();
    println!("flags from 20 s after the step: plain {n_plain}, adaptive {n_adaptive} over {fixes} fixes");
    assert!(n_plain > 20, "the plain filter keeps flagging: {n_plain}");
    // Four tests at α = 0.001 over the fixes (windows overlap): a handful of false alarms at most.
    assert!(n_adaptive <= 8, "the adaptive filter keeps flagging: {n_adaptive}");
    let (x, _) = adaptive.final_biases();
    assert!((x.x - step).abs() < 0.3 * step, "estimated forward accelerometer bias {} vs {step}", x.x);
    let smoothed = smooth(&adaptive).unwrap();
    let truth = s.drive.trajectory.records();
    let late = smoothed.iter().zip(truth).filter(|(e, _)| e.time > settle);
    let err = late.map(|(e, t)| (e.position.p - t.position.p).norm()).fold(0.0, f64::max);
    assert!(err < 0.03, "smoothed error after the step {err}");
}

#[test]
fn flags_blame_gnss_for_a_jump_and_the_imu_for_a_bias_step() {
    let clean = common::scenario(6, &common::block_route(1), &ImuErrors::TACTICAL, 100.0, 5.0);
    let t0 = clean.drive.trajectory.records()[0].time;
    let flags_of = |s: &common::Scenario| {
        let fw = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
        test_innovations(&fw.innovations, &IntegrityConfig::default()).unwrap()
    };
    let (a, b) = (t0 + 40.0, t0 + 50.0);
    let mut jumped = common::scenario(6, &common::block_route(1), &ImuErrors::TACTICAL, 100.0, 5.0);
    for f in jumped.gnss.iter_mut().filter(|f| f.time >= a && f.time < b) {
        f.position.p.x += 0.5;
    }
    let flags = flags_of(&jumped);
    // The onset and the end of the jump are abrupt: GNSS; so is most of what the absorbing filter flags
    // in between (global windows holding the onset).
    for edge in [a, b] {
        let at: Vec<&Flag> = flags.iter().filter(|f| (f.time - edge).abs() < 0.01).collect();
        assert!(!at.is_empty() && at.iter().all(|f| f.sensor == Sensor::Gnss), "at {edge}: {at:?}");
    }
    let jump: Vec<&Flag> = flags.iter().filter(|f| f.time >= a && f.time <= b + 0.1).collect();
    let gnss = jump.iter().filter(|f| f.sensor == Sensor::Gnss).count();
    assert!(gnss as f64 > 0.7 * jump.len() as f64, "{gnss} of {} blame GNSS", jump.len());
    let step_at = t0 + 100.0;
    let mut stepped = clean;
    common::add_bias_step(&mut stepped.imu, step_at, 0.003);
    let flags = flags_of(&stepped);
    let imu = |f: &&Flag| f.sensor == Sensor::Imu;
    let first = flags.iter().filter(|f| f.time > step_at).find(imu).unwrap();
    println!("first IMU-blamed flag {:.1} s after the bias step: {first:?}", first.time - step_at);
    assert!(first.time - step_at < 15.0);
    let after: Vec<&Flag> = flags.iter().filter(|f| f.time > step_at && f.time < step_at + 30.0).collect();
    let share = after.iter().filter(|f| f.sensor == Sensor::Imu).count() as f64 / after.len() as f64;
    println!("{} flags in the 30 s after the step, {:.0} % blame the IMU", after.len(), 100.0 * share);
    assert!(share > 0.5);
    let before = flags.iter().filter(|f| f.time < step_at).count();
    assert!(before <= 8, "{before} flags on clean data");
}

#[test]
fn coarse_alignment_recovers_the_start_pose_and_the_filter_converges() {
    for seed in [3, 8] {
        let s = common::scenario(seed, &common::block_route(1), &ImuErrors::TACTICAL, 100.0, 5.0);
        let lever = Vec3::new(common::LEVER[0], common::LEVER[1], common::LEVER[2]);
        let init = align(&s.imu, &s.gnss, &lever, &AlignmentConfig::default()).unwrap();
        let truth = &s.drive.trajectory.records()[0];
        let d =
            |a: f64, b: f64| (a - b + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        let (dr, dp) = (d(init.attitude.roll, truth.attitude.roll), d(init.attitude.pitch, truth.attitude.pitch));
        let dh = d(init.attitude.heading, truth.attitude.heading);
        println!("seed {seed}: alignment errors roll {dr:.2e}, pitch {dp:.2e}, heading {dh:.2e} rad");
        // Within the σ the alignment states (3σ), which a sign error in levelling or the heading rate breaks.
        assert!(dr.abs() < 3.0 * init.attitude_std[0] && dp.abs() < 3.0 * init.attitude_std[1]);
        assert!(dh.abs() < 3.0 * init.attitude_std[2], "heading error {dh}");
        assert!((init.position.p - truth.position.p).norm() < 0.05);
        let fw = filter_adaptive(&s.imu, &s.gnss, &init, &s.config, &Adaptation::default()).unwrap();
        let smoothed = smooth(&fw).unwrap();
        let records = s.drive.trajectory.records();
        // From the second second on: the alignment's own first epoch is not a converged solution.
        let converged = smoothed.iter().zip(records).filter(|(e, _)| e.time > init.time + 1.0);
        let err = converged.map(|(e, t)| (e.position.p - t.position.p).norm()).fold(0.0, f64::max);
        assert!(err < 0.03, "seed {seed}: smoothed error {err} m from the aligned start");
    }
}
