#![allow(clippy::unwrap_used)]
//! Innovation tests (Cazzaniga et al. 2007 §3.1.2): nominal false-alarm rates on clean data, detection of injected
//! faults (a 1 m GNSS jump for 10 s, a step in an accelerometer bias); the fixes' scatter measured against
//! their stated σ.

use plumbline_fixtures::navigation;

use plumbline_navigation::{
    Component, Flag, IntegrityConfig, NavConfig, TestKind, filter, measure_fix_noise, measure_gnss_correlation,
    test_innovations,
};
use plumbline_synth::motion::imu::ImuErrors;
use rand::SeedableRng;

/// |count − n·p| within 4 binomial standard deviations (+1 for discreteness).
fn within_binomial(count: usize, n: usize, p: f64) -> bool {
    let mean = n as f64 * p;
    (count as f64 - mean).abs() <= 4.0 * (mean * (1.0 - p)).sqrt() + 1.0
}

#[test]
fn clean_data_rejects_at_nominal_rate() {
    let window = 10;
    let local = IntegrityConfig { alpha: 0.01, window };
    let global = IntegrityConfig { alpha: 0.05, window };
    let (mut epochs, mut windows) = (0usize, 0usize);
    let count = |flags: &[Flag], kind: TestKind, keep: &dyn Fn(&Flag) -> bool| {
        flags.iter().filter(|f| f.test == kind && keep(f)).count()
    };
    let (mut lo, mut ls, mut go, mut gs) = (0, 0, 0, 0);
    for seed in [1, 2, 3, 4] {
        let s = navigation::scenario(seed, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
        let fw = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
        let inn = &fw.innovations;
        epochs += inn.len();
        let fl = test_innovations(inn, &local).unwrap();
        lo += count(&fl, TestKind::LocalOverall, &|_| true);
        ls += count(&fl, TestKind::LocalSlippage, &|_| true);
        // Non-overlapping windows only: overlapping ones are correlated.
        let ends: Vec<f64> = inn.iter().skip(window - 1).step_by(window).map(|i| i.time).collect();
        windows += ends.len();
        let fg = test_innovations(inn, &global).unwrap();
        let at_end = |f: &Flag| ends.contains(&f.time);
        go += count(&fg, TestKind::GlobalOverall, &at_end);
        gs += count(&fg, TestKind::GlobalSlippage, &at_end);
    }
    println!("{epochs} epochs: local overall {lo}, local slippage {ls}; {windows} windows: global {go}, {gs}");
    assert!(within_binomial(lo, epochs, 0.01), "local overall {lo} of {epochs}");
    // The slippage flag reports the worst of three nearly independent components.
    let any3 = |a: f64| 1.0 - (1.0 - a).powi(3);
    assert!(within_binomial(ls, epochs, any3(0.01)), "local slippage {ls} of {epochs}");
    assert!(within_binomial(go, windows, 0.05), "global overall {go} of {windows}");
    assert!(within_binomial(gs, windows, any3(0.05)), "global slippage {gs} of {windows}");
}

#[test]
fn gnss_jump_is_flagged_and_blamed_on_its_component() {
    let mut s = navigation::scenario(5, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
    let t0 = s.drive.trajectory.records()[0].time;
    let (a, b) = (t0 + 80.0, t0 + 90.0);
    for f in s.gnss.iter_mut().filter(|f| f.time >= a && f.time < b) {
        f.position.p.y += 1.0;
    }
    let fw = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
    let flags = test_innovations(&fw.innovations, &IntegrityConfig::default()).unwrap();
    let first = |kind| flags.iter().find(|f| f.test == kind && f.time >= a).unwrap();
    let jump = first(TestKind::LocalOverall);
    assert!(jump.time < a + 0.01, "local overall fires at the jump's first fix, not at {}", jump.time - a);
    assert!(jump.statistic > 100.0 * jump.critical, "1 m against 1 cm σ: {}", jump.statistic);
    let slip = first(TestKind::LocalSlippage);
    assert_eq!((slip.time, slip.component), (jump.time, Some(Component::GnssNorth)));
    let back = flags.iter().find(|f| f.test == TestKind::LocalSlippage && f.time >= b).unwrap();
    assert!(back.time < b + 0.01 && back.component == Some(Component::GnssNorth), "jump back at {}", back.time - b);
    let before = flags.iter().filter(|f| f.time < a).count();
    assert!(before <= 6, "{before} flags before the jump at α = 0.001");
}

#[test]
fn accelerometer_bias_step_is_flagged() {
    let mut s = navigation::scenario(6, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
    let t0 = s.drive.trajectory.records()[0].time;
    let step_at = t0 + 100.0;
    let step = 0.01; // ~1 mg on the forward axis
    navigation::add_bias_step(&mut s.imu, step_at, step);
    let fw = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
    let flags = test_innovations(&fw.innovations, &IntegrityConfig::default()).unwrap();
    let after: Vec<&Flag> = flags.iter().filter(|f| f.time > step_at).collect();
    let first = after.first().expect("the bias step is detected");
    println!("first flag {:?} after {:.2} s; {} flags after the step", first.test, first.time - step_at, after.len());
    assert!(first.time - step_at < 5.0, "detected {} s after the step", first.time - step_at);
    let before = flags.iter().filter(|f| f.time <= step_at).count();
    assert!(before <= 6, "{before} flags before the step at α = 0.001");
}

#[test]
fn fix_noise_is_measured_against_the_stated_sigma() {
    for seed in [1, 2] {
        let mut s = navigation::scenario(seed, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
        let fw = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
        let fitting = measure_fix_noise(&fw, &s.gnss).unwrap();
        println!("seed {seed}, σ as stated: {fitting:?}");
        assert_eq!(fitting.fixes, s.gnss.len());
        assert_eq!(fitting.excess(), [false; 3], "{fitting:?}");
        assert!(fitting.factor.iter().all(|k| (0.6..1.5).contains(k)), "{fitting:?}");
        // Twice the stated σ added on every axis while the stated σ stay: the scatter is √5 × the σ.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        for f in &mut s.gnss {
            for a in 0..3 {
                f.position.p[a] += 2.0 * f.std[a] * navigation::gauss(&mut rng);
            }
        }
        let fw = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
        let optimistic = measure_fix_noise(&fw, &s.gnss).unwrap();
        println!("seed {seed}, σ stated half the scatter: {optimistic:?}");
        assert_eq!(optimistic.excess(), [true; 3], "{optimistic:?}");
        assert!(optimistic.factor.iter().all(|k| (3.5..7.0).contains(k)), "{optimistic:?}");
    }
}

#[test]
fn fix_noise_needs_enough_fixes() {
    let s = navigation::scenario(3, &navigation::block_route(1), &ImuErrors::NAVIGATION, 100.0, 5.0);
    let fw = filter(&s.imu, &s.gnss[..20], &s.initial, &s.config).unwrap();
    assert!(measure_fix_noise(&fw, &s.gnss[..20]).is_none());
}

/// A lasting error in the fixes — a Gauss–Markov process of their stated σ with a 5 s correlation time,
/// as a receiver's filter or slow multipath leaves — is found and taken as a state; fixes whose errors
/// are white get no model. With the state, the local test flags far fewer of the good fixes. A lasting error
/// three times the stated σ is found too, and the fixes' scatter measured with the state says the σ are
/// optimistic.
#[test]
fn a_lasting_gnss_error_is_measured_and_modelled() {
    let local = IntegrityConfig { alpha: 0.01, window: 10 };
    for seed in [1, 2] {
        let clean = navigation::scenario(seed, &navigation::block_route(2), &ImuErrors::NAVIGATION, 100.0, 1.0);
        let white =
            measure_gnss_correlation(&clean.imu, &clean.gnss, &clean.initial, &clean.config, &[]).unwrap().unwrap();
        println!("seed {seed}, white fixes: {white:?}");
        assert!(!white.significant(), "{white:?}");
        let lasting = |factor: f64| {
            let mut gnss = clean.gnss.clone();
            let tau = 5.0;
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 10);
            let mut error = [0.0f64; 3];
            let mut last = gnss[0].time;
            for f in &mut gnss {
                let phi = (-(f.time - last) / tau).exp();
                last = f.time;
                for (a, e) in error.iter_mut().enumerate() {
                    *e = phi * *e + (1.0 - phi * phi).sqrt() * factor * f.std[a] * navigation::gauss(&mut rng);
                    f.position.p[a] += *e;
                }
            }
            navigation::Scenario { gnss, ..clean.clone() }
        };
        let s = lasting(1.0);
        let found = measure_gnss_correlation(&s.imu, &s.gnss, &s.initial, &s.config, &[]).unwrap().unwrap();
        println!("seed {seed}, lasting error of the stated σ, 5 s: {found:?}");
        let model = found.model().expect("a lasting error of the stated σ is significant");
        assert!((1.5..20.0).contains(&model.correlation_time), "{model:?}");
        assert!(model.std.iter().zip(&s.gnss[0].std).all(|(m, stated)| m == stated), "{model:?}");
        let flagged = |config| {
            let fw = filter(&s.imu, &s.gnss, &s.initial, config).unwrap();
            let flags = test_innovations(&fw.innovations, &local).unwrap();
            (flags.iter().filter(|f| f.test == TestKind::LocalOverall).count(), fw.innovations.len())
        };
        let (as_white, n) = flagged(&s.config);
        let (as_state, _) = flagged(&NavConfig { gnss_error: Some(model), ..s.config });
        println!("seed {seed}: local test flags {as_white} of {n} taken as white, {as_state} with the state");
        assert!(as_state * 3 <= as_white, "{as_state} with the state against {as_white} as white");
        assert!(within_binomial(as_state, n, 0.01) || as_state as f64 <= n as f64 * 0.01, "{as_state} of {n}");

        let s = lasting(3.0);
        let found = measure_gnss_correlation(&s.imu, &s.gnss, &s.initial, &s.config, &[]).unwrap().unwrap();
        println!("seed {seed}, lasting error of 3 × the stated σ, 5 s: {found:?}");
        let model = found.model().expect("a lasting error of 3 × the stated σ is significant");
        let fw = filter(&s.imu, &s.gnss, &s.initial, &NavConfig { gnss_error: Some(model), ..s.config }).unwrap();
        let scatter = measure_fix_noise(&fw, &s.gnss).unwrap();
        println!("seed {seed}, scatter with the state: {scatter:?}");
        assert_eq!(scatter.excess(), [true; 3], "{scatter:?}");
    }
}
