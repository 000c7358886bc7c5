//! The driver on an analytic scene: pairing, per-image diagnostics for bad input, and tie rays that meet
//! at the true ground point when cast from the true poses; the image-derived motion across a DG jump.

use plumbline_geo::dg::intersect_height;
use plumbline_geo::{Attitude, Trajectory, TrajectoryRecord, ValidationLimits, Vec3};
use plumbline_imaging::GrayImage;
use plumbline_navigation::{ConsistencyConfig, ImageMotion, check_consistency};

use super::*;
use crate::mm::testing::{Ground, rig, scene_panorama, true_pose};
use crate::mm::{FallbackReason, MmConfig, Panorama, TransformSource};
use crate::output::DiscardReason;

#[test]
fn pairs_neighbours_reports_bad_and_lonely_images_and_writes_ties_consistent_with_the_truth() {
    let ground = Ground::markings(21, [6.0, 0.0], 16.0);
    let rig = rig(true);
    let dg = [0.9, -0.6, 0.05];
    let places = [([0.0, 0.0], 1.5), ([5.0, 0.1], 1.55), ([10.0, 0.2], 1.55), ([60.0, 0.0], 1.6)];
    let mut panoramas: Vec<Panorama> = places
        .iter()
        .enumerate()
        .map(|(i, (at, heading))| {
            let mut p = scene_panorama(&format!("p{i}"), &ground, &rig, *at, *heading, dg);
            p.time = 100.0 + i as f64;
            p
        })
        .collect();
    let mut broken = panoramas[1].clone();
    (broken.id, broken.time, broken.image) = ("broken".into(), 101.5, GrayImage::filled(100, 50, 0.0));
    panoramas.push(broken);
    // Listed out of time order on purpose: the driver sorts.
    panoramas.reverse();
    let config =
        PipelineConfig { mm: MmConfig { half_extent: 7.5, ..MmConfig::default() }, ..PipelineConfig::default() };
    let prepared = prepare_panoramas(&panoramas, &rig, &config.mm);
    let run = register_tile(TileId { col: 0, row: 0 }, &prepared, &rig, &AerialReference::Frames(Vec::new()), &config);
    let result = run.result.into_latest();
    let ids: Vec<&str> = result.images.iter().map(|d| d.image.as_str()).collect();
    assert_eq!(ids, ["p0", "p1", "broken", "p2", "p3"]);
    let by_id = |id: &str| result.images.iter().find(|d| d.image == id).unwrap();
    assert!(matches!(&by_id("broken").discarded, Some(DiscardReason::Failed { step, .. }) if step == "ortho/features"));
    assert!(matches!(by_id("p3").discarded, Some(DiscardReason::NoNeighbour { nearest_m: Some(d) }) if d > 49.0));
    // p2's next panorama is 50 m away: it pairs backwards, across the broken one, which cannot serve.
    assert_eq!(by_id("p0").neighbour.as_deref(), Some("p1"));
    assert_eq!(by_id("p2").neighbour.as_deref(), Some("broken"));
    assert!(
        matches!(&by_id("p2").discarded, Some(DiscardReason::Failed { step, .. }) if step.starts_with("neighbour"))
    );
    // p1 skips the broken one (same place: no baseline) and pairs with p0. No aerial frames: no overlap.
    assert_eq!(by_id("p1").neighbour.as_deref(), Some("p0"));
    let p0 = by_id("p0");
    assert!(matches!(p0.discarded, Some(DiscardReason::Aerial(crate::aerial::AerialDiscard::NoOverlap))), "{p0:?}");
    assert!(p0.corners.triangulated >= 20, "{:?}", p0.corners);
    assert_eq!(result.summary.images_matched, 0);
    // MM-only ties: two rays each. The first ray cast from A's TRUE pose hits the true ground point; the
    // second, cast from B's TRUE pose, must point at that same point to within its stated σ.
    let ties: Vec<_> = result.ties.iter().filter(|t| t.id.0.starts_with("p0:")).collect();
    assert_eq!(ties.len(), p0.corners.triangulated);
    let cams = [0, 1].map(|i| rig.mount.camera_pose(&true_pose(&ground, places[i].0, places[i].1)));
    let mut within = 0;
    for t in &ties {
        assert_eq!((t.rays[0].time, t.rays[1].time), (100.0, 101.0));
        let [a, b] = [0, 1].map(|k| {
            let d = Vec3::new(t.rays[k].direction[0], t.rays[k].direction[1], t.rays[k].direction[2]);
            cams[k].rotation.apply(&d)
        });
        let g = intersect_height(&cams[0].translation, &a, ground.height).unwrap();
        let angle = (g - cams[1].translation).v.angle(&b.v);
        within += usize::from(angle <= 3.0 * t.rays[1].sigma);
    }
    assert!(within * 10 >= ties.len() * 9, "{within} of {} within 3σ", ties.len());
}

