//! DG jumps the consistency check did not flag, seen in the DG's own sideways motion: a jump inside a
//! control gap gets short links of its own and is corrected where it happens (and is smeared over the gap
//! without that); an island between two such jumps held only by weak control is freed from the weak prior
//! (the spans are DG breaks; without that the prior holds it near the DG's offset); an IMU heading a degree or
//! two off the direction of travel is estimated as the drive's crab angle, not taken for jumps everywhere.
#![allow(clippy::unwrap_used)]

use faer::Par;
use nalgebra::{Vector3, Vector6};
use plumbline_adjustment::{
    Adjustment, AdjustmentConfig, AdjustmentInput, ObservationSetV1, PoleUpdate, WeakLink, adjust,
};
use plumbline_fixtures::adjustment::*;
use rand::SeedableRng;

/// A smooth drift plus a jump of `size` metres to the left of the street over [from, to) s.
fn island(size: f64, from: f64, to: f64) -> impl Fn(f64) -> Vector6<f64> {
    move |t| {
        let jump = if (from..to).contains(&t) { size } else { 0.0 };
        let left = Vector3::new(-(30f64.to_radians().sin()), 30f64.to_radians().cos(), 0.0) * jump;
        Vector6::new(0.1 * (t / 25.0).sin() + left.x, 0.05 * (t / 40.0).cos() + left.y, 0.0, 0.0, 0.0, 2e-4)
    }
}

fn run(s: &Scene, poles: Vec<PoleUpdate>, config: &AdjustmentConfig) -> Adjustment {
    run_flagged(s, poles, config, &[])
}

fn run_flagged(s: &Scene, poles: Vec<PoleUpdate>, config: &AdjustmentConfig, links: &[WeakLink]) -> Adjustment {
    let m = mount();
    let obs = ObservationSetV1 { poles, ..Default::default() };
    let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: links };
    adjust(&input, config, Par::Seq).unwrap()
}

/// Horizontal errors at the records whose time lies in [a, b].
fn errors_in(s: &Scene, result: &Adjustment, a: f64, b: f64) -> Vec<f64> {
    let errors = horizontal_errors(&result.apply(&s.dg).unwrap(), &s.truth);
    s.truth.iter().zip(errors).filter(|(r, _)| r.time >= a && r.time <= b).map(|(_, e)| e).collect()
}

#[test]
fn an_unflagged_jump_in_a_control_gap_is_corrected_where_it_happens() {
    // A 0.6 m jump at 50 s (lasting to 90 s) between poles at 44 and 56 s: nothing flags it.
    let s = scene(120.0, 10.0, None, island(0.6, 50.0, 90.0), 0.02);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
    let mut poles = poles(&s, 10, 0.05, 0.0, &mut rng);
    poles.retain(|p| !(44.5..=55.5).contains(&p.time));
    let config = AdjustmentConfig::default();
    let with = run(&s, poles.clone(), &config);
    let without = run(&s, poles.clone(), &AdjustmentConfig { kinematic_jumps: None, ..config });
    // Outside the rise itself (one 0.1 s record step at 50 s).
    let gap = |r: &Adjustment| {
        let mut e = errors_in(&s, r, 45.0, 49.8);
        e.extend(errors_in(&s, r, 50.2, 55.0));
        max(&e)
    };
    eprintln!("max error in the gap: {:.3} m with kinematic nodes, {:.3} m without", gap(&with), gap(&without));
    // Without: the widened 12 s link interpolates the 0.6 m step linearly across the gap.
    assert!(gap(&without) > 0.2, "{}", gap(&without));
    assert!(gap(&with) < 0.06, "{}", gap(&with));
    // The control around the gap is kept (the jump is on the chain, not in the poles).
    let near = |r: &plumbline_adjustment::RejectedObservation| match &r.item {
        plumbline_adjustment::ObservationRef::Pole { index, .. } => (35.0..65.0).contains(&poles[*index].time),
        _ => true,
    };
    assert!(!with.rejected.iter().any(near), "{:?}", with.rejected);
}

