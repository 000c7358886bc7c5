//! Seeded synthetic streets corrected with pole CUPTs: a drifting DG trajectory with a jump is pulled onto
//! the truth; posterior σ is calibrated; a 1 m wrong control point is rejected by data snooping.
#![allow(clippy::unwrap_used)]

use faer::Par;
use plumbline_adjustment::{
    AdjustmentConfig, AdjustmentInput, ObservationRef, ObservationSetV1, WeakLink, adjust, adjust_observed,
};
use plumbline_fixtures::adjustment::*;
use rand::SeedableRng;

fn run(
    s: &Scene,
    obs: &ObservationSetV1,
    links: &[WeakLink],
    config: &AdjustmentConfig,
) -> plumbline_adjustment::Adjustment {
    let m = mount();
    let input = AdjustmentInput { trajectory: &s.dg, observations: obs, mount: &m, weak_links: links };
    adjust(&input, config, Par::Seq).unwrap()
}

#[test]
fn exact_cupts_pull_a_drifting_jumping_trajectory_onto_the_truth() {
    let s = scene(120.0, 10.0, None, drift_and_jump(60.05), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    // Poles every 30 m (3 s at 10 m/s), exact observations.
    let obs = ObservationSetV1 { poles: poles(&s, 30, 0.0, 0.005, &mut rng), ..Default::default() };
    let links = [WeakLink { start: 60.0, end: 60.1, factor: 100.0 }];
    let config = AdjustmentConfig { node_spacing: Some(0.5), ..AdjustmentConfig::default() };
    let result = run(&s, &obs, &links, &config);
    let corrected = result.apply(&s.dg).unwrap();
    let before = horizontal_errors(&s.dg, &s.truth);
    let after = horizontal_errors(&corrected, &s.truth);
    // Inside the pole-covered span (first and last pole at 1.5 s and 118.5 s).
    let inner = |v: &[f64]| v[15..=1185].to_vec();
    eprintln!(
        "DG rms {:.3} max {:.3}; corrected rms {:.4} max {:.4}",
        rms(&before),
        max(&before),
        rms(&inner(&after)),
        max(&inner(&after))
    );
    assert!(rms(&before) > 0.25, "the DG error must be substantial");
    assert!(rms(&inner(&after)) < 0.01, "rms {}", rms(&inner(&after)));
    assert!(max(&inner(&after)) < 0.03, "max {}", max(&inner(&after)));
    assert!(result.rejected.is_empty(), "{:?}", result.rejected);
    // Without the flag the stiff relative constraints smear the jump over the neighbouring poles.
    let stiff = run(&s, &obs, &[], &config).apply(&s.dg).unwrap();
    let smeared = inner(&horizontal_errors(&stiff, &s.truth));
    assert!(max(&smeared) > 0.05, "max {}", max(&smeared));
}

#[test]
fn noisy_cupts_give_calibrated_posterior_sigma() {
    let s = scene(120.0, 10.0, None, random_walk_truth(5), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
    let obs = ObservationSetV1 { poles: poles(&s, 20, 0.03, 0.0, &mut rng), ..Default::default() };
    let config = AdjustmentConfig { snooping: None, huber: None, ..AdjustmentConfig::default() };
    let result = run(&s, &obs, &[], &config);
    // Normalised errors of the node positions against the truth correction.
    let mut z = Vec::new();
    for n in &result.nodes[1..result.nodes.len() - 1] {
        let truth = s.correction[(n.time * 10.0).round() as usize];
        let std = n.std();
        for c in 0..2 {
            z.push((n.position[c] - truth[c]) / std[c]);
        }
    }
    let zrms = rms(&z);
    let f = result.variance_factors.poles;
    eprintln!("pole variance factor {f:.3}");
    // The stated σ is right, so the variance component is 1 within its sampling error (~0.2 here); σ off by
    // a factor 2 either way would give 0.25 or 4.
    assert!((0.6..1.6).contains(&f), "variance factor {f}");
    assert!(result.variance_factors.gnss.is_nan());
    eprintln!("normalised rms {zrms:.3} over {} values, sigma0 {:.3}", z.len(), result.sigma0);
    // A weight off by a factor 2 (σ vs σ², a missing eq. (1) term) moves this well outside the band.
    assert!((0.7..1.4).contains(&zrms), "normalised rms {zrms}");
    assert!(max(&z.iter().map(|v| v.abs()).collect::<Vec<_>>()) < 4.5);
    let corrected = result.apply(&s.dg).unwrap();
    let after = horizontal_errors(&corrected, &s.truth);
    assert!(rms(&after[10..1190]) < 0.04, "rms {}", rms(&after));
}

#[test]
fn a_control_point_one_metre_off_is_rejected_by_data_snooping() {
    let s = scene(120.0, 10.0, None, drift_and_jump(1e9), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut obs = ObservationSetV1 { poles: poles(&s, 30, 0.03, 0.05, &mut rng), ..Default::default() };
    obs.poles[17].cadastre[0] += 0.8;
    obs.poles[17].cadastre[1] -= 0.6;
    let result = run(&s, &obs, &[], &AdjustmentConfig::default());
    let rejected: Vec<_> = result.rejected.iter().map(|r| r.item.clone()).collect();
    assert_eq!(rejected, [ObservationRef::Pole { index: 17, cadastre_id: "pole-17".into() }], "{:?}", result.rejected);
    assert!(result.rejected[0].w > 10.0);
    let after = horizontal_errors(&result.apply(&s.dg).unwrap(), &s.truth);
    let clean = max(&after[15..1186]);
    assert!(clean < 0.08, "max {clean}");
    // Without snooping or robust weights the blunder bends the trajectory far more.
    let plain = AdjustmentConfig { snooping: None, huber: None, ..AdjustmentConfig::default() };
    let bent = horizontal_errors(&run(&s, &obs, &[], &plain).apply(&s.dg).unwrap(), &s.truth);
    assert!(max(&bent) > 0.1 && max(&bent) > 2.0 * clean, "max {} vs {clean}", max(&bent));
    // Huber IRLS alone (no snooping) already shrinks the blunder's pull severalfold.
    let huber = AdjustmentConfig { snooping: None, ..AdjustmentConfig::default() };
    let robust = horizontal_errors(&run(&s, &obs, &[], &huber).apply(&s.dg).unwrap(), &s.truth);
    assert!(max(&robust) < 0.5 * max(&bent), "huber {} vs plain {}", max(&robust), max(&bent));
}

#[test]
fn broken_observations_are_skipped_and_named_while_the_rest_is_used() {
    let s = scene(60.0, 10.0, None, drift_and_jump(1e9), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    let mut obs = ObservationSetV1 { poles: poles(&s, 30, 0.0, 0.01, &mut rng), ..Default::default() };
    obs.poles[2].sigma_camera = f64::NAN;
    obs.poles[4].time = 500.0;
    let result = run(&s, &obs, &[], &AdjustmentConfig::default());
    let fields: Vec<_> = result.skipped.iter().map(|e| (e.item.clone(), e.field)).collect();
    assert!(fields.contains(&(ObservationRef::Pole { index: 2, cadastre_id: "pole-2".into() }, "sigma_camera")));
    assert!(fields.contains(&(ObservationRef::Pole { index: 4, cadastre_id: "pole-4".into() }, "time")));
    let after = horizontal_errors(&result.apply(&s.dg).unwrap(), &s.truth);
    assert!(rms(&after[15..586]) < 0.02, "rms {}", rms(&after[15..586]));
}

#[test]
fn the_corrected_trajectory_carries_interpolated_posterior_sigma() {
    let s = scene(60.0, 10.0, None, drift_and_jump(1e9), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
    let obs = ObservationSetV1 { poles: poles(&s, 50, 0.02, 0.02, &mut rng), ..Default::default() };
    let result = run(&s, &obs, &[], &AdjustmentConfig::default());
    let corrected = result.apply(&s.dg).unwrap();
    let records = corrected.records();
    // At a node epoch the record's σ is the node's σ.
    let node = &result.nodes[2];
    let at = records.iter().find(|r| (r.time - node.time).abs() < 1e-9).unwrap();
    assert!((at.std.unwrap().east - node.std()[0]).abs() < 1e-12);
    // Midway between poles (5 s apart) the position is less certain than at the poles.
    let (t0, t1) = (result.nodes[2].time, result.nodes[3].time);
    let mid = records.iter().find(|r| (r.time - 0.5 * (t0 + t1)).abs() < 0.051).unwrap();
    assert!(mid.std.unwrap().east > at.std.unwrap().east);
    // And the corrected record is the DG record moved by the interpolated correction.
    let (delta, _) = result.correction_at(mid.time).unwrap();
    let dg = s.dg.records().iter().find(|r| r.time == mid.time).unwrap();
    assert!((mid.position.p - dg.position.p - delta.fixed_rows::<3>(0)).norm() < 1e-9);
}

#[test]
fn the_export_holds_the_nodes_chain_and_poles_the_adjustment_solves() {
    let s = scene(30.0, 10.0, None, drift_and_jump(1e9), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut obs = ObservationSetV1 { poles: poles(&s, 20, 0.03, 0.02, &mut rng), ..Default::default() };
    obs.poles[3].sigma_camera = -1.0;
    let result = run(&s, &obs, &[], &AdjustmentConfig::default());
    let m = mount();
    let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: &[] };
    let exported = plumbline_adjustment::export(&input, &AdjustmentConfig::default());
    assert_eq!(exported.nodes.len(), result.nodes.len());
    assert_eq!(exported.links.len(), result.nodes.len() - 1);
    assert_eq!(exported.link_means.len(), exported.links.len());
    assert_eq!(exported.poles.len(), obs.poles.len() - 1, "the broken pole is left out");
    for (e, n) in exported.nodes.iter().zip(&result.nodes) {
        assert_eq!(e.time, n.time);
    }
    for (e, l) in exported.links.iter().zip(&result.link_variances) {
        assert!((e[0] * e[0] - l[0]).abs() < 1e-15 && (e[5] * e[5] - l[5]).abs() < 1e-18);
    }
    let p = &exported.poles[0];
    assert!((p.sigma - obs.poles[0].sigma()).abs() < 1e-15 && p.cadastre == obs.poles[0].cadastre);
}

/// The correction at t = 20 s of a DG that is the truth, when one pole 10 m from the vehicle, its cadastre
/// entry 0.3 m off, is seen from `epochs` (σ_cam 5 cm, σ_pole 0.3 m); plain least squares.
fn pull_of_one_biased_pole(epochs: &[usize], pole_offsets: bool) -> f64 {
    let s = scene(40.0, 10.0, None, |_| nalgebra::Vector6::zeros(), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
    let at = &s.truth[200];
    let x = at.position.p + at.attitude.to_rotation().matrix() * nalgebra::Vector3::new(8.0, 6.0, 0.0);
    let bias = nalgebra::Vector2::new(0.18, -0.24);
    let updates = epochs
        .iter()
        .map(|&i| plumbline_adjustment::PoleUpdate {
            cadastre_id: "light-1".into(),
            time: s.truth[i].time,
            cadastre: [x.x + bias.x, x.y + bias.y],
            observed: [x.x + 0.05 * gauss(&mut rng), x.y + 0.05 * gauss(&mut rng)],
            sigma_camera: 0.05,
            sigma_pole: 0.3,
        })
        .collect();
    let obs = ObservationSetV1 { poles: updates, ..Default::default() };
    let config = AdjustmentConfig { snooping: None, huber: None, pole_offsets, ..AdjustmentConfig::default() };
    let (delta, _) = run(&s, &obs, &[], &config).correction_at(20.0).unwrap();
    delta.fixed_rows::<2>(0).norm()
}

#[test]
fn updates_of_one_pole_share_its_cadastre_error() {
    let ten: Vec<usize> = (195..205).collect();
    let single = pull_of_one_biased_pole(&[200], true);
    let shared = pull_of_one_biased_pole(&ten, true);
    let independent = pull_of_one_biased_pole(&ten, false);
    eprintln!(
        "pull of a 0.3 m cadastre error: 1 update {single:.3} m, 10 shared {shared:.3}, 10 independent {independent:.3}"
    );
    // One object, one cadastre error: ten sightings pull no harder than one (the camera noise averages, the
    // cadastre error does not). Weighted as independent control (same nodes, same data), they pull several
    // times as hard as the shared model lets them.
    assert!(single > 0.01, "the pole must pull at all: {single}");
    assert!(shared <= single, "shared {shared} vs single {single}");
    assert!(independent > 3.0 * shared, "independent {independent} vs shared {shared}");
}

#[test]
fn control_decides_between_flagged_jumps_where_the_dg_sigma_is_optimistic() {
    // The DG reports 2 cm but is 0.8 m off between its flagged jumps at 40 s and 60 s; poles every second
    // (σ_cam 0.3 m). The prior of 10 × 2 cm at every node would hold the trajectory near the DG.
    let jump = |t: f64| {
        let off = if (40.0..60.0).contains(&t) { 0.8 } else { 0.0 };
        nalgebra::Vector6::new(off, 0.05 * (t / 30.0).sin(), 0.0, 0.0, 0.0, 0.0)
    };
    let s = scene(100.0, 10.0, None, jump, 0.02);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
    let obs = ObservationSetV1 { poles: poles(&s, 10, 0.3, 0.05, &mut rng), ..Default::default() };
    let links =
        [WeakLink { start: 39.9, end: 40.1, factor: 100.0 }, WeakLink { start: 59.9, end: 60.1, factor: 100.0 }];
    let inside = |config: &AdjustmentConfig| {
        let errors = horizontal_errors(&run(&s, &obs, &links, config).apply(&s.dg).unwrap(), &s.truth);
        rms(&errors[420..580])
    };
    let floored = inside(&AdjustmentConfig::default());
    let held = inside(&AdjustmentConfig { fault_prior: None, ..AdjustmentConfig::default() });
    eprintln!("rms inside the fault: {floored:.3} m with the floor, {held:.3} m without");
    // 20 poles of σ 0.3 m fix the offset to ~7 cm; the tight prior keeps most of the 0.8 m.
    assert!(floored < 0.15, "with the floor: {floored}");
    assert!(held > 0.4, "without: {held}");
}

#[test]
fn every_iteration_is_reported_and_the_last_one_has_the_final_sigma0() {
    let s = scene(120.0, 10.0, None, drift_and_jump(1e9), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let mut obs = ObservationSetV1 { poles: poles(&s, 30, 0.03, 0.05, &mut rng), ..Default::default() };
    obs.poles[17].cadastre[0] += 0.8;
    let m = mount();
    let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: &[] };
    let mut seen = Vec::new();
    let result = adjust_observed(&input, &AdjustmentConfig::default(), Par::Seq, &mut |it| seen.push(*it)).unwrap();
    assert_eq!(seen.len(), result.iterations);
    assert!(seen.iter().enumerate().all(|(i, it)| it.iteration == i + 1), "{seen:?}");
    assert!(seen.windows(2).all(|w| w[0].round <= w[1].round && w[0].rejected <= w[1].rejected), "{seen:?}");
    // Round 0 is the Huber solution, then one snooping round rejected the bad pole, then a clean one.
    let last = seen.last().unwrap();
    assert_eq!((seen[0].round, last.round, last.rejected, result.rejected.len()), (0, 2, 1, 1), "{seen:?}");
    assert!((last.sigma0 - result.sigma0).abs() < 1e-6 * result.sigma0, "{} vs {}", last.sigma0, result.sigma0);
    assert_eq!(last.note(), format!("iteration {}: σ0 {:.2}, 1 rejected", result.iterations, result.sigma0));
}