/// A DG jump between two panoramas: the feature transformation disagrees with the DG poses (and the
/// orientation fallback serves the corners), yet the image-derived motion reports the TRUE displacement,
/// and the consistency check of Cazzaniga et al. 2007 §4.1 flags exactly the pairs across the jump.
#[test]
fn a_dg_jump_leaves_the_image_motion_true_and_the_consistency_check_flags_it() {
    let ground = Ground::markings(23, [5.0, 0.0], 14.0);
    let rig = rig(true);
    let common = [0.9, -0.6, 0.05];
    let jumped = [0.9, -0.6 + 0.8, 0.05];
    let places = [([0.0, 0.0], 1.55), ([5.0, 0.1], 1.55), ([10.0, 0.2], 1.57)];
    let panoramas: Vec<Panorama> = places
        .iter()
        .enumerate()
        .map(|(i, (at, heading))| {
            let mut p =
                scene_panorama(&format!("p{i}"), &ground, &rig, *at, *heading, if i < 2 { common } else { jumped });
            p.time = 100.0 + i as f64;
            p
        })
        .collect();
    let config =
        PipelineConfig { mm: MmConfig { half_extent: 7.5, ..MmConfig::default() }, ..PipelineConfig::default() };
    let prepared = prepare_panoramas(&panoramas, &rig, &config.mm);
    let run = register_tile(TileId { col: 0, row: 0 }, &prepared, &rig, &AerialReference::Frames(Vec::new()), &config);
    let result = run.result.into_latest();
    assert!(matches!(result.images[0].transform, Some(TransformSource::Kaze { .. })), "{:?}", result.images[0]);
    let jump = &result.images[1];
    assert!(
        matches!(jump.transform, Some(TransformSource::Orientation(FallbackReason::Disagrees { disagreement_m }))
            if (disagreement_m - 0.8).abs() < 0.05),
        "{:?}",
        jump.transform
    );
    let motions: Vec<ImageMotion> = result.images.iter().map(|d| d.motion.unwrap()).collect();
    // p2 pairs backwards with p1: the same pair, reported in time order.
    let truth = [[5.0, 0.1, 0.0], [5.0, 0.1, 0.02], [5.0, 0.1, 0.02]];
    for (m, want) in motions.iter().zip(truth) {
        let error = [m.displacement[0] - want[0], m.displacement[1] - want[1], m.heading_change - want[2]];
        assert!((0..3).all(|k| error[k].abs() <= 3.0 * m.std[k]), "{m:?}: error {error:?}");
        assert!(m.std[0] <= 0.03 && m.std[2] <= 3e-3, "{m:?}");
    }
    assert_eq!([motions[1].start, motions[1].end, motions[2].start, motions[2].end], [101.0, 102.0, 101.0, 102.0]);
    // The DG trajectory through the panoramas' poses: the check flags the pairs across the jump only.
    let records = panoramas
        .iter()
        .map(|p| TrajectoryRecord {
            time: p.time,
            position: p.pose.translation,
            attitude: Attitude::from_rotation(&p.pose.rotation),
            std: None,
        })
        .collect();
    let dg = Trajectory::new(records, &ValidationLimits::default()).unwrap();
    let report = check_consistency(&dg, &motions, &ConsistencyConfig::default()).unwrap();
    assert!(report.skipped.is_empty(), "{:?}", report.skipped);
    let flagged: Vec<usize> = report.flags.iter().map(|f| f.pair).collect();
    assert_eq!(flagged, [1, 2]);
    // Image − DG: the jump, reversed (DG moved 0.8 m north too far).
    let d = report.flags[0].discrepancy;
    assert!(d[0].abs() < 0.03 && (d[1] + 0.8).abs() < 0.03, "{d:?}");
}