#[test]
fn a_jump_seen_in_the_dg_motion_frees_its_weakly_controlled_island_from_the_prior() {
    // A 1 m jump over [50, 70) s; the island is seen only by far poles (σ 0.5 m) once a second.
    let s = scene(120.0, 10.0, None, island(1.0, 50.0, 70.0), 0.02);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
    let mut poles = poles(&s, 10, 0.05, 0.0, &mut rng);
    let weak = poles_weak(&s, &mut rng);
    poles.retain(|p| !(49.0..=71.0).contains(&p.time));
    poles.extend(weak);
    let config = AdjustmentConfig::default();
    let with = run(&s, poles.clone(), &config);
    let mut held = config;
    if let Some(k) = &mut held.kinematic_jumps {
        k.widen = false;
    }
    let without = run(&s, poles, &held);
    let island_rms = |r: &Adjustment| rms(&errors_in(&s, r, 51.0, 69.0));
    eprintln!("island RMS: {:.3} m freed, {:.3} m held by the prior", island_rms(&with), island_rms(&without));
    // 20 poles of σ 0.5 m fix the island's offset to ~0.11 m; the prior (10 × 2 cm per node, a node per
    // pole) would hold it near the DG's 1 m.
    assert!(island_rms(&without) > 0.5, "{}", island_rms(&without));
    assert!(island_rms(&with) < 0.35, "{}", island_rms(&with));
}

/// Poles inside the island (50–70 s) once a second with σ_cam 0.5 m.
fn poles_weak(s: &Scene, rng: &mut impl rand::Rng) -> Vec<PoleUpdate> {
    let mut weak = poles(s, 10, 0.5, 0.0, rng);
    weak.retain(|p| (50.5..=69.5).contains(&p.time));
    for p in &mut weak {
        p.cadastre_id = format!("far-{}", p.cadastre_id);
    }
    weak
}

/// The scene with the IMU's heading `crab` radians off the direction of travel (truth and DG alike: the
/// cameras are calibrated to the IMU, only the vehicle's motion is no longer along its heading).
fn crabbed(s: Scene, crab: f64) -> Scene {
    let turn = |r: &plumbline_geo::TrajectoryRecord| {
        let mut r = *r;
        r.attitude.heading += crab;
        r
    };
    let dg: Vec<_> = s.dg.records().iter().map(turn).collect();
    let dg = plumbline_geo::Trajectory::new(dg, &plumbline_geo::ValidationLimits::default()).unwrap();
    Scene { truth: s.truth.iter().map(turn).collect(), dg, correction: s.correction }
}

#[test]
fn a_misaligned_heading_leaves_a_clean_drive_alone_and_a_jump_in_a_gap_is_still_corrected() {
    for degrees in [1.0f64, 2.0] {
        let crab = degrees.to_radians();
        // No jump: the drift alone, control every second but in 44.5–55.5 s.
        let clean = crabbed(scene(120.0, 10.0, None, island(0.0, 50.0, 90.0), 0.02), crab);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(43);
        let mut control = poles(&clean, 10, 0.05, 0.0, &mut rng);
        control.retain(|p| !(44.5..=55.5).contains(&p.time));
        let config = AdjustmentConfig::default();
        let result = run(&clean, control.clone(), &config);
        let all = max(&errors_in(&clean, &result, 1.0, 119.0));
        // Unestimated, the crab's 17–35 cm/s of sideways motion is taken for jumps everywhere.
        let mut naive = config;
        if let Some(k) = &mut naive.kinematic_jumps {
            k.crab = false;
        }
        let naive_all = max(&errors_in(&clean, &run(&clean, control, &naive), 1.0, 119.0));
        eprintln!("{degrees}° crab, no jump: max error {all:.3} m ({naive_all:.3} m taking the heading as travel)");
        assert!(all < 0.06, "{degrees}°: {all}");
        assert!(naive_all > 2.0 * all, "{degrees}°: {naive_all} vs {all}");
        // A 0.3 m sideways jump at 50 s in the gap.
        let s = crabbed(scene(120.0, 10.0, None, island(0.3, 50.0, 90.0), 0.02), crab);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(44);
        let mut control = poles(&s, 10, 0.05, 0.0, &mut rng);
        control.retain(|p| !(44.5..=55.5).contains(&p.time));
        let result = run(&s, control, &config);
        let mut gap = errors_in(&s, &result, 45.0, 49.8);
        gap.extend(errors_in(&s, &result, 50.2, 55.0));
        eprintln!("{degrees}° crab, 0.3 m jump in the gap: max error {:.3} m", max(&gap));
        assert!(max(&gap) < 0.06, "{degrees}°: {}", max(&gap));
    }
}
