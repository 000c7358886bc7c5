#![allow(clippy::unwrap_used)]
//! The consistency check of DG relative motion against image-derived motion (Cazzaniga et al. 2007 §4,
//! Jende et al. 2017 §3.3): a DG jump is flagged at exactly the pairs spanning its start and end; clean pairs pass
//! at the nominal rate.

use plumbline_fixtures::navigation;

use plumbline_geo::{Trajectory, TrajectoryRecord, ValidationLimits, Vec3};
use plumbline_navigation::{ConsistencyConfig, ImageMotion, NavError, check_consistency};
use plumbline_synth::motion::imu::ImuErrors;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const IMAGE_STD: [f64; 3] = [0.02, 0.02, 1e-3];

/// Pairs of consecutive panoramas every ~5 m of driving, measured from the truth with [`IMAGE_STD`] noise.
fn image_motions(truth: &[TrajectoryRecord], distance: &[f64], rng: &mut ChaCha8Rng) -> Vec<ImageMotion> {
    let mut shots = vec![0usize];
    for (i, d) in distance.iter().enumerate() {
        if d - distance[*shots.last().unwrap()] >= 5.0 {
            shots.push(i);
        }
    }
    shots
        .windows(2)
        .map(|w| {
            let (a, b) = (&truth[w[0]], &truth[w[1]]);
            let d = b.position - a.position;
            let turn = (b.attitude.heading - a.attitude.heading + std::f64::consts::PI)
                .rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            ImageMotion {
                start: a.time,
                end: b.time,
                displacement: [
                    d.x() + IMAGE_STD[0] * navigation::gauss(rng),
                    d.y() + IMAGE_STD[1] * navigation::gauss(rng),
                ],
                heading_change: turn + IMAGE_STD[2] * navigation::gauss(rng),
                std: IMAGE_STD,
            }
        })
        .collect()
}

#[test]
fn dg_jump_is_flagged_at_its_edges_only() {
    let (mut clean, mut false_flags) = (0usize, 0usize);
    for seed in [1, 2, 3] {
        let s = navigation::scenario(seed, &navigation::block_route(1), &ImuErrors::PERFECT, 100.0, 1.0);
        let truth = s.drive.trajectory.records();
        let distance: Vec<f64> = s.drive.kinematics.iter().map(|k| k.distance).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let motions = image_motions(truth, &distance, &mut rng);
        // The jump starts inside one pair and ends inside a later one (pairs are distance-triggered, so a jump
        // wholly inside one standstill pair would leave no trace in the relative motion).
        let mid = |m: &ImageMotion| 0.5 * (m.start + m.end);
        let (ja, jb) = (mid(&motions[motions.len() / 3]), mid(&motions[motions.len() / 3 + 4]));
        let jumped: Vec<TrajectoryRecord> = truth
            .iter()
            .map(|r| {
                let off = if r.time >= ja && r.time < jb { Vec3::new(0.0, 0.5, 0.0) } else { Vec3::zeros() };
                TrajectoryRecord { position: r.position + off, ..*r }
            })
            .collect();
        let dg = Trajectory::new(jumped, &ValidationLimits { max_speed: 1e4 }).unwrap();
        let report = check_consistency(&dg, &motions, &ConsistencyConfig::default()).unwrap();
        assert!(report.skipped.is_empty());
        let spans = |t: f64| move |m: &ImageMotion| m.start < t && m.end >= t;
        let edges: Vec<usize> =
            (0..motions.len()).filter(|&i| spans(ja)(&motions[i]) || spans(jb)(&motions[i])).collect();
        assert_eq!(edges.len(), 2);
        for e in &edges {
            let f = report.flags.iter().find(|f| f.pair == *e).expect("edge pair flagged");
            assert!((f.discrepancy[1].abs() - 0.5).abs() < 4.0 * 0.021, "north discrepancy {:?}", f.discrepancy);
            assert_eq!((f.link.start, f.link.end), (motions[*e].start, motions[*e].end));
        }
        clean += motions.len() - 2;
        false_flags += report.flags.iter().filter(|f| !edges.contains(&f.pair)).count();
    }
    // α = 0.001 over the clean pairs; 4 binomial σ + 1.
    let mean = clean as f64 * 0.001;
    assert!((false_flags as f64) <= mean + 4.0 * mean.sqrt() + 1.0, "{false_flags} false flags of {clean}");
}

#[test]
fn broken_pair_is_skipped_not_fatal() {
    let s = navigation::scenario(4, &navigation::block_route(1), &ImuErrors::PERFECT, 100.0, 1.0);
    let truth = s.drive.trajectory.records();
    let distance: Vec<f64> = s.drive.kinematics.iter().map(|k| k.distance).collect();
    let mut motions = image_motions(truth, &distance, &mut ChaCha8Rng::seed_from_u64(4));
    motions[3].std[1] = 0.0;
    motions[7].end = truth[truth.len() - 1].time + 10.0;
    let report = check_consistency(&s.drive.trajectory, &motions, &ConsistencyConfig::default()).unwrap();
    let skipped: Vec<usize> = report.skipped.iter().map(|(i, _)| *i).collect();
    assert_eq!(skipped, vec![3, 7]);
    assert!(matches!(report.skipped[0].1, NavError::Pair { index: 3, field: "std[north]", .. }));
    assert!(report.flags.len() <= 3, "clean truth: {} flags", report.flags.len());
}