/// A street of panoramas 5 m apart going east, all owned: DG error `errors[i]`, paired with `neighbours[i]`
/// (image motion of the true displacement, plus `motion_error` on the pair of the panorama it names), aerial
/// offsets −error (+ `blunder` on the panorama it names) on every one but the `unmatched`.
struct Street<'a> {
    errors: &'a [[f64; 2]],
    neighbours: &'a [usize],
    unmatched: &'a [usize],
    blunder: (usize, [f64; 2]),
    motion_error: (usize, [f64; 2]),
}

fn outcomes(street: &Street<'_>) -> (Vec<PreparedPanorama>, Vec<pair::PairOutcome>) {
    let Street { errors, neighbours, unmatched, blunder, motion_error } = *street;
    use plumbline_adjustment::{AerialPoint, TiePoint, TiePointId, TieRay};
    use plumbline_geo::{MapFromBody, Point3, Pose, Rotation};

    use crate::output::{AerialOffset, CornerCounts};
    let truth = |i: usize| [5.0 * i as f64, 0.2 * i as f64];
    let prepared: Vec<PreparedPanorama> = (0..errors.len())
        .map(|i| {
            let at = Point3::new(truth(i)[0] + errors[i][0], truth(i)[1] + errors[i][1], 50.0);
            let pose: MapFromBody = Pose::new(Rotation::identity(), at);
            PreparedPanorama::unprepared(PanoramaInfo {
                id: format!("p{i}"),
                time: 10.0 + i as f64,
                pose,
                position_sigma: 0.5,
                velocity: None,
                owned: true,
            })
        })
        .collect();
    let outcomes = (0..errors.len())
        .map(|i| {
            let j: usize = neighbours[i];
            let (a, b) = (i.min(j), i.max(j));
            let wrong = if motion_error.0 == i { motion_error.1 } else { [0.0; 2] };
            let displacement = [0, 1].map(|c| truth(b)[c] - truth(a)[c] + wrong[c]);
            let motion = ImageMotion {
                start: 10.0 + a as f64,
                end: 10.0 + b as f64,
                displacement,
                heading_change: 0.0,
                std: [0.01, 0.01, 1e-3],
            };
            let matched = !unmatched.contains(&i);
            let wrong = if i == blunder.0 { blunder.1 } else { [0.0; 2] };
            let offset = [wrong[0] - errors[i][0], wrong[1] - errors[i][1]];
            let ray = |t: f64| TieRay::new(t, [0.0, 0.6, -0.8], 1e-3);
            let ties = (0..3)
                .map(|k| TiePoint {
                    id: TiePointId(format!("p{i}:{k:04}")),
                    rays: vec![ray(10.0 + i as f64), ray(10.0 + j as f64)],
                    aerial: matched.then_some(AerialPoint {
                        position: [0.0; 3],
                        covariance: [[1e-4, 0.0, 0.0], [0.0, 1e-4, 0.0], [0.0, 0.0, 1e-3]],
                    }),
                })
                .collect();
            let diagnostic = ImageDiagnostic {
                image: format!("p{i}"),
                time: 10.0 + i as f64,
                neighbour: Some(format!("p{j}")),
                transform: None,
                motion: Some(motion),
                motion_contradicted: false,
                corners: CornerCounts::default(),
                aerial_images: Vec::new(),
                aerial_points: if matched { 3 } else { 0 },
                dropped_ties: 0,
                aerial_frames: Vec::new(),
                aerial_offset: matched.then_some(AerialOffset { offset, std: [0.02, 0.02], points: 3 }),
                cross_check: None,
                discarded: (!matched).then_some(DiscardReason::TooFewMmPoints { points: 4, needed: 10 }),
                strokes: Vec::new(),
            };
            pair::PairOutcome { diagnostic, ties, timings: StageTimings::default(), trace: Vec::new() }
        })
        .collect();
    (prepared, outcomes)
}

