//! Tie points and GNSS: a street driven out and back where only the outbound pass has control, the return
//! pass corrected through tie points seen from both passes; aerial-triangulated ties and GNSS as control;
//! aerial heights sharing their frame set's bias.
#![allow(clippy::unwrap_used)]

use faer::Par;
use nalgebra::{Vector3, Vector6};
use plumbline_adjustment::{AdjustmentConfig, AdjustmentInput, AerialFrameSet, AerialPoint, ObservationSetV1, adjust};
use plumbline_fixtures::adjustment::*;
use rand::SeedableRng;

/// Outbound 0–60 s with a smooth drift; the return pass (60–120 s) picks up a different, larger offset.
fn two_pass_correction(t: f64) -> Vector6<f64> {
    let base = Vector6::new(0.2 * (t / 20.0).sin(), -0.15, 0.03, 0.0, 0.0, 2e-4);
    if t > 60.0 { base + Vector6::new(0.4, 0.3, 0.0, 0.0, 0.0, 0.0) * ((t - 60.0) / 5.0).min(1.0) } else { base }
}

/// Ground points 7 m beside the outbound lane every 20 m, seen from both passes.
fn ties(s: &Scene, rng: &mut impl rand::Rng) -> Vec<(plumbline_adjustment::TiePoint, Vector3<f64>)> {
    (1..29)
        .map(|j| {
            let i_out = j * 20;
            let tr = &s.truth[i_out];
            let x = tr.position.p + tr.attitude.to_rotation().matrix() * Vector3::new(6.0, -7.0, 2.5);
            // The return pass passes the same place at 120 − t.
            let i_back = 1200 - i_out - 6;
            (tie(s, &format!("t{j}"), x, &[i_out, i_out + 3, i_back, i_back + 3], 5e-4, rng), x)
        })
        .collect()
}

