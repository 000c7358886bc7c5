//! End-to-end tests of the worker library on a campaign written by the real `plumbline simulate`: one tile
//! registered and its poles matched, broken inputs skipped and named, resuming from a written result.
//!
//! The campaign is simulated once per test build (the slow step) into `CARGO_TARGET_TMPDIR/worker-e2e`
//! (older copies removed, so one at most stays on disk) with 25 m tiles, so that a tile holds a handful of
//! panoramas and the tests stay quick.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plumbline_campaign::Campaign;
use plumbline_geo::tiling::{Tile, TileId};
use plumbline_runtime::{Files, is_invalid};
use plumbline_scheduler::load_campaign;
use plumbline_worker::{WorkerConfig, process_tile, run_tile, tile_key};
use support::plumbline;

/// Tile size and overlap the tests plan with, metres (the manifest's default is 250 m).
const TILING: &str = "\n[tiling]\ntile_size_m = 25.0\noverlap_m = 10.0\n";

/// The simulated campaign directory, shared by the tests of this binary ([`support::once_per_build`]).
fn simulated() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| support::once_per_build("worker-e2e", "campaign.toml", simulate_into))
}

/// Simulate the campaign into `out` with 25 m tiles.
fn simulate_into(out: &Path) {
    let start = std::time::Instant::now();
    plumbline(&["simulate", "--preset", "tiny", "--seed", "3", "--out", out.to_str().unwrap()]).run().success();
    eprintln!("simulate --preset tiny: {:.1} s", start.elapsed().as_secs_f64());
    let manifest = out.join("campaign.toml");
    let mut text = std::fs::read_to_string(&manifest).unwrap();
    assert!(!text.contains("[tiling]"), "the simulator now writes [tiling]; adapt the test");
    text.push_str(TILING);
    std::fs::write(&manifest, text).unwrap();
}

/// A private copy of the simulated campaign (removed with the returned guard).
fn copy_of_campaign() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let dst = dir.path().join("camp");
    support::copy_dir(simulated(), &dst);
    (dir, dst)
}

async fn load(dir: &Path) -> Campaign {
    load_campaign(&Files::default(), dir.join("campaign.toml").to_str().unwrap()).await.unwrap()
}

/// The tile with the most panoramas that also has depth images.
fn busiest(campaign: &Campaign) -> Tile {
    let tiles = campaign.plan.tiles.tiles();
    let with_depth = tiles.iter().filter(|t| !campaign.plan.depth_of(&t.id).is_empty());
    with_depth.max_by_key(|t| (t.owned.len(), std::cmp::Reverse(t.id))).unwrap().clone()
}

