//! The whole pipeline on a junction of the synthetic `tiny` world: panoramas rendered with the true poses,
//! processed with the DG poses, registered against aerial frames (AT-reported orientations); tie points and
//! the image-derived motion between neighbours scored against the truth.

#![allow(clippy::unwrap_used)]

use plumbline_fixtures::registration::{AERIAL_GSD, Campaign, Profile, Spec, wrong};
use plumbline_geo::tiling::TileId;
use plumbline_registration::pipeline::prepare_panoramas;
use plumbline_registration::{PipelineConfig, TileResult, register_tile};
use plumbline_synth::world;

/// Panoramas every 5 m (the simulator's `district` spacing), 1024 × 512, around a junction.
fn spec(seed: u64) -> Spec {
    Spec {
        preset: world::Preset::Tiny,
        seed,
        profile: Profile::Mixed,
        length: 400.0,
        spacing: 5.0,
        width: 1024,
        window: Some(7),
        realism: plumbline_synth::render::Realism::of(plumbline_synth::render::RealismLevel::Ideal),
    }
}

#[test]
fn tiny_junction_registers_with_correct_ties() {
    let seed = std::env::var("MM_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    let campaign = Campaign::build(&spec(seed));
    let config = PipelineConfig::default();
    let prepared = prepare_panoramas(&campaign.panoramas, &campaign.rig, &config.mm);
    let run = register_tile(TileId { col: 0, row: 0 }, &prepared, &campaign.rig, &campaign.reference, &config);
    let result = run.result.clone().into_latest();
    let summary = &result.summary;
    eprintln!("seed {seed}: {summary:?}; {:?}", run.timings);
    // Every image has a diagnostic; every discarded one says why.
    assert_eq!(result.images.len(), campaign.panoramas.len());
    // Jende et al. (2017) reached 10–23 % of images at junction-rich areas; the target is ≥ 50 % where markings exist.
    assert!(summary.images_matched * 2 >= summary.images, "{summary:?}");
    // Correct: the aerial position within 2 aerial pixels of the true ground point, horizontally (two
    // nadir frames with a 1500 m flying height fix the height only to metres: checked against its σ).
    let errors = campaign.aerial_errors(&result);
    assert_eq!(errors.len(), summary.ties_with_aerial);
    assert!(errors.len() >= 2 * summary.images_matched, "{} correspondences", errors.len());
    let correct = errors.iter().filter(|(e, _)| e[0].hypot(e[1]) <= 2.0 * AERIAL_GSD).count();
    eprintln!("{correct} of {} correct; {}", errors.len(), wrong::ambiguity(&campaign, &result, &run.traces, 2.0));
    let explained = wrong::explain(&campaign, &result, &run.traces, 2.0 * AERIAL_GSD).join("\n");
    assert!(correct * 100 >= errors.len() * 99, "{correct} of {} correct:\n{explained}", errors.len());
    let consistent = errors.iter().filter(|(e, s)| e[2].abs() <= 3.0 * s[2]).count();
    assert!(consistent * 100 >= errors.len() * 99, "{consistent} of {} heights within 3σ", errors.len());
    // Every aerial tie records the ≥ 2 frames it was triangulated from, each one that gave its panorama's
    // patch correspondences (Jende et al. 2017 §3.9; for the adjustment's per-frame-set height bias).
    for d in &result.images {
        let with_aerial = result.ties.iter().filter(|t| t.aerial.is_some() && t.id.0.starts_with(&d.image));
        assert_eq!(d.aerial_frames.len(), with_aerial.count(), "{}", d.image);
        for f in &d.aerial_frames {
            let used = |id: &String| d.aerial_images.iter().any(|a| &a.frame == id && a.correspondences > 0);
            assert!(f.frames.len() >= 2 && f.frames.iter().all(used), "{f:?}");
            assert!(f.frames.windows(2).all(|w| w[0] < w[1]), "sorted, distinct: {f:?}");
        }
    }
    // Image-derived motion (Jende et al. 2017 §3.3, Cazzaniga et al. 2007 §4.1): most pairs have one; it agrees
    // with the TRUE motion within 3σ for ≥ 90 % of them, with σ of centimetres and milliradians, whatever the DG
    // motion's own error (printed beside it).
    let motions = campaign.motion_checks(&result);
    for m in &motions {
        eprintln!("motion error {:?} σ {:?}; DG motion error {:?}", m.error, m.std, m.dg_error);
    }
    assert!(
        motions.len() * 10 >= result.images.len() * 7,
        "{} of {} with a motion",
        motions.len(),
        result.images.len()
    );
    let within = motions.iter().filter(|m| m.within(3.0)).count();
    assert!(within * 10 >= motions.len() * 9, "{within} of {} within 3σ", motions.len());
    assert!(motions.iter().all(|m| m.std[0].max(m.std[1]) <= 0.05 && m.std[2] <= 5e-3), "σ too large");
    // The result survives its wire format, and every tie passes the adjustment's checks.
    let json = serde_json::to_string(&run.result).unwrap();
    assert!(json.starts_with(r#"{"version":"1""#));
    let back: TileResult = serde_json::from_str(&json).unwrap();
    assert_eq!(back, run.result);
    assert!(result.ties.iter().enumerate().all(|(i, t)| t.problems(i).is_empty()));
}
