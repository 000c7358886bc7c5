//! One tile end to end: [`process_tile`] reads, registers and matches; [`run_tile`] adds resuming from a
//! result already written and writes the new one.

use std::collections::HashSet;
use std::time::Instant;

use plumbline_campaign::manifest::Panoramas;
use plumbline_geo::tiling::{Tile, TileId};
use plumbline_geo::{Map, Point3};
use plumbline_registration::mm::PanoramaRig;
use plumbline_registration::output::TileSummary;
use plumbline_registration::{TileResultV1, register_tile};
use plumbline_runtime::{Files, invalid};
use plumbline_scheduler::{Campaign, SkippedInput};

use crate::config::WorkerConfig;
use crate::fetch::blocking;
use crate::output::{TileOutput, TileOutputV1, tile_key};
use crate::{aerial, panoramas, poles};

/// Registration of a tile and its stage times.
struct Registered {
    result: Option<TileResultV1>,
    skipped: Vec<SkippedInput>,
    seconds: Vec<(String, f64)>,
}

/// Process one tile of a planned campaign: register its owned panoramas (with their context neighbours)
/// against the aerial reference (paper 000) and match the poles of its depth images (paper 002).
///
/// Broken inputs (a missing or corrupt panorama, frame or depth image, a bad cadastre feature) are skipped
/// and listed in the output. Errors: a tile that is not in the plan, a campaign without panoramas, or one
/// that gives no camera height (invalid input); failures of the store or the runtime.
#[tracing::instrument(skip_all, fields(col = tile.col, row = tile.row))]
pub async fn process_tile(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    config: &WorkerConfig,
) -> anyhow::Result<TileOutputV1> {
    let start = Instant::now();
    let Some(planned) = campaign.plan.tiles.tile(tile) else {
        return Err(invalid(format!("tile c{}_r{}: not in the campaign's plan", tile.col, tile.row)));
    };
    let Some(spec) = &campaign.manifest.panoramas else {
        return Err(invalid("panoramas: missing; tiles are made of panoramas"));
    };
    let registered = register(files, campaign, planned, spec, config).await?;
    let poles = poles::process(files, campaign, tile, &planned.fetch, &config.poles, config.concurrency).await?;
    let mut seconds = registered.seconds;
    seconds.push(("poles_read".into(), poles.read_s));
    seconds.push(("poles".into(), poles.process_s));
    seconds.push(("total".into(), start.elapsed().as_secs_f64()));
    let mut skipped = registered.skipped;
    skipped.extend(poles.skipped);
    tracing::info!(
        matched = registered.result.as_ref().map_or(0, |r| r.summary.images_matched),
        ties = registered.result.as_ref().map_or(0, |r| r.ties.len()),
        pole_updates = poles.updates.len(),
        skipped = skipped.len(),
        seconds = start.elapsed().as_secs_f64(),
        "tile processed"
    );
    Ok(TileOutputV1 {
        tile: *tile,
        registration: registered.result,
        poles: poles.updates,
        pole_frames: poles.reports,
        skipped,
        seconds,
    })
}

/// The height of the panoramic camera above the road that a tile's registration uses: the manifest's
/// `panoramas.camera_height_m`, else the DG camera height minus the terrain model's height under the tile's
/// first panorama. Invalid input when neither is available.
pub async fn tile_camera_height(files: &Files, campaign: &Campaign, tile: &TileId) -> anyhow::Result<f64> {
    let Some(planned) = campaign.plan.tiles.tile(tile) else {
        return Err(invalid(format!("tile c{}_r{}: not in the campaign's plan", tile.col, tile.row)));
    };
    let Some(spec) = &campaign.manifest.panoramas else {
        return Err(invalid("panoramas: missing; tiles are made of panoramas"));
    };
    let images = panoramas::planned(campaign, planned)?;
    let first = images.iter().min_by(|a, b| a.time.total_cmp(&b.time)).ok_or_else(|| anyhow::anyhow!("empty tile"))?;
    panoramas::camera_height(files, campaign, spec, first).await
}

