//! The driver on an analytic scene: pairing, per-image diagnostics for bad input, and tie rays that meet
//! at the true ground point when cast from the true poses.

use plumbline_geo::Vec3;
use plumbline_geo::dg::intersect_height;
use plumbline_imaging::GrayImage;

use super::*;
use crate::mm::MmConfig;
use crate::mm::testing::{Ground, rig, scene_panorama, true_pose};
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
    let run = register_tile(
        TileId { col: 0, row: 0 },
        &panoramas,
        &rig,
        &AerialReference::Frames(Vec::new()),
        &PipelineConfig { mm: MmConfig { half_extent: 7.5, ..MmConfig::default() }, ..PipelineConfig::default() },
    );
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
