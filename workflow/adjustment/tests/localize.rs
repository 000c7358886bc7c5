//! Jumps rising inside a flagged interval with control only outside it: the links inside follow the vehicle's
//! reference motion (their mean is minus the DG's anomalous displacement), so the correction follows the
//! jump's own profile through its rise — not the share of it a σ-only widening gives each link (a
//! least-squares increment goes with σ², which piles a large jump into its steepest links and leaves a small
//! fall next to a large rise nearly uncorrected). The DG reports σ 0.1 m (a canyon): with a jump that lasts
//! to the end, a σ of 2 cm would let the weak prior hold the trajectory near the DG.
#![allow(clippy::unwrap_used)]

use faer::Par;
use nalgebra::{Vector3, Vector6};
use plumbline_adjustment::{Adjustment, AdjustmentConfig, AdjustmentInput, ObservationSetV1, WeakLink, adjust};
use plumbline_fixtures::adjustment::*;
use rand::SeedableRng;

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// A unit vector at `degrees` clockwise from the street's direction (30° north of east).
fn direction(degrees: f64) -> Vector3<f64> {
    let a = (30.0 - degrees).to_radians();
    Vector3::new(a.cos(), a.sin(), 0.0)
}

/// A smooth drift plus DG jumps (the correction is minus the DG's offset): each (size, direction, rise start,
/// fall start), rising and falling over 1 s.
fn jumps(list: Vec<(f64, Vector3<f64>, f64, f64)>) -> impl Fn(f64) -> Vector6<f64> {
    move |t| {
        let offset: Vector3<f64> = list
            .iter()
            .map(|(size, dir, rise, fall)| dir * (size * smoothstep(t - rise).min(1.0 - smoothstep(t - fall))))
            .sum();
        Vector6::new(0.1 * (t / 25.0).sin() - offset.x, 0.05 * (t / 40.0).cos() - offset.y, 0.0, 0.0, 0.0, 2e-4)
    }
}

/// Adjust against poles every second (σ 5 cm) outside [gap.0, gap.1] with the given flagged interval.
fn run(s: &Scene, gap: (f64, f64), flagged: (f64, f64), seed: u64) -> Adjustment {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut poles = poles(s, 10, 0.05, 0.0, &mut rng);
    poles.retain(|p| !(gap.0..=gap.1).contains(&p.time));
    let m = mount();
    let obs = ObservationSetV1 { poles, ..Default::default() };
    let links = [WeakLink { start: flagged.0, end: flagged.1, factor: 100.0 }];
    let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: &links };
    adjust(&input, &AdjustmentConfig::default(), Par::Seq).unwrap()
}

/// The largest horizontal error over the records in [a, b].
fn max_in(s: &Scene, result: &Adjustment, a: f64, b: f64) -> f64 {
    let errors = horizontal_errors(&result.apply(&s.dg).unwrap(), &s.truth);
    max(&s.truth.iter().zip(errors).filter(|(r, _)| r.time >= a && r.time <= b).map(|(_, e)| e).collect::<Vec<_>>())
}

#[test]
fn a_large_jump_is_corrected_through_its_rise() {
    // 1.4 m at 70° to the street (mostly sideways, partly along) rising over 60–61 s, until the end.
    let s = scene(120.0, 10.0, None, jumps(vec![(1.4, direction(70.0), 60.0, 1e9)]), 0.1);
    let result = run(&s, (55.0, 66.0), (59.05, 62.05), 51);
    let rise = max_in(&s, &result, 58.0, 63.0);
    eprintln!("max error through the rise: {rise:.3} m");
    // The gap's own error (pole noise, the chain's drift over 11 s at DG σ 0.1 m) is ~5 cm; the 1.4 m rise
    // adds little to it (σ-only widening: 0.08 m here, more where the node spacing is uneven).
    assert!(rise < 0.1, "{rise}");
    assert!(max_in(&s, &result, 1.0, 119.0) < 0.1);
}

#[test]
fn a_small_fall_next_to_a_large_rise_is_corrected_too() {
    // 0.45 m to the left falling over 59–60 s, then 1.2 m to the right (and forwards) rising over 60–61 s.
    let list = vec![(0.45, direction(-90.0), 20.0, 59.0), (1.2, direction(60.0), 60.0, 1e9)];
    let s = scene(120.0, 10.0, None, jumps(list), 0.1);
    let result = run(&s, (55.0, 66.0), (58.5, 62.0), 52);
    let worst = max_in(&s, &result, 57.0, 63.0);
    eprintln!("max error through the fall and the rise: {worst:.3} m");
    // σ-only widening leaves most of the fall in the trajectory (0.29 m); the gap's own error is ~5 cm.
    assert!(worst < 0.12, "{worst}");
}