/// The registration half of a tile; `result: None` when the campaign has no aerial imagery.
async fn register(
    files: &Files,
    campaign: &Campaign,
    tile: &Tile,
    spec: &Panoramas,
    config: &WorkerConfig,
) -> anyhow::Result<Registered> {
    let mut out = Registered { result: None, skipped: Vec::new(), seconds: Vec::new() };
    if campaign.manifest.aerial.is_none() {
        return Ok(out);
    }
    let images = panoramas::planned(campaign, tile)?;
    let Some(first) = images.iter().min_by(|a, b| a.time.total_cmp(&b.time)) else {
        return Ok(out);
    };
    let camera_height = panoramas::camera_height(files, campaign, spec, first).await?;
    let loaded = panoramas::load(files, campaign, spec, &images, config.concurrency).await?;
    out.skipped.extend(loaded.skipped);
    let (mut read_s, mut decode_s) = (loaded.read_s, loaded.decode_s);
    let owned: HashSet<String> = images[..tile.owned.len()].iter().map(|p| p.image_id.clone()).collect();
    let Some(size) = loaded.size else {
        // Nothing decoded and no size in the manifest: every panorama is already reported as skipped.
        out.result = Some(summarised(tile.id, Vec::new(), Vec::new()));
        return Ok(out);
    };
    let rig = panoramas::rig(files, campaign, spec, size, camera_height, &mut out.skipped).await?;
    let ground = ground_points(&loaded.panoramas, &owned, &rig, tile);
    let margin = config.registration.mm.half_extent;
    let area = aerial::window_of(&tile.fetch, margin);
    let Some(reference) = aerial::load(files, campaign, &ground, area, config.concurrency).await? else {
        return Ok(out);
    };
    out.skipped.extend(reference.skipped);
    read_s += reference.read_s;
    decode_s += reference.decode_s;
    let (id, pipeline, panoramas) = (tile.id, config.registration, loaded.panoramas);
    let run = blocking(move || register_tile(id, &panoramas, &rig, &reference.reference, &pipeline)).await?;
    let t = &run.timings;
    out.seconds = vec![
        ("read".into(), read_s),
        ("decode".into(), decode_s),
        ("ortho".into(), t.ortho.as_secs_f64()),
        ("features".into(), t.features.as_secs_f64()),
        ("matching".into(), t.matching.as_secs_f64()),
        ("triangulation".into(), t.triangulation.as_secs_f64()),
        ("aerial".into(), t.aerial.as_secs_f64()),
        ("registration".into(), t.total.as_secs_f64()),
    ];
    out.result = Some(owned_only(run.result.into_latest(), &owned));
    Ok(out)
}

/// Where the tile's MM patches lie on the road: the owned panoramas' DG camera centres lowered by the camera
/// height, and the fetch box's centre at their mean height.
fn ground_points(
    panoramas: &[plumbline_registration::mm::Panorama],
    owned: &HashSet<String>,
    rig: &PanoramaRig,
    tile: &Tile,
) -> Vec<Point3<Map>> {
    let mut ground: Vec<Point3<Map>> = panoramas
        .iter()
        .filter(|p| owned.contains(&p.id))
        .map(|p| {
            let c = rig.mount.camera_pose(&p.pose).translation;
            Point3::new(c.x(), c.y(), c.z() - rig.camera_height)
        })
        .collect();
    if !ground.is_empty() {
        let z = ground.iter().map(Point3::z).sum::<f64>() / ground.len() as f64;
        let f = &tile.fetch;
        ground.push(Point3::new(0.5 * (f.min_east + f.max_east), 0.5 * (f.min_north + f.max_north), z));
    }
    ground
}

/// Keep the diagnostics and ties of the tile's own panoramas (context panoramas belong to their own tile; a
/// tie's id is `{first panorama}:{index}`) and recount the summary.
fn owned_only(result: TileResultV1, owned: &HashSet<String>) -> TileResultV1 {
    let images = result.images.into_iter().filter(|d| owned.contains(&d.image)).collect();
    let first = |id: &str| id.rsplit_once(':').map(|(image, _)| image.to_owned());
    let ties = result.ties.into_iter().filter(|t| first(&t.id.0).is_some_and(|i| owned.contains(&i))).collect();
    summarised(result.tile, images, ties)
}