#[test]
fn the_return_pass_is_corrected_through_tie_points_to_the_controlled_pass() {
    let s = scene(120.0, 10.0, Some(60.0), two_pass_correction, 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let outbound: Vec<_> = poles(&s, 30, 0.01, 0.01, &mut rng).into_iter().filter(|p| p.time < 58.0).collect();
    let (tie_points, truth_points): (Vec<_>, Vec<_>) = ties(&s, &mut rng).into_iter().unzip();
    let with_ties = ObservationSetV1 { poles: outbound.clone(), ties: tie_points, ..Default::default() };
    let without = ObservationSetV1 { poles: outbound, ..Default::default() };
    let m = mount();
    // The scene's turnaround moves the vehicle 3 m sideways in one step (a synthetic U-turn), which the search
    // for jumps in the DG's own motion rightly flags; off here, so only the ties carry the return pass.
    let config = AdjustmentConfig { kinematic_jumps: None, ..AdjustmentConfig::default() };
    let run = |obs: &ObservationSetV1| {
        let input = AdjustmentInput { trajectory: &s.dg, observations: obs, mount: &m, weak_links: &[] };
        let result = adjust(&input, &config, Par::Seq).unwrap();
        (horizontal_errors(&result.apply(&s.dg).unwrap(), &s.truth), result)
    };
    let (tied, result) = run(&with_ties);
    let (untied, _) = run(&without);
    let back = 660..1140;
    eprintln!("return pass rms: tied {:.4}, untied {:.4}", rms(&tied[back.clone()]), rms(&untied[back.clone()]));
    assert!(result.rejected.is_empty(), "{:?}", result.rejected);
    assert!(rms(&untied[back.clone()]) > 0.3, "without ties the return pass keeps its offset");
    assert!(rms(&tied[back.clone()]) < 0.04, "rms {}", rms(&tied[back.clone()]));
    assert!(max(&tied[back]) < 0.1);
    // The correction's 0.5 m ramp over 5 s at the uncontrolled turnaround is 5.6σ of the DG random walk:
    // snooping widens that link as a jump (and nothing else).
    assert_eq!(result.jumps.len(), 1, "{:?}", result.jumps);
    assert!(result.jumps[0].start >= 55.0 && result.jumps[0].end <= 65.0, "{:?}", result.jumps);
    // The tie points themselves land on the truth; the one seen across the widened link (t28, at 56 s and
    // 63 s) rests on two short-base rays at each end and lands within 0.15 m.
    assert_eq!(result.points.len(), 28);
    let errors: Vec<f64> =
        result.points.iter().zip(&truth_points).map(|(p, x)| (Vector3::from(p.position) - x).norm()).collect();
    assert!(errors[..27].iter().all(|e| *e < 0.1), "{errors:?}");
    assert!(errors[27] < 0.15, "{errors:?}");
}

#[test]
fn aerial_tie_points_and_gnss_control_all_three_coordinates() {
    let s = scene(60.0, 10.0, None, drift_and_jump(1e9), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
    let (sh, sv) = (0.03, 0.06);
    let tie_points: Vec<_> = (1..15)
        .map(|j| {
            let i = j * 40;
            let tr = &s.truth[i];
            let x = tr.position.p + tr.attitude.to_rotation().matrix() * Vector3::new(8.0, 4.0, 2.5);
            let mut t = tie(&s, &format!("a{j}"), x, &[i - 5, i, i + 5], 5e-4, &mut rng);
            // Aerial triangulation with 3 cm horizontal and 6 cm vertical noise, as its covariance says.
            let noisy = x + Vector3::new(gauss(&mut rng) * sh, gauss(&mut rng) * sh, gauss(&mut rng) * sv);
            let covariance = [[sh * sh, 0.0, 0.0], [0.0, sh * sh, 0.0], [0.0, 0.0, sv * sv]];
            t.aerial = Some(AerialPoint { position: noisy.into(), covariance });
            t
        })
        .collect();
    let obs =
        ObservationSetV1 { ties: tie_points, gnss: gnss(&s, &[100, 300, 500], 0.02, &mut rng), ..Default::default() };
    let m = mount();
    let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: &[] };
    let result = adjust(&input, &AdjustmentConfig::default(), Par::Seq).unwrap();
    let corrected = result.apply(&s.dg).unwrap();
    let error_3d = |t: &plumbline_geo::Trajectory| -> Vec<f64> {
        t.records().iter().zip(&s.truth).map(|(a, b)| (a.position.p - b.position.p).norm()).collect()
    };
    let (before, after) = (error_3d(&s.dg), error_3d(&corrected));
    eprintln!("3D rms before {:.3}, after {:.4}", rms(&before), rms(&after[35..566]));
    assert!(rms(&before) > 0.15);
    assert!(rms(&after[35..566]) < 0.06, "rms {}", rms(&after[35..566]));
    let horizontal = horizontal_errors(&corrected, &s.truth);
    assert!(rms(&horizontal[35..566]) < 0.04, "rms {}", rms(&horizontal[35..566]));
    assert!(result.skipped.is_empty() && result.rejected.is_empty(), "{:?} {:?}", result.skipped, result.rejected);
}

#[test]
fn a_tie_point_left_undetermined_by_snooping_is_rejected_whole() {
    let s = scene(60.0, 10.0, None, drift_and_jump(1e9), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let poles = poles(&s, 30, 0.02, 0.02, &mut rng);
    // Two rays, one 20 mrad off, and aerial coordinates 5 m off: snooping rejects the aerial coordinates, then
    // one of the two inconsistent rays; a single ray cannot fix the point's three coordinates.
    let tr = &s.truth[300];
    let x = tr.position.p + tr.attitude.to_rotation().matrix() * Vector3::new(4.0, 8.0, 2.5);
    let mut bad = tie(&s, "lonely", x, &[300, 340], 5e-4, &mut rng);
    let d = Vector3::from(bad.rays[1].direction);
    let turned = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), 0.02) * d;
    bad.rays[1].direction = turned.normalize().into();
    let (sh, sv) = (0.03f64, 0.06f64);
    let covariance = [[sh * sh, 0.0, 0.0], [0.0, sh * sh, 0.0], [0.0, 0.0, sv * sv]];
    bad.aerial = Some(AerialPoint { position: (x + Vector3::new(3.0, -4.0, 0.0)).into(), covariance });
    let obs = ObservationSetV1 { poles, ties: vec![bad], ..Default::default() };
    let m = mount();
    let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: &[] };
    let result = adjust(&input, &AdjustmentConfig::default(), Par::Seq).unwrap();
    let tie_items: Vec<_> = result
        .rejected
        .iter()
        .filter(|r| !matches!(r.item, plumbline_adjustment::ObservationRef::Pole { .. }))
        .map(|r| r.item.clone())
        .collect();
    eprintln!("rejected {tie_items:?}");
    let whole = plumbline_adjustment::ObservationRef::Tie {
        index: 0,
        point: plumbline_adjustment::TiePointId("lonely".into()),
    };
    assert_eq!(tie_items.last(), Some(&whole), "{:?}", result.rejected);
    let after = horizontal_errors(&result.apply(&s.dg).unwrap(), &s.truth);
    assert!(rms(&after[15..586]) < 0.03, "rms {}", rms(&after[15..586]));
}

