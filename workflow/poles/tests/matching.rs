//! Matching against the cadastre: a junction group with a common DG offset is matched pole by pole, a pole
//! missing from the cadastre is left unmatched (never forced onto a neighbour), an ambiguous single pole is
//! not matched, one pole seen in consecutive frames keeps its track, and the gate widens with the cadastre
//! object's accuracy.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use plumbline_campaign::manifest::PoleClass;
use plumbline_campaign::{CadastreFeature, CadastreFeatureId};
use plumbline_poles::{
    DetectConfig, Detection, FrameDetections, MatchConfig, MatchInput, UnmatchedReason, ViewSector, match_frames,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn feature(fid: u64, e: f64, n: f64) -> CadastreFeature {
    CadastreFeature {
        id: CadastreFeatureId { layer: 0, fid, part: 0 },
        class: PoleClass::Sign,
        easting: e,
        northing: n,
        accuracy_m: 0.07,
        diameter_m: Some(0.16),
    }
}

fn detection(centre: [f64; 2]) -> Detection {
    Detection {
        centre,
        covariance: [[0.03f64.powi(2), 0.0], [0.0, 0.03f64.powi(2)]],
        diameter_m: 0.16,
        diameter_sigma_m: 0.03,
        height_extent_m: [0.0, 2.7],
        ground_height_m: 0.0,
        points: 300,
        range_m: 5.0,
        lean: 0.0,
        slices: 6,
        reliable: true,
    }
}

fn frame(k: usize, dets: Vec<Detection>, dg_sigma_m: f64) -> MatchInput {
    let view = ViewSector {
        origin: [0.0, 0.0],
        from_rad: -1.2,
        width_rad: 2.4,
        max_range_m: DetectConfig::default().max_range_m,
    };
    MatchInput {
        frame: format!("f{k}"),
        time: k as f64,
        dg_sigma_m,
        detections: FrameDetections { ground_height_m: 0.0, view, detections: dets },
    }
}

/// A junction: five poles within 4 m; one more real pole (index 5) is missing from the cadastre.
const POLES: [[f64; 2]; 6] = [[5.0, 0.0], [5.5, 1.5], [6.5, -1.2], [7.5, 0.8], [8.0, 2.6], [6.0, 2.9]];

#[test]
fn a_junction_group_matches_pole_by_pole_and_never_forces_the_missing_one() {
    for seed in 0..20u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let cadastre: Vec<CadastreFeature> =
            POLES[..5].iter().enumerate().map(|(i, p)| feature(i as u64 + 1, p[0], p[1])).collect();
        // The DG error: up to 1.5 m, the same for all detections of the frames; the last cadastre pole
        // (index 4) is not detected.
        let offset = [rng.random_range(-1.5..1.5), rng.random_range(-1.5..1.5)];
        let frames: Vec<MatchInput> = (0..3)
            .map(|k| {
                let dets = [0usize, 1, 2, 3, 5]
                    .iter()
                    .map(|&i| {
                        let noise = [rng.random_range(-0.04..0.04), rng.random_range(-0.04..0.04)];
                        detection([POLES[i][0] - offset[0] + noise[0], POLES[i][1] - offset[1] + noise[1]])
                    })
                    .collect();
                frame(k, dets, 0.6)
            })
            .collect();
        for (k, m) in match_frames(&frames, &cadastre, &MatchConfig::default()).iter().enumerate() {
            let t = m.offset.expect("offset");
            assert!((t[0] - offset[0]).hypot(t[1] - offset[1]) < 0.1, "seed {seed} frame {k}: {t:?} vs {offset:?}");
            let pairs: Vec<(usize, usize)> = m.matches.iter().map(|x| (x.detection, x.cadastre)).collect();
            assert_eq!(pairs, [(0, 0), (1, 1), (2, 2), (3, 3)], "seed {seed} frame {k}");
            assert_eq!(m.unmatched.len(), 1, "seed {seed} frame {k}: {:?}", m.unmatched);
            assert_eq!(m.unmatched[0].detection, 4);
            assert_eq!(m.unseen, [4], "seed {seed} frame {k}");
        }
    }
}

#[test]
fn a_lone_pole_with_two_cadastre_candidates_in_the_gate_is_not_matched() {
    let cadastre = vec![feature(1, 5.0, 0.0), feature(2, 5.0, 1.6)];
    let frames = vec![frame(0, vec![detection([5.0, 0.9])], 0.8)];
    let m = &match_frames(&frames, &cadastre, &MatchConfig::default())[0];
    assert!(m.matches.is_empty() && m.offset.is_none(), "{m:?}");
    assert_eq!(m.unmatched[0].reason, UnmatchedReason::AmbiguousOffset);
    // With a tight DG gate only one candidate remains, and it is matched.
    let frames = vec![frame(0, vec![detection([5.0, 0.2])], 0.1)];
    let m = &match_frames(&frames, &cadastre, &MatchConfig::default())[0];
    assert_eq!(m.matches.len(), 1, "{m:?}");
    assert_eq!(m.matches[0].cadastre, 0);
    // Nothing in the gate: reported, not forced.
    let frames = vec![frame(0, vec![detection([9.0, -4.0])], 0.3)];
    let m = &match_frames(&frames, &cadastre, &MatchConfig::default())[0];
    assert_eq!(m.unmatched[0].reason, UnmatchedReason::NoCandidate);
}

#[test]
fn a_pole_keeps_its_track_over_consecutive_frames() {
    let cadastre = vec![feature(1, 5.0, 0.0), feature(2, 9.0, 3.0)];
    let frames: Vec<MatchInput> = (0..4)
        .map(|k| {
            let dets = vec![detection([5.2 + 0.01 * k as f64, 0.3]), detection([9.2, 3.3 - 0.01 * k as f64])];
            frame(k, dets, 0.5)
        })
        .collect();
    let matched = match_frames(&frames, &cadastre, &MatchConfig::default());
    let tracks: Vec<Vec<usize>> = matched.iter().map(|m| m.matches.iter().map(|x| x.track).collect()).collect();
    assert!(tracks.iter().all(|t| t == &tracks[0]) && tracks[0].len() == 2, "{tracks:?}");
    assert_ne!(tracks[0][0], tracks[0][1]);
}

#[test]
fn the_gate_widens_with_the_cadastre_objects_accuracy() {
    // A lone pole 1 m from where a tight DG trajectory puts it: outside the DG gate for a pole surveyed to
    // ±7 cm, inside it for one whose position the cadastre gives to ±0.5 m.
    let frames = vec![frame(0, vec![detection([5.0, 1.0])], 0.1)];
    let m = &match_frames(&frames, &[feature(1, 5.0, 0.0)], &MatchConfig::default())[0];
    assert_eq!(m.unmatched[0].reason, UnmatchedReason::NoCandidate, "{m:?}");
    let rough = CadastreFeature { accuracy_m: 0.5, ..feature(1, 5.0, 0.0) };
    let m = &match_frames(&frames, &[rough], &MatchConfig::default())[0];
    assert_eq!(m.matches.len(), 1, "{m:?}");
}