fn summarised(
    tile: TileId,
    images: Vec<plumbline_registration::output::ImageDiagnostic>,
    ties: Vec<plumbline_adjustment::TiePoint>,
) -> TileResultV1 {
    let summary = TileSummary::of(&images, &ties);
    TileResultV1 { tile, ties, images, summary }
}

/// [`process_tile`] with resuming: when `{output}tiles/{col}_{row}.json` already holds this tile's output,
/// return it and `true`; otherwise process, write the output (pretty JSON) and return it with `false`. An
/// existing file that does not parse, or holds another tile, is logged and replaced.
pub async fn run_tile(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    config: &WorkerConfig,
) -> anyhow::Result<(TileOutputV1, bool)> {
    let url = format!("{}{}", campaign.output, tile_key(tile));
    if files.exists(&url).await? {
        let bytes = files.read(&url).await?;
        match serde_json::from_slice::<TileOutput>(&bytes).map(TileOutput::into_latest) {
            Ok(done) if done.tile == *tile => return Ok((done, true)),
            Ok(other) => {
                tracing::warn!(file = %url, found = ?other.tile, "tile output holds another tile; reprocessing")
            }
            Err(e) => tracing::warn!(file = %url, error = %e, "tile output does not parse; reprocessing"),
        }
    }
    let output = process_tile(files, campaign, tile, config).await?;
    let json = serde_json::to_vec_pretty(&TileOutput::V1(output.clone()))?;
    files.write(&url, json).await?;
    Ok((output, false))
}

#[cfg(test)]
mod tests {
    use plumbline_adjustment::{AerialPoint, TiePoint, TiePointId, TieRay};
    use plumbline_registration::output::{CornerCounts, DiscardReason, ImageDiagnostic};

    use super::*;

    /// A diagnostic through its wire form (fields with serde defaults left out).
    fn diagnostic(image: &str, matched: bool) -> ImageDiagnostic {
        let discarded = (!matched).then_some(DiscardReason::NoNeighbour { nearest_m: None });
        serde_json::from_value(serde_json::json!({
            "image": image, "time": 0.0, "neighbour": null, "transform": null, "corners": CornerCounts::default(),
            "aerial_images": [], "aerial_points": 0, "discarded": discarded,
        }))
        .unwrap()
    }

    fn tie(id: &str, aerial: bool) -> TiePoint {
        let ray = TieRay { time: 0.0, direction: [0.0, 0.0, 1.0], sigma: 1e-3 };
        let point =
            AerialPoint { position: [0.0; 3], covariance: [[1e-2, 0.0, 0.0], [0.0, 1e-2, 0.0], [0.0, 0.0, 1e-2]] };
        TiePoint { id: TiePointId(id.into()), rays: vec![ray, ray], aerial: aerial.then_some(point) }
    }

    #[test]
    fn only_the_owned_panoramas_diagnostics_and_ties_are_kept_and_recounted() {
        let tile = TileId { col: 3, row: -2 };
        // "cam:7" is owned (an id with a colon: the tie index follows the last one); "ctx" is context.
        let images = vec![diagnostic("cam:7", true), diagnostic("ctx", true), diagnostic("own2", false)];
        let ties =
            vec![tie("cam:7:0000", true), tie("cam:7:0001", false), tie("ctx:0000", true), tie("own2:0000", false)];
        let summary = TileSummary::of(&images, &ties);
        let owned: HashSet<String> = ["cam:7", "own2"].map(String::from).into();
        let kept = owned_only(TileResultV1 { tile, ties, images, summary }, &owned);
        let names: Vec<&str> = kept.images.iter().map(|d| d.image.as_str()).collect();
        assert_eq!(names, ["cam:7", "own2"]);
        let ids: Vec<&str> = kept.ties.iter().map(|t| t.id.0.as_str()).collect();
        assert_eq!(ids, ["cam:7:0000", "cam:7:0001", "own2:0000"]);
        let s = &kept.summary;
        assert_eq!((s.images, s.images_matched, s.ties, s.ties_with_aerial), (2, 1, 3, 1));
        assert_eq!(s.discarded.get("no_neighbour"), Some(&1));
        assert_eq!(kept.tile, tile);
    }
}
