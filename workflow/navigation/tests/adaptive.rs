#![allow(clippy::unwrap_used)]
//! The filter acting on its own tests: a GNSS jump is excluded instead of absorbed, also when it builds up
//! over a second as multipath does; after an IMU bias step the filter re-estimates the bias and stops
//! flagging; a re-initialisation bends the smoothed trajectory instead of stepping it; coarse alignment from
//! the data, standing (also with canyon-grade fixes) or already moving, and its errors when it cannot work;
//! the step test (the default of `navigate`) excluding steps, outliers and faults found after an outage, and
//! nothing else.

use plumbline_fixtures::navigation;

use nalgebra::Vector3;
use plumbline_geo::Vec3;
use plumbline_geo::angle::wrap;
use plumbline_navigation::{
    Adaptation, AlignmentConfig, Decision, EpisodeEnd, Flag, ForwardPass, GnssFix, ImuSample, InitialState,
    IntegrityConfig, NavConfig, NavError, Sensor, SmoothedEpoch, StepTest, VehicleConstraint, align, filter,
    filter_adaptive, filter_excluding, filter_screened, screen_steps, smooth, test_innovations, to_trajectory,
};
use plumbline_synth::motion::imu::ImuErrors;

/// Largest horizontal error of the filtered positions against the truth within [a, b).
fn worst(fw: &ForwardPass, s: &navigation::Scenario, a: f64, b: f64) -> f64 {
    let truth = s.drive.trajectory.records();
    fw.filtered()
        .zip(truth)
        .filter(|(f, _)| f.time >= a && f.time < b)
        .map(|(f, t)| (f.position.p - t.position.p).xy().norm())
        .fold(0.0, f64::max)
}

