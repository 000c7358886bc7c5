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
/// and the consistency check of paper 001 §4.1 flags exactly the pairs across the jump.
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