fn ids(campaign: &Campaign, images: &[plumbline_geo::tiling::ImageId]) -> HashSet<String> {
    images.iter().map(|id| campaign.plan.panoramas[id.0 as usize].image_id.clone()).collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_tile_registers_its_own_panoramas_and_matches_poles() {
    let dir = simulated();
    let campaign = load(dir).await;
    let tile = busiest(&campaign);
    let config = WorkerConfig::from_manifest(&campaign.manifest);
    let start = std::time::Instant::now();
    let out = process_tile(&Files::default(), &campaign, &tile.id, &config).await.unwrap();
    eprintln!(
        "tile {:?}: {} owned + {} context panoramas, {:.1} s; seconds {:?}",
        tile.id,
        tile.owned.len(),
        tile.context.len(),
        start.elapsed().as_secs_f64(),
        out.seconds
    );
    assert_eq!(out.tile, tile.id);
    assert!(out.skipped.is_empty(), "{:#?}", out.skipped);
    let registration = out.registration.as_ref().expect("the campaign has aerial frames");
    let summary = &registration.summary;
    eprintln!("{summary:?}; {} pole updates", out.poles.len());
    assert!(summary.images_matched > 0 && summary.ties_with_aerial > 0, "{summary:?}");
    // Exactly one diagnostic per owned panorama; context panoramas belong to their own tiles.
    let owned = ids(&campaign, &tile.owned);
    let diagnosed: Vec<&str> = registration.images.iter().map(|d| d.image.as_str()).collect();
    assert_eq!(diagnosed.len(), owned.len(), "{diagnosed:?}");
    assert_eq!(diagnosed.iter().map(|s| s.to_string()).collect::<HashSet<_>>(), owned);
    assert!(registration.ties.iter().all(|t| owned.contains(t.id.0.rsplit_once(':').unwrap().0)));
    assert_eq!(summary.images, owned.len());
    assert_eq!(summary.ties, registration.ties.len());
    // Poles: a report per depth frame of the tile, and coordinate updates from the cadastre.
    assert_eq!(out.pole_frames.len(), campaign.plan.depth_of(&tile.id).len());
    assert!(!out.poles.is_empty(), "no pole updates from {} depth frames", out.pole_frames.len());
    let stages: Vec<&str> = out.seconds.iter().map(|(s, _)| s.as_str()).collect();
    for stage in ["read", "decode", "ortho", "features", "aerial", "poles", "total"] {
        assert!(stages.contains(&stage), "{stages:?}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_corrupt_panorama_and_missing_or_broken_depth_images_are_skipped_and_named() {
    let (_guard, dir) = copy_of_campaign();
    let campaign = load(&dir).await;
    let tile = busiest(&campaign);
    // Break the second owned panorama (garbage bytes) and delete the tile's first depth image.
    let pano = &campaign.plan.panoramas[tile.owned[1].0 as usize];
    std::fs::write(dir.join("panoramas").join(&pano.file), b"this is no JPEG").unwrap();
    let depth = &campaign.plan.depth[campaign.plan.depth_of(&tile.id)[0]];
    std::fs::remove_file(dir.join("depth/right").join(&depth.file)).unwrap();
    // And truncate the second depth image: its frame is reported with the problem.
    let truncated = &campaign.plan.depth[campaign.plan.depth_of(&tile.id)[1]];
    let png = std::fs::read(dir.join("depth/right").join(&truncated.file)).unwrap();
    std::fs::write(dir.join("depth/right").join(&truncated.file), &png[..png.len() / 3]).unwrap();
    let config = WorkerConfig::from_manifest(&campaign.manifest);
    let out = process_tile(&Files::default(), &campaign, &tile.id, &config).await.unwrap();
    let find = |stage: &str, reason: &str| {
        out.skipped
            .iter()
            .find(|s| s.stage.name() == stage && s.reason.name() == reason)
            .unwrap_or_else(|| panic!("{:#?}", out.skipped))
    };
    let bad = find("registration", "decode");
    assert!(bad.item.ends_with(&pano.file) && bad.detail.contains(&pano.file), "{bad:?}");
    let gone = find("poles", "missing");
    assert!(gone.item.ends_with(&depth.file) && gone.detail.contains(&depth.file), "{gone:?}");
    let frame = find("poles", "frame");
    assert!(frame.item.ends_with(&truncated.file) && frame.detail.contains(&truncated.image_id), "{frame:?}");
    assert_eq!(out.skipped.len(), 3, "{:#?}", out.skipped);
    // The rest goes on: the broken panorama has no diagnostic, the others still give ties.
    let registration = out.registration.unwrap();
    assert_eq!(registration.images.len(), tile.owned.len() - 1);
    assert!(registration.images.iter().all(|d| d.image != pano.image_id));
    assert!(registration.summary.ties > 0, "{:?}", registration.summary);
    // A report for every depth image that could be read, the truncated one's naming its problem.
    assert_eq!(out.pole_frames.len(), campaign.plan.depth_of(&tile.id).len() - 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn run_tile_writes_its_output_and_resumes_from_it() {
    let (_guard, dir) = copy_of_campaign();
    let campaign = load(&dir).await;
    // The smallest tile keeps this quick.
    let tile = campaign.plan.tiles.tiles().iter().min_by_key(|t| (t.owned.len() + t.context.len(), t.id)).unwrap();
    let (files, config) = (Files::default(), WorkerConfig::from_manifest(&campaign.manifest));
    let (first, resumed) = run_tile(&files, &campaign, &tile.id, &config).await.unwrap();
    assert!(!resumed);
    let path = dir.join("results").join(tile_key(&tile.id));
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("\"version\": \"1\""), "pretty, versioned JSON");
    let (second, resumed) = run_tile(&files, &campaign, &tile.id, &config).await.unwrap();
    assert!(resumed);
    assert_eq!(second, first);
    // An output of another tile is not taken for this one.
    let other = TileId { col: tile.id.col + 1000, row: tile.id.row };
    std::fs::write(&path, text.replace(&format!("\"col\": {}", tile.id.col), &format!("\"col\": {}", other.col)))
        .unwrap();
    let (third, resumed) = run_tile(&files, &campaign, &tile.id, &config).await.unwrap();
    assert!(!resumed);
    assert_eq!(third.tile, tile.id);
    // Nor is a file that does not parse: it is replaced by a fresh result.
    std::fs::write(&path, "{ \"version\": \"1\", \"tile\": ").unwrap();
    let (fourth, resumed) = run_tile(&files, &campaign, &tile.id, &config).await.unwrap();
    assert!(!resumed);
    assert_eq!(fourth.registration, first.registration);
    let written: plumbline_worker::TileOutput = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(written.into_latest(), fourth);
}

/// A second cadastre, a copy of the first: the same objects must come back under their own ids.
const SECOND_CADASTRE: &str = "\n[[cadastres]]\nurl = \"cadastre/copy.gpkg\"\nlayers = [\"poles\", \"trees\"]\n\
                               class_attribute = \"class\"\n[cadastres.class_values]\nlight = \"light\"\n\
                               sign = \"sign\"\ntraffic_light = \"sign\"\ntree = \"tree\"\n";

/// Cadastre ids (`layer:fid`) the tile's pole reports name, matched or in view.
fn cadastre_ids(out: &plumbline_worker::TileOutputV1) -> HashSet<String> {
    let reports = serde_json::to_value(&out.pole_frames).unwrap();
    let mut ids = HashSet::new();
    for r in reports.as_array().unwrap() {
        for list in ["matches", "unseen"] {
            ids.extend(r[list].as_array().unwrap().iter().map(|m| m["cadastre_id"].as_str().unwrap().to_owned()));
        }
    }
    ids
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_orthophoto_with_its_terrain_model_stands_in_for_frames_and_camera_height() {
    let (_guard, dir) = copy_of_campaign();
    let manifest = dir.join("campaign.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let given: f64 = text.lines().find_map(|l| l.strip_prefix("camera_height_m = ")).unwrap().parse().unwrap();
    let mut edited: String =
        text.lines().filter(|l| !l.starts_with("camera_height_m")).map(|l| format!("{l}\n")).collect();
    let (frames, ortho) = (edited.find("[aerial.frames]").unwrap(), edited.find("[aerial.orthophoto]").unwrap());
    edited.replace_range(frames..ortho, "");
    edited.push_str(SECOND_CADASTRE);
    std::fs::copy(dir.join("cadastre/poles.gpkg"), dir.join("cadastre/copy.gpkg")).unwrap();
    std::fs::write(&manifest, &edited).unwrap();
    let campaign = load(&dir).await;
    assert!(campaign.manifest.aerial.as_ref().is_some_and(|a| a.frames.is_none()));
    let tile = busiest(&campaign);
    let files = Files::default();
    let height = plumbline_worker::tile_camera_height(&files, &campaign, &tile.id).await.unwrap();
    // Flat simulated terrain: DG camera height minus terrain height is the rig's height up to the DG height error.
    assert!((height - given).abs() < 0.15, "{height} vs {given}");
    let config = WorkerConfig::from_manifest(&campaign.manifest);
    let out = process_tile(&files, &campaign, &tile.id, &config).await.unwrap();
    assert!(out.skipped.is_empty(), "{:#?}", out.skipped);
    let registration = out.registration.as_ref().unwrap();
    eprintln!("orthophoto: {:?}", registration.summary);
    let frames: HashSet<&str> =
        registration.images.iter().flat_map(|d| d.aerial_images.iter().map(|a| a.frame.as_str())).collect();
    assert_eq!(frames, HashSet::from(["orthophoto.tif"]), "the orthophoto window is the only aerial image");
    // Both cadastres were read, the same objects under distinct ids (layers 0–1 and 2–3).
    let ids = cadastre_ids(&out);
    let second: Vec<&String> = ids.iter().filter(|id| id.starts_with("2:") || id.starts_with("3:")).collect();
    assert!(!second.is_empty(), "{ids:?}");
    for id in second {
        let (layer, fid) = id.split_once(':').unwrap();
        let first = format!("{}:{fid}", layer.parse::<u32>().unwrap() - 2);
        assert!(ids.contains(&first), "{id} without {first}: {ids:?}");
    }
    // Frames but neither a camera height nor a terrain model: the input is invalid, naming the field.
    let orthophoto = "[aerial.orthophoto]\nimage = \"aerial/orthophoto.tif\"\nterrain = \"aerial/terrain.tif\"\n";
    let without: String =
        text.lines().filter(|l| !l.starts_with("camera_height_m")).map(|l| format!("{l}\n")).collect();
    assert!(without.contains(orthophoto));
    std::fs::write(&manifest, without.replace(orthophoto, "")).unwrap();
    let campaign = load(&dir).await;
    let err = process_tile(&files, &campaign, &tile.id, &config).await.unwrap_err();
    assert!(is_invalid(&err) && format!("{err:#}").contains("panoramas.camera_height_m"), "{err:#}");
}
