//! Image-derived motion between panoramas as a relative observation: a DG jump inside a control gap, flagged
//! at its edges by the consistency check, is corrected with the motions (and left at the DG's offset without
//! them); a motion 1 m off is rejected by data snooping and does not bend the trajectory.
#![allow(clippy::unwrap_used)]

use faer::Par;
use nalgebra::{Vector3, Vector6};
use plumbline_adjustment::{
    Adjustment, AdjustmentConfig, AdjustmentInput, ObservationSetV1, RelativeMotion, WeakLink, adjust,
};
use plumbline_fixtures::adjustment::*;
use rand::{Rng, SeedableRng};

/// Image-motion σ: east, north (m), heading (rad) (Jende et al. 2017 §3.3).
const STD: [f64; 3] = [0.02, 0.02, 1e-3];

/// Smooth drift plus a 0.4 m jump to the left of the street (heading 30° east of north) over [50, 70) s.
fn drift_and_island(t: f64) -> Vector6<f64> {
    let jump = if (50.0..70.0).contains(&t) { 0.4 } else { 0.0 };
    let left = Vector3::new(-(30f64.to_radians().sin()), 30f64.to_radians().cos(), 0.0) * jump;
    Vector6::new(0.1 * (t / 25.0).sin() + left.x, 0.05 * (t / 40.0).cos() + left.y, 0.0, 0.0, 0.0, 2e-4)
}

/// Motions between records `every` apart, measured from the truth with [`STD`] noise.
fn motions(s: &Scene, every: usize, rng: &mut impl Rng) -> Vec<RelativeMotion> {
    (0..s.truth.len() - every)
        .step_by(every)
        .map(|i| {
            let (a, b) = (&s.truth[i], &s.truth[i + every]);
            let d = b.position.p - a.position.p;
            let turn = b.attitude.heading - a.attitude.heading;
            RelativeMotion {
                start: a.time,
                end: b.time,
                displacement: [d.x + STD[0] * gauss(rng), d.y + STD[1] * gauss(rng)],
                heading_change: turn + STD[2] * gauss(rng),
                std: STD,
            }
        })
        .collect()
}

/// The largest of a motion's three noise draws in units of its σ.
fn largest_noise(s: &Scene, m: &RelativeMotion) -> f64 {
    let at = |t: f64| &s.truth[(t * 10.0).round() as usize];
    let (a, b) = (at(m.start), at(m.end));
    let d = b.position.p - a.position.p;
    let turn = b.attitude.heading - a.attitude.heading;
    let noise = [m.displacement[0] - d.x, m.displacement[1] - d.y, m.heading_change - turn];
    (0..3).map(|i| (noise[i] / m.std[i]).abs()).fold(0.0, f64::max)
}

fn run(s: &Scene, obs: &ObservationSetV1, links: &[WeakLink]) -> Adjustment {
    run_with(s, obs, links, &AdjustmentConfig::default())
}

fn run_with(s: &Scene, obs: &ObservationSetV1, links: &[WeakLink], config: &AdjustmentConfig) -> Adjustment {
    let m = mount();
    let input = AdjustmentInput { trajectory: &s.dg, observations: obs, mount: &m, weak_links: links };
    adjust(&input, config, Par::Seq).unwrap()
}

/// The largest horizontal error over records whose time lies in [a, b].
fn max_in(s: &Scene, result: &Adjustment, a: f64, b: f64) -> f64 {
    let errors = horizontal_errors(&result.apply(&s.dg).unwrap(), &s.truth);
    let inside: Vec<f64> =
        s.truth.iter().zip(errors).filter(|(r, _)| r.time >= a && r.time <= b).map(|(_, e)| e).collect();
    max(&inside)
}

