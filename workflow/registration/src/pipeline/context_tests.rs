//! Panoramas prepared one at a time and context panoramas used only as neighbours: the owned panoramas'
//! diagnostics and ties are exactly those of registering every panorama of the tile.

use std::sync::atomic::{AtomicUsize, Ordering};

use super::*;
use crate::mm::Panorama;
use crate::mm::testing::{Ground, rig, scene_panorama};
use crate::output::DiscardReason;

/// Four panoramas 5 m apart along a street, and a fifth standing at the third's place a moment later (a stop:
/// no baseline, so it can pair with nobody and pushes the third's pairing backwards).
fn street(rig: &PanoramaRig) -> Vec<Panorama> {
    let ground = Ground::markings(31, [7.5, 0.0], 16.0);
    let places =
        [(100.0, [0.0, 0.0]), (101.0, [5.0, 0.1]), (102.0, [10.0, 0.2]), (102.5, [10.05, 0.2]), (103.0, [15.0, 0.3])];
    places
        .iter()
        .enumerate()
        .map(|(i, (time, at))| {
            let mut p = scene_panorama(&format!("p{i}"), &ground, rig, *at, 1.55, [0.7, -0.5, 0.04]);
            p.time = *time;
            p
        })
        .collect()
}

fn config() -> PipelineConfig {
    PipelineConfig { mm: MmConfig { half_extent: 7.5, ..MmConfig::default() }, ..PipelineConfig::default() }
}

#[test]
fn owned_panoramas_register_exactly_as_when_every_panorama_is_owned() {
    let (rig, config) = (rig(true), config());
    let panoramas = street(&rig);
    let none = AerialReference::Frames(Vec::new());
    let tile = TileId { col: 0, row: 0 };
    let all = register_tile(tile, &prepare_panoramas(&panoramas, &rig, &config.mm), &rig, &none, &config);
    let all = all.result.into_latest();
    // p1 and p2 are the tile's; the others belong to neighbouring tiles. p1 pairs forwards with p2; p2's
    // next panorama is the stop p3 (no baseline), so it pairs backwards with p1: no context panorama is
    // needed, and p3, unprepared, must still sit between p2 and p4.
    let owned = |id: &str| id == "p1" || id == "p2";
    let infos: Vec<PanoramaInfo> = panoramas.iter().map(|p| PanoramaInfo::of(p, owned(&p.id))).collect();
    assert_eq!(panoramas_to_prepare(&infos, &rig, &config), [false, true, true, false, false]);
    // Owning p0 and p4 instead needs their neighbours p1 and p3: context panoramas are prepared.
    let other: Vec<PanoramaInfo> =
        panoramas.iter().map(|p| PanoramaInfo::of(p, p.id == "p0" || p.id == "p4")).collect();
    assert_eq!(panoramas_to_prepare(&other, &rig, &config), [true, true, false, true, true]);
    // Prepared in reverse, one at a time, the unneeded ones left unprepared.
    let needed = panoramas_to_prepare(&infos, &rig, &config);
    let prepared: Vec<PreparedPanorama> =
        panoramas
            .iter()
            .zip(infos)
            .zip(needed)
            .rev()
            .map(|((p, info), need)| {
                if need {
                    prepare_panorama(p, info.owned, &rig, &config.mm)
                } else {
                    PreparedPanorama::unprepared(info)
                }
            })
            .collect();
    assert!(prepared.iter().all(|p| p.is_prepared() == p.owned() && p.error().is_none()));
    let calls = AtomicUsize::new(0);
    let count = |_: &ImageDiagnostic| {
        calls.fetch_add(1, Ordering::Relaxed);
    };
    let part = register_tile_reporting(tile, &prepared, &rig, &none, &config, &count).result.into_latest();
    assert_eq!(calls.load(Ordering::Relaxed), 2);
    let ids: Vec<&str> = part.images.iter().map(|d| d.image.as_str()).collect();
    assert_eq!(ids, ["p1", "p2"]);
    assert_eq!(part.images[1].neighbour.as_deref(), Some("p1"), "{:?}", part.images[1]);
    let expected: Vec<_> = all.images.iter().filter(|d| owned(&d.image)).cloned().collect();
    assert_eq!(part.images, expected);
    let tie_owner = |id: &str| id.rsplit_once(':').is_some_and(|(image, _)| owned(image));
    let expected_ties: Vec<_> = all.ties.iter().filter(|t| tie_owner(&t.id.0)).cloned().collect();
    assert!(expected_ties.len() >= 20, "{} ties", expected_ties.len());
    assert_eq!(part.ties, expected_ties);
    assert_eq!((part.summary.images, part.summary.ties), (2, expected_ties.len()));
    // Were p3 dropped instead of kept unprepared, p2 would pair with p4, which nobody prepared: the place
    // of an unprepared panorama matters, and a missing preparation is a diagnostic, not a panic.
    let without: Vec<PreparedPanorama> = prepared.into_iter().filter(|p| p.id() != "p3").collect();
    let wrong = register_tile(tile, &without, &rig, &none, &config).result.into_latest();
    assert_eq!(wrong.images[1].neighbour.as_deref(), Some("p4"));
    assert!(
        matches!(&wrong.images[1].discarded, Some(DiscardReason::Failed { step, message })
            if step == "neighbour ortho/features" && message.contains("p4")),
        "{:?}",
        wrong.images[1]
    );
}