/// The check on a tile's outcomes: a DG jump between p3 and p4 that the (backward-paired) image motion
/// measures is not flagged; a wrong registration on top of it is, and only it loses its aerial points.
#[test]
fn the_cross_check_flags_a_wrong_registration_across_a_dg_jump_through_backward_pairs() {
    let mut errors = [[0.5, -0.3], [0.52, -0.31], [0.55, -0.3], [0.6, -0.28], [0.6, -0.28]];
    errors[4][1] += 0.8;
    let config = PipelineConfig::default();
    let check = |blunder: [f64; 2]| {
        let street = Street {
            errors: &errors,
            neighbours: &[1, 2, 1, 2, 3],
            unmatched: &[2],
            blunder: (4, blunder),
            motion_error: (0, [0.0; 2]),
        };
        let (prepared, mut outcomes) = outcomes(&street);
        let order: Vec<&PreparedPanorama> = prepared.iter().collect();
        cross_check(&order, &[0, 1, 2, 3, 4], &mut outcomes, &config);
        outcomes
    };
    let kept = check([0.0, 0.0]);
    assert!(kept.iter().all(|o| !matches!(o.diagnostic.discarded, Some(DiscardReason::Inconsistent { .. }))));
    let compared = |o: &pair::PairOutcome| match &o.diagnostic.cross_check {
        Some(CrossCheck::Compared { agreeing, disagreeing }) => (agreeing.clone(), disagreeing.len()),
        other => panic!("{other:?}"),
    };
    assert_eq!(compared(&kept[4]), (vec!["p0".to_owned(), "p1".into(), "p3".into()], 0));
    assert_eq!(kept[2].diagnostic.cross_check, None);
    // 1.5 m off (a repainted dash) on top of the jump: p4 is flagged, its ties keep their rays only.
    let flagged = check([-1.46, -0.55]);
    let p4 = &flagged[4];
    let Some(DiscardReason::Inconsistent { disagreements, agreeing: 0 }) = &p4.diagnostic.discarded else {
        panic!("{:?}", p4.diagnostic.discarded)
    };
    assert_eq!(disagreements.iter().map(|d| d.partner.as_str()).collect::<Vec<_>>(), ["p0", "p1", "p3"]);
    assert!(disagreements.iter().all(|d| (d.residual_m - 1.46f64.hypot(0.55)).abs() < 1e-6), "{disagreements:?}");
    assert_eq!(p4.diagnostic.aerial_points, 0);
    assert!(p4.ties.len() == 3 && p4.ties.iter().all(|t| t.aerial.is_none() && t.rays.len() == 2));
    assert!(flagged[..4].iter().all(|o| o.diagnostic.discarded.is_none() || o.diagnostic.aerial_points == 0));
    assert_eq!(compared(&flagged[0]), (vec!["p1".to_owned(), "p3".into()], 0));
    let diagnostics: Vec<ImageDiagnostic> = flagged.iter().map(|o| o.diagnostic.clone()).collect();
    let ties: Vec<_> = flagged.iter().flat_map(|o| o.ties.clone()).collect();
    let summary = TileSummary::of(&diagnostics, &ties);
    assert_eq!((summary.images_matched, summary.discarded.get("inconsistent")), (3, Some(&1)));
    assert_eq!(summary.ties_with_aerial, 9);
    assert!(p4.diagnostic.discarded.as_ref().unwrap().to_string().contains("inconsistent with p0 (residual 1.56 m"));
    assert!(flagged.iter().all(|o| !o.diagnostic.motion_contradicted));
}