#[test]
fn motions_carry_the_correction_across_a_flagged_jump_in_a_control_gap() {
    let s = scene(120.0, 10.0, None, drift_and_island, 0.02);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(31);
    // Poles every 2 s outside 40–80 s; nothing observes the jump's island.
    let mut poles = poles(&s, 20, 0.03, 0.0, &mut rng);
    poles.retain(|p| !(40.0..=80.0).contains(&p.time));
    // The consistency check flags the panorama pairs across the jump's edges.
    let links = [50.0, 70.0].map(|t| WeakLink { start: t - 0.5, end: t + 0.5, factor: 100.0 });
    // What the motions alone carry: the DG's own motion would show this jump too (kinematics.rs, localize.rs).
    let config = AdjustmentConfig { kinematic_jumps: None, jump_localization: None, ..AdjustmentConfig::default() };
    let without = run_with(&s, &ObservationSetV1 { poles: poles.clone(), ..Default::default() }, &links, &config);
    let with_motions = ObservationSetV1 { poles, motions: motions(&s, 5, &mut rng), ..Default::default() };
    let with = run_with(&s, &with_motions, &links, &config);
    let (before, after) = (max_in(&s, &without, 51.0, 69.0), max_in(&s, &with, 51.0, 69.0));
    eprintln!("max error on the island: {before:.3} m without motions, {after:.3} m with");
    // Without motions the island keeps the DG's 0.4 m offset; with them it is tied to the controlled ends
    // through the two flagged pairs' motions (σ 2 cm each).
    assert!(before > 0.3, "{before}");
    assert!(after < 0.06, "{after}");
    // Snooping rejects only motions whose own noise draw is an outlier (the w-test's nominal false alarms).
    let good = &with_motions.motions;
    assert!(
        with.rejected_motions.iter().all(|r| largest_noise(&s, &good[r.index]) > 3.0),
        "{:?}",
        with.rejected_motions
    );
    // Outside the flagged pairs (without localisation the jump is interpolated linearly across each).
    for (a, b) in [(5.0, 49.5), (50.5, 69.5), (70.5, 115.0)] {
        assert!(max_in(&s, &with, a, b) < 0.1, "{a}-{b} s: {}", max_in(&s, &with, a, b));
    }
}

#[test]
fn a_motion_one_metre_off_is_rejected_and_bends_nothing() {
    let s = scene(120.0, 10.0, None, drift_and_island, 0.02);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(32);
    let links = [50.0, 70.0].map(|t| WeakLink { start: t - 0.5, end: t + 0.5, factor: 100.0 });
    let mut motions = motions(&s, 5, &mut rng);
    let wrong = motions.iter().position(|m| m.start >= 30.0).unwrap();
    motions[wrong].displacement[0] += 0.6;
    motions[wrong].displacement[1] += 0.8;
    let obs = ObservationSetV1 { poles: poles(&s, 20, 0.03, 0.0, &mut rng), motions, ..Default::default() };
    let result = run(&s, &obs, &links);
    // The wrong one first, with a |w| far beyond chance; any other only where its own noise is an outlier.
    let first = result.rejected_motions[0];
    assert!(first.index == wrong && first.round == 0 && first.w > 10.0, "{:?}", result.rejected_motions);
    let others = &result.rejected_motions[1..];
    assert!(others.iter().all(|r| largest_noise(&s, &obs.motions[r.index]) > 3.0 && r.w < 5.0), "{others:?}");
    let near = max_in(&s, &result, 25.0, 35.0);
    assert!(near < 0.05, "{near}");
}

#[test]
fn broken_motions_are_skipped_and_named() {
    let s = scene(30.0, 10.0, None, drift_and_island, 0.02);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(33);
    let mut motions = motions(&s, 5, &mut rng);
    motions[1].std[2] = 0.0;
    motions[2].start = 500.0;
    motions[2].end = 501.0;
    let obs = ObservationSetV1 { poles: poles(&s, 20, 0.03, 0.0, &mut rng), motions, ..Default::default() };
    let result = run(&s, &obs, &[]);
    let named: Vec<_> = result.skipped_motions.iter().map(|e| (e.index, e.field)).collect();
    assert_eq!(named, [(1, "std"), (2, "start/end")]);
}