/// Aerial tie points every 1 s beside a 60 s drive, triangulated from two frame sets whose orientation errors
/// shift every height by +0.6 m (first half) and −0.4 m (second half); each height's own σ 0.5 m, its noise
/// 5 cm; poles for the horizontal.
fn biased_aerial_heights(s: &Scene, rng: &mut impl rand::Rng) -> ObservationSetV1 {
    let (sh, sv) = (0.03, 0.5);
    let mut sets = vec![
        AerialFrameSet { frames: vec!["f1".into(), "f2".into()], ties: Vec::new() },
        AerialFrameSet { frames: vec!["f2".into(), "f3".into()], ties: Vec::new() },
    ];
    let ties = (1..59)
        .map(|j| {
            let i = j * 10;
            let tr = &s.truth[i];
            let x = tr.position.p + tr.attitude.to_rotation().matrix() * Vector3::new(8.0, 4.0, 2.5);
            let mut t = tie(s, &format!("h{j}"), x, &[i - 3, i + 3], 5e-4, rng);
            let (set, bias) = if j < 30 { (0, 0.6) } else { (1, -0.4) };
            let noise = Vector3::new(gauss(rng) * sh, gauss(rng) * sh, gauss(rng) * 0.05 + bias);
            let covariance = [[sh * sh, 0.0, 0.0], [0.0, sh * sh, 0.0], [0.0, 0.0, sv * sv]];
            t.aerial = Some(AerialPoint { position: (x + noise).into(), covariance });
            sets[set].ties.push(t.id.clone());
            t
        })
        .collect();
    ObservationSetV1 { ties, poles: poles(s, 30, 0.02, 0.02, rng), aerial_frame_sets: sets, ..Default::default() }
}

#[test]
fn a_height_bias_per_aerial_frame_set_keeps_the_shared_error_out_of_the_trajectory() {
    let s = scene(60.0, 10.0, None, drift_and_jump(1e9), 0.05);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
    let obs = biased_aerial_heights(&s, &mut rng);
    let m = mount();
    let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: &[] };
    let run = |config: &AdjustmentConfig| adjust(&input, config, Par::Seq).unwrap();
    // How far the adjustment moved the trajectory's height from the DG's (the DG's own height error is a
    // few centimetres of smooth drift; the aerial heights would say +0.6 m and −0.4 m).
    let pull = |r: &plumbline_adjustment::Adjustment| -> Vec<f64> {
        let corrected = r.apply(&s.dg).unwrap();
        corrected.records().iter().zip(s.dg.records()).map(|(a, b)| a.position.p.z - b.position.p.z).collect()
    };
    let with = run(&AdjustmentConfig::default());
    let without = run(&AdjustmentConfig { height_biases: None, ..AdjustmentConfig::default() });
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let halves = |v: &[f64]| (mean(&v[20..290]), mean(&v[310..580]));
    let (independent, shared) = (halves(&pull(&without)), halves(&pull(&with)));
    eprintln!("height pull by half: independent {independent:?}, with biases {shared:?}");
    eprintln!("biases {:?}", with.height_biases);
    // Independent, the 29 heights of a set pull the trajectory towards their common error.
    assert!(independent.0 > 0.07 && independent.1 < -0.03, "independent heights: {independent:?}");
    // With one bias per set the trajectory keeps the DG's height and the biases come out.
    assert!(shared.0.abs() < 0.02 && shared.1.abs() < 0.02, "with biases: {shared:?}");
    assert_eq!(with.height_biases.len(), 2);
    for (bias, truth) in with.height_biases.iter().zip([0.6, -0.4]) {
        assert_eq!(bias.points, 29);
        assert!((bias.prior_sigma - 0.5).abs() < 1e-9, "{bias:?}");
        assert!((bias.bias - truth).abs() < 3.0 * bias.sigma && bias.sigma < 0.15, "{bias:?} vs {truth}");
    }
    // Horizontal control is untouched by the height model.
    let horizontal = horizontal_errors(&with.apply(&s.dg).unwrap(), &s.truth);
    assert!(rms(&horizontal[20..580]) < 0.03, "rms {}", rms(&horizontal[20..580]));
}