#[test]
fn a_gnss_jump_is_excluded_instead_of_absorbed() {
    let mut s = navigation::scenario(5, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
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
    // 10 s of free inertial navigation with a navigation-grade IMU: centimetres.
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
    let mut s = navigation::scenario(6, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
    let t0 = s.drive.trajectory.records()[0].time;
    let step_at = t0 + 100.0;
    let step = 0.01; // ~1 mg on the forward axis
    navigation::add_bias_step(&mut s.imu, step_at, step);
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

/// A gyro whose bias is 1000 times its model's turn-on σ (a unit worse than its class, as the KITTI OXTS is
/// against a tactical model): one re-opening to the turn-on σ cannot take the bias in (without escalation the
/// estimate ends at 0.2 % of it, with 14 fixes excluded), so re-openings that follow each other re-open wider
/// until it does.
#[test]
fn a_gyro_bias_far_beyond_its_model_is_taken_in_by_escalating_reopenings() {
    let mut s = navigation::scenario(6, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
    let t0 = s.drive.trajectory.records()[0].time;
    let bias = 1000.0 * s.config.imu.gyro_bias;
    for r in s.imu.iter_mut().filter(|r| r.time > t0 + 30.0) {
        r.delta_theta.v.x += bias * r.dt;
    }
    let adaptive = filter_adaptive(&s.imu, &s.gnss, &s.initial, &s.config, &Adaptation::default()).unwrap();
    let (_, gyro) = adaptive.final_biases();
    let excluded = adaptive.innovations.iter().filter(|i| i.decision == Decision::Excluded).count();
    println!("gyro x bias {bias:.3e}, estimated {:.3e} rad/s; {excluded} fixes excluded", gyro.x);
    assert!(gyro.x > 0.5 * bias && gyro.x < 2.0 * bias, "estimated {} vs {bias}", gyro.x);
    assert!(excluded <= 5, "{excluded} fixes excluded");
}

#[test]
fn flags_blame_gnss_for_a_jump_and_the_imu_for_a_bias_step() {
    let clean = navigation::scenario(6, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
    let t0 = clean.drive.trajectory.records()[0].time;
    let flags_of = |s: &navigation::Scenario| {
        let fw = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
        test_innovations(&fw.innovations, &IntegrityConfig::default()).unwrap()
    };
    let (a, b) = (t0 + 40.0, t0 + 50.0);
    let mut jumped = navigation::scenario(6, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
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
    navigation::add_bias_step(&mut stepped.imu, step_at, 0.003);
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
        let s = navigation::scenario(seed, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
        let lever = Vec3::new(navigation::LEVER[0], navigation::LEVER[1], navigation::LEVER[2]);
        let init = align(&s.imu, &s.gnss, &lever, &AlignmentConfig::default()).unwrap();
        let truth = &s.drive.trajectory.records()[0];
        let d = |a: f64, b: f64| wrap(a - b);
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

/// Largest horizontal error of the smoothed positions against the truth within [a, b).
fn worst_smoothed(smoothed: &[SmoothedEpoch], s: &navigation::Scenario, a: f64, b: f64) -> f64 {
    let truth = s.drive.trajectory.records();
    let start = truth.partition_point(|r| r.time < smoothed[0].time - 1e-9);
    smoothed
        .iter()
        .zip(&truth[start..])
        .filter(|(e, _)| e.time >= a && e.time < b)
        .map(|(e, t)| (e.position.p - t.position.p).xy().norm())
        .fold(0.0, f64::max)
}

/// Largest excess of the speed implied between consecutive smoothed epochs over the true speed, m/s: a step in
/// the smoothed trajectory shows as a spike of step / dt.
fn worst_speed_excess(smoothed: &[SmoothedEpoch], s: &navigation::Scenario) -> f64 {
    smoothed
        .windows(2)
        .zip(&s.drive.kinematics[1..])
        .map(|(w, k)| (w[1].position.p - w[0].position.p).norm() / (w[1].time - w[0].time) - k.velocity.norm())
        .fold(0.0, f64::max)
}

#[test]
fn a_multipath_jump_that_builds_up_over_a_second_is_excluded_and_bridged_on_the_imu() {
    for seed in [5, 9] {
        let mut s = navigation::scenario(seed, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
        let t0 = s.drive.trajectory.records()[0].time;
        let (a, b) = (t0 + 80.0, t0 + 90.0);
        // 0.4 m, arriving and leaving over 1 s like the simulator's multipath jumps.
        navigation::add_ramped_jump(&mut s.gnss, a, b, 1.0, Vector3::new(0.1, 0.3, -0.25));
        let fw = filter_adaptive(&s.imu, &s.gnss, &s.initial, &s.config, &Adaptation::default()).unwrap();
        let during = || fw.innovations.iter().filter(|i| i.time >= a && i.time < b);
        assert!(during().all(|i| i.decision != Decision::Reinitialised), "seed {seed}: the IMU was blamed");
        let plateau = during().filter(|i| i.time >= a + 1.0 && i.time < b - 1.0);
        assert!(plateau.clone().all(|i| i.decision == Decision::Excluded), "seed {seed}: a jumped fix was used");
        let smoothed = smooth(&fw).unwrap();
        let worst = worst_smoothed(&smoothed, &s, a - 2.0, b + 5.0);
        let plain = smooth(&filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap()).unwrap();
        let followed = worst_smoothed(&plain, &s, a - 2.0, b + 5.0);
        println!("seed {seed}: smoothed error around the jump {worst:.3} m (plain filter {followed:.3} m)");
        assert!(followed > 0.08, "seed {seed}: the plain filter follows the jump: {followed}");
        // 10 s bridged on a navigation-grade IMU between clean fixes: centimetres.
        assert!(worst < 0.05, "seed {seed}: the jump bends the smoothed trajectory by {worst} m");
        to_trajectory(&smoothed).unwrap();
    }
}

#[test]
fn a_re_initialisation_bends_the_smoothed_trajectory_instead_of_stepping() {
    let mut s = navigation::scenario(7, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
    let t0 = s.drive.trajectory.records()[0].time;
    let (a, b) = (t0 + 60.0, t0 + 100.0);
    for f in s.gnss.iter_mut().filter(|f| f.time >= a && f.time < b) {
        f.position.p.y += 1.0;
    }
    // The jump outlasts the exclusion limit: the filter blames itself and takes the jumped fixes.
    let adaptation = Adaptation { max_exclusion: 5.0, ..Adaptation::default() };
    // With the vehicle constraint, checkpoints lie 0.1 s apart: the spread must still reach back to the
    // last used fix, not to the last constraint update.
    for vehicle in [None, Some(VehicleConstraint::default())] {
        let config = NavConfig { vehicle, ..s.config };
        let fw = filter_adaptive(&s.imu, &s.gnss, &s.initial, &config, &adaptation).unwrap();
        let reinit = fw.innovations.iter().find(|i| i.decision == Decision::Reinitialised).unwrap();
        assert!(reinit.time > a + 5.0 && reinit.time < a + 6.0, "re-initialised at {}", reinit.time - a);
        let smoothed = smooth(&fw).unwrap();
        // Re-opening the position as a step at the re-initialisation would move 1 m in one 10 ms epoch
        // (100 m/s); spread over the 5 s since the last used fix it adds about 0.2 m/s.
        let excess = worst_speed_excess(&smoothed, &s);
        println!("vehicle constraint {}: largest smoothed speed above the truth: {excess:.3} m/s", vehicle.is_some());
        assert!(excess < 0.5, "the smoothed trajectory steps: {excess} m/s above the true speed");
        let before = worst_smoothed(&smoothed, &s, t0 + 2.0, a - 1.0);
        assert!(before < 0.03, "the bend reaches back before the jump: {before} m");
        to_trajectory(&smoothed).unwrap();
    }
}

/// Alignment errors (roll, pitch, heading; rad) against the truth at the aligned epoch.
fn attitude_errors(init: &InitialState, s: &navigation::Scenario) -> [f64; 3] {
    let records = s.drive.trajectory.records();
    let truth = &records[records.partition_point(|r| r.time < init.time - 1e-9)];
    let d = |a: f64, b: f64| wrap(a - b);
    let (a, t) = (&init.attitude, &truth.attitude);
    [d(a.roll, t.roll), d(a.pitch, t.pitch), d(a.heading, t.heading)]
}

fn lever() -> Vec3<plumbline_geo::Body> {
    Vec3::new(navigation::LEVER[0], navigation::LEVER[1], navigation::LEVER[2])
}

#[test]
fn a_drive_that_starts_moving_is_aligned_in_motion() {
    for (seed, after) in [(3, 30.0), (8, 55.0), (11, 100.0)] {
        let s = navigation::scenario(seed, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
        let t0 = s.drive.trajectory.records()[0].time;
        let (imu, gnss): (Vec<ImuSample>, Vec<GnssFix>) = navigation::starting_at(&s, t0 + after);
        let k = s.drive.kinematics.partition_point(|k| k.time < imu[0].time - imu[0].dt - 1e-9);
        let (speed, velocity) = (s.drive.kinematics[k].speed, s.drive.kinematics[k].velocity);
        assert!(speed > 3.0, "seed {seed}: the drive stands at the cut ({speed} m/s)");
        let init = align(&imu, &gnss, &lever(), &AlignmentConfig::default()).unwrap();
        let [dr, dp, dh] = attitude_errors(&init, &s);
        let dv = (init.velocity.v - velocity.v).norm();
        println!(
            "seed {seed}, {speed:.1} m/s: roll {dr:.2e}, pitch {dp:.2e}, heading {dh:.2e} rad, velocity {dv:.3} m/s"
        );
        // Within the stated 3σ, and the σ small enough to be of use (a tilt of 1° spoils the first seconds).
        let sd = init.attitude_std;
        assert!(dr.abs() < 3.0 * sd[0] && dp.abs() < 3.0 * sd[1] && dh.abs() < 3.0 * sd[2], "seed {seed}");
        assert!(sd[0] < 0.01 && sd[2] < 0.05, "seed {seed}: σ {sd:?}");
        assert!(dv < 3.0 * init.velocity_std && init.velocity_std < 0.1, "seed {seed}: velocity error {dv}");
        let fw = filter_adaptive(&imu, &gnss, &init, &s.config, &Adaptation::default()).unwrap();
        let smoothed = smooth(&fw).unwrap();
        let err = worst_smoothed(&smoothed, &s, init.time + 1.0, f64::MAX);
        assert!(err < 0.03, "seed {seed}: smoothed error {err} m from the in-motion alignment");
    }
}

#[test]
fn a_standing_start_with_canyon_grade_fixes_is_recognised_and_levelled() {
    for seed in [1, 2, 3, 4] {
        let mut s = navigation::scenario(seed, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
        // The simulator's canyon receiver noise: 5 cm per horizontal axis, 10 cm in height.
        navigation::degrade_fixes(&mut s.gnss, [0.05, 0.05, 0.1], seed);
        let init = align(&s.imu, &s.gnss, &lever(), &AlignmentConfig::default()).unwrap();
        let [dr, dp, dh] = attitude_errors(&init, &s);
        println!("seed {seed}: roll {dr:.2e}, pitch {dp:.2e}, heading {dh:.2e} rad, σ {:?}", init.attitude_std);
        assert_eq!(init.velocity.v, Vector3::zeros(), "seed {seed}: the standstill was not recognised");
        // Static levelling of a navigation-grade IMU: the turn-on accelerometer bias over g.
        assert!(dr.abs() < 3.0 * init.attitude_std[0] && init.attitude_std[0] < 3e-3, "seed {seed}: roll {dr}");
        assert!(dp.abs() < 3.0 * init.attitude_std[1], "seed {seed}: pitch {dp}");
        assert!(dh.abs() < 3.0 * init.attitude_std[2], "seed {seed}: heading {dh}");
        let truth = &s.drive.trajectory.records()[0];
        assert!((init.position.p - truth.position.p).norm() < 0.1, "seed {seed}");
    }
}

/// Agencies' raw GNSS is often logged at 1 Hz; the 2 s levelling window then holds two fixes.
/// It widens to the fourth fix, and both a standing and a moving start align within their stated σ.
#[test]
fn one_hertz_gnss_aligns_standing_and_moving() {
    for (seed, after) in [(3, None), (8, None), (8, Some(55.0)), (11, Some(100.0))] {
        let s = navigation::scenario(seed, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 1.0);
        let t0 = s.drive.trajectory.records()[0].time;
        let (imu, gnss) = match after {
            Some(a) => navigation::starting_at(&s, t0 + a),
            None => (s.imu.clone(), s.gnss.clone()),
        };
        let init = align(&imu, &gnss, &lever(), &AlignmentConfig::default()).unwrap();
        let [dr, dp, dh] = attitude_errors(&init, &s);
        println!("seed {seed}, start {after:?}: roll {dr:.2e}, pitch {dp:.2e}, heading {dh:.2e} rad");
        let sd = init.attitude_std;
        assert!(dr.abs() < 3.0 * sd[0] && dp.abs() < 3.0 * sd[1] && dh.abs() < 3.0 * sd[2], "seed {seed}");
        assert!(sd[0] < 0.01 && sd[2] < 0.05, "seed {seed}: σ {sd:?}");
        let fw = filter_adaptive(&imu, &gnss, &init, &s.config, &Adaptation::default()).unwrap();
        let err = worst_smoothed(&smooth(&fw).unwrap(), &s, init.time + 5.0, f64::MAX);
        assert!(err < 0.05, "seed {seed}: smoothed error {err} m after a 1 Hz alignment");
    }
}

#[test]
fn alignment_fails_only_when_impossible_and_says_why() {
    let s = navigation::scenario(3, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
    let t0 = s.drive.trajectory.records()[0].time;
    let reason = |imu: &[ImuSample], gnss: &[GnssFix]| match align(imu, gnss, &lever(), &AlignmentConfig::default()) {
        Err(NavError::Alignment { reason }) => reason,
        other => panic!("expected an alignment error, got {other:?}"),
    };
    let late: Vec<GnssFix> = s.gnss.iter().filter(|f| f.time > t0 + 5.0).copied().collect();
    assert!(reason(&s.imu, &late).contains("no usable GNSS fix within the levelling time"));
    // Three fixes in the widened window (10 × 2 s) are not enough for the motion fit.
    let sparse: Vec<GnssFix> = s.gnss.iter().filter(|f| f.time < t0 + 21.0).step_by(40).copied().collect();
    assert_eq!(sparse.len(), 3);
    assert!(reason(&s.imu, &sparse).contains("fewer than 4 usable GNSS fixes"));
    // Only the standstill at the start: no course to take the heading from.
    let standing = t0 + s.drive.stops[0].duration * 0.9;
    let imu: Vec<ImuSample> = s.imu.iter().filter(|r| r.time <= standing).copied().collect();
    let gnss: Vec<GnssFix> = s.gnss.iter().filter(|f| f.time <= standing).copied().collect();
    assert!(reason(&imu, &gnss).contains("never moves"));
    let bad = AlignmentConfig { alpha: 0.0, ..AlignmentConfig::default() };
    let err = align(&s.imu, &s.gnss, &lever(), &bad).unwrap_err();
    assert!(matches!(err, NavError::Config { field: "alignment.alpha", .. }), "{err:?}");
}

/// Indices of the fixes within [a, b).
fn fixes_in(gnss: &[GnssFix], a: f64, b: f64) -> Vec<usize> {
    gnss.iter().enumerate().filter(|(_, f)| f.time >= a && f.time < b).map(|(i, _)| i).collect()
}

#[test]
fn the_step_test_excludes_steps_and_outliers_until_the_fixes_return_and_nothing_else() {
    let mut s = navigation::scenario(7, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 1.0);
    let t0 = s.drive.trajectory.records()[0].time;
    // A 3.5 m multipath step for 15 s; a 10 m outlier; a fault changing level fix by fix (2 m, then 4 m,
    // then back); a slow drift of 2 m over 20 s, which is no step.
    let step = Vector3::new(2.0, -2.5, 1.2);
    let (a, b) = (t0 + 40.0, t0 + 55.0);
    let multipath = fixes_in(&s.gnss, a, b);
    multipath.iter().for_each(|&i| s.gnss[i].position.p += step);
    let outlier = fixes_in(&s.gnss, t0 + 80.0, t0 + 81.0)[0];
    s.gnss[outlier].position.p.x += 10.0;
    let staircase = fixes_in(&s.gnss, t0 + 100.0, t0 + 106.0);
    for (n, &i) in staircase.iter().enumerate() {
        s.gnss[i].position.p.y += if n < 3 { 2.0 } else { 4.0 };
    }
    for f in s.gnss.iter_mut().filter(|f| f.time >= t0 + 130.0) {
        f.position.p.x += ((f.time - t0 - 130.0) * 0.1).min(2.0);
    }
    let first = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
    let screen = screen_steps(&first, &s.gnss, &StepTest::default());
    let excluded: Vec<usize> = (0..s.gnss.len()).filter(|&i| screen.excluded[i]).collect();
    let mut expected: Vec<usize> = multipath.iter().chain(&[outlier]).chain(&staircase).copied().collect();
    expected.sort_unstable();
    assert_eq!(excluded, expected, "{:?}", screen.episodes);
    assert_eq!(screen.episodes.len(), 3, "{:?}", screen.episodes);
    assert!(screen.episodes.iter().all(|e| e.ended == EpisodeEnd::Returned), "{:?}", screen.episodes);
    // The step that opened each episode, as estimated against the IMU.
    let opened = Vector3::from(screen.episodes[0].step);
    assert!((opened - step).norm() < 0.1, "multipath step estimated as {opened:?}");
    assert!((Vector3::from(screen.episodes[1].step) - Vector3::new(10.0, 0.0, 0.0)).norm() < 0.2);
    assert!((Vector3::from(screen.episodes[2].step) - Vector3::new(0.0, 2.0, 0.0)).norm() < 0.2);

    // Filtered without them, the smoothed trajectory stays on the truth through the step.
    let forward = filter_excluding(&s.imu, &s.gnss, &s.initial, &s.config, &screen.excluded).unwrap();
    let excluded_decisions = forward.innovations.iter().filter(|i| i.decision == Decision::Excluded).count();
    assert_eq!(excluded_decisions, expected.len());
    let truth = s.drive.trajectory.records();
    let worst_in = |smoothed: &[SmoothedEpoch], from: f64, to: f64| {
        smoothed
            .iter()
            .zip(truth)
            .filter(|(e, _)| e.time >= from && e.time < to)
            .map(|(e, t)| (e.position.p - t.position.p).xy().norm())
            .fold(0.0, f64::max)
    };
    let smoothed = smooth(&forward).unwrap();
    let absorbed = smooth(&first).unwrap();
    let (during, before) = (worst_in(&smoothed, a, b), worst_in(&smoothed, t0 + 5.0, a - 5.0));
    println!(
        "worst inside the step: {during:.3} m excluded, {:.3} m absorbed; before it {before:.3} m",
        worst_in(&absorbed, a, b)
    );
    // 15 s bridged on a navigation-grade IMU at 1 Hz GNSS: a decimetre at most, where the step is 3.4 m.
    assert!(during < 0.15, "the smoothed trajectory leaves the truth by {during} m inside the step");
    assert!(worst_in(&absorbed, a, b) > 1.0, "the step should matter to the filter that takes it in");
}

#[test]
fn a_chain_that_starts_inside_a_fault_trusts_the_level_most_of_its_fixes_share() {
    let mut s = navigation::scenario(8, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 1.0);
    let t0 = s.drive.trajectory.records()[0].time;
    // An outage of 20 s (longer than the test bridges), and the first 12 s after it carry a 3 m fault.
    s.gnss.retain(|f| !(f.time >= t0 + 60.0 && f.time < t0 + 80.0));
    let fault = fixes_in(&s.gnss, t0 + 80.0, t0 + 92.0);
    fault.iter().for_each(|&i| s.gnss[i].position.p += Vector3::new(-3.0, 0.0, 0.5));
    let first = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
    let screen = screen_steps(&first, &s.gnss, &StepTest::default());
    let excluded: Vec<usize> = (0..s.gnss.len()).filter(|&i| screen.excluded[i]).collect();
    assert_eq!(excluded, fault, "{:?}", screen.episodes);
    assert_eq!(screen.episodes.len(), 1);
    assert_eq!(screen.episodes[0].ended, EpisodeEnd::Returned);
}

/// A fault that changes level at consecutive fixes (4 m, then 1.6 m more, then back): the second step's
/// evidence is small beside the first's side lobe, and only estimating the run of steps together keeps it.
#[test]
fn steps_at_consecutive_fixes_are_each_declared() {
    let mut s = navigation::scenario(9, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 1.0);
    let t0 = s.drive.trajectory.records()[0].time;
    let fault = fixes_in(&s.gnss, t0 + 50.0, t0 + 56.0);
    for (n, &i) in fault.iter().enumerate() {
        s.gnss[i].position.p.x += if n == 0 { 4.0 } else { 5.6 };
    }
    let first = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
    let screen = screen_steps(&first, &s.gnss, &StepTest::default());
    let excluded: Vec<usize> = (0..s.gnss.len()).filter(|&i| screen.excluded[i]).collect();
    assert_eq!(excluded, fault, "{:?}", screen.episodes);
    assert_eq!(screen.steps, 3, "out, further out, back: {screen:?}");
    assert!((Vector3::from(screen.episodes[0].step) - Vector3::new(4.0, 0.0, 0.0)).norm() < 0.2, "{screen:?}");
}

#[test]
fn step_test_parameters_are_checked_by_name() {
    let bad = [
        (StepTest { alpha: 0.0, ..StepTest::default() }, "steps.alpha"),
        (StepTest { max_gap: f64::NAN, ..StepTest::default() }, "steps.max_gap"),
        (StepTest { min_step: -1.0, ..StepTest::default() }, "steps.min_step"),
    ];
    for (test, field) in bad {
        let e = test.check().unwrap_err();
        assert!(matches!(e, NavError::Config { field: f, .. } if f == field), "{e}");
    }
    assert!(StepTest::default().check().is_ok());
}

/// A logger's dropout held through the entry into a corner hides a 15° turn, and a 3 m multipath step
/// begins 4 s after it: the step test, judging fixes against the IMU's free displacement, excludes the step's
/// fixes and nothing else (its first pass keeps a stiff heading through the gap, so the hidden turn reads as
/// a slow drift), and the final pass bridges both.
#[test]
fn an_imu_dropout_is_not_taken_for_a_gnss_step_and_hides_none() {
    let mut s = navigation::scenario(9, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 1.0);
    let onset = navigation::corner_onset(&s.imu, 30.0);
    let missed = navigation::hold_dropout(&mut s.imu, onset - 100, onset + 59);
    assert!(missed.to_degrees().abs() > 10.0, "{}°", missed.to_degrees());
    let t = s.imu[onset].time;
    let multipath = fixes_in(&s.gnss, t + 4.0, t + 19.0);
    multipath.iter().for_each(|&i| s.gnss[i].position.p += Vector3::new(-2.0, 2.0, 1.0));
    let (forward, screen) = filter_screened(&s.imu, &s.gnss, &s.initial, &s.config, &StepTest::default()).unwrap();
    let excluded: Vec<usize> = (0..s.gnss.len()).filter(|&i| screen.excluded[i]).collect();
    assert_eq!(excluded, multipath, "{:?}", screen.episodes);
    assert_eq!(forward.imu_gaps().len(), 1);
    let smoothed = smooth(&forward).unwrap();
    let worst = worst_smoothed(&smoothed, &s, t - 5.0, t + 25.0);
    println!(
        "held 1.6 s dropout missing {:.1}° and a 3 m step after it: smoothed max error {worst:.3} m",
        missed.to_degrees()
    );
    assert!(worst < 0.2, "{worst} m");
}