/// A wrong image motion between two groups of three matched panoramas (p3 paired backwards with p2, 0.6 m
/// off): no panorama is flagged, the motion is marked contradicted and the groups are compared apart.
#[test]
fn the_cross_check_marks_a_wrong_image_motion_and_flags_nobody() {
    let errors: Vec<[f64; 2]> = (0..6).map(|i| [0.3 + 0.05 * i as f64, -0.2]).collect();
    let street = Street {
        errors: &errors,
        neighbours: &[1, 2, 1, 2, 3, 4],
        unmatched: &[],
        blunder: (9, [0.0; 2]),
        motion_error: (3, [0.6, 0.0]),
    };
    let (prepared, mut outcomes) = outcomes(&street);
    let order: Vec<&PreparedPanorama> = prepared.iter().collect();
    cross_check(&order, &[0, 1, 2, 3, 4, 5], &mut outcomes, &PipelineConfig::default());
    let contradicted: Vec<bool> = outcomes.iter().map(|o| o.diagnostic.motion_contradicted).collect();
    assert_eq!(contradicted, [false, false, false, true, false, false]);
    assert!(outcomes.iter().all(|o| o.diagnostic.discarded.is_none()));
    let agreeing = |o: &pair::PairOutcome| match &o.diagnostic.cross_check {
        Some(CrossCheck::Compared { agreeing, disagreeing }) if disagreeing.is_empty() => agreeing.join(" "),
        other => panic!("{other:?}"),
    };
    assert_eq!((agreeing(&outcomes[2]), agreeing(&outcomes[3])), ("p0 p1".to_owned(), "p4 p5".to_owned()));
}

/// The aerial offset: the median resists two blunders among eleven points; σ is the MAD's / √n, the prior
/// point σ / √n or the points' own σ, whichever is largest; no points, no offset.
#[test]
fn the_aerial_offset_is_the_robust_median_with_a_floored_sigma() {
    let mut d: Vec<[f64; 2]> =
        (0..11).map(|k| [0.3 + 0.01 * (k as f64 - 5.0), -0.2 - 0.02 * (k as f64 - 5.0)]).collect();
    (d[0], d[10]) = ([1.8, 0.9], [-1.0, -2.0]);
    let own = vec![[0.001, 0.001]; 11];
    let o = pair::offset_of(&d, &own, 0.0).unwrap();
    assert!((o.offset[0] - 0.3).abs() < 1e-12 && (o.offset[1] + 0.2).abs() < 1e-12, "{o:?}");
    // MAD of east: the sorted |deviations| 0, .01, .01, …, .04, .04, 1.3, 1.5 → 0.03.
    assert!((o.std[0] - 1.4826 * 0.03 / 11f64.sqrt()).abs() < 1e-9, "{o:?}");
    assert!((o.std[1] - 1.4826 * 0.06 / 11f64.sqrt()).abs() < 1e-9, "{o:?}");
    assert_eq!(o.points, 11);
    let floored = pair::offset_of(&d, &[[0.05, 0.05]; 11], 0.0).unwrap();
    assert_eq!(floored.std, [0.05, 0.05]);
    // Two points that happen to agree: the prior, not their MAD of zero.
    let two = pair::offset_of(&[[0.3, -0.2], [0.3, -0.2]], &own[..2], 0.06).unwrap();
    assert_eq!(two.std, [0.06 / 2f64.sqrt(); 2]);
    assert_eq!(pair::offset_of(&[], &[], 0.06), None);
}
