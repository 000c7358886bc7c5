//! One tile end to end: [`process_tile`] reads, registers and matches; [`run_tile`] adds resuming from a
//! result already written and writes the new one. The `_reporting` variants report progress per stage.

use std::sync::Arc;
use std::time::Instant;

use plumbline_campaign::Stage;
use plumbline_campaign::manifest::Panoramas;
use plumbline_campaign::progress::{NoProgress, Progress};
use plumbline_campaign::{Campaign, SkippedInput};
use plumbline_geo::tiling::{Tile, TileId};
use plumbline_geo::{Map, Point3};
use plumbline_registration::TileResultV1;
use plumbline_registration::mm::PanoramaRig;
use plumbline_registration::output::{ImageDiagnostic, TileSummary};
use plumbline_runtime::{Files, invalid};
use tracing::Instrument as _;

use crate::config::WorkerConfig;
use crate::output::{TileOutput, TileOutputV1, read_finished, tile_key};
use crate::stages::Timed;
use crate::{aerial, panoramas, poles, prepare};

/// Registration of a tile and its stage times.
struct Registered {
    result: Option<TileResultV1>,
    skipped: Vec<SkippedInput>,
    seconds: Vec<(String, f64)>,
}

/// Process one tile of a planned campaign: register its owned panoramas (with their context neighbours)
/// against the aerial reference (Jende et al. 2017) and match the poles of its depth images (Meyer et al. 2023).
///
/// Broken inputs (a missing or corrupt panorama, frame or depth image, a bad cadastre feature) are skipped
/// and listed in the output. Errors: a tile that is not in the plan, a campaign without panoramas, or one
/// that gives no camera height (invalid input); failures of the store or the runtime.
pub async fn process_tile(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    config: &WorkerConfig,
) -> plumbline_runtime::Result<TileOutputV1> {
    process_tile_reporting(files, campaign, tile, config, &NoProgress).await
}

/// [`process_tile`], reporting to `progress`: stage `registration` advances by one per owned panorama
/// (registered, or skipped when it could not be read or the campaign has no aerial imagery) and stage
/// `poles` by one per depth image (processed, or skipped when it could not be read). Panoramas are read,
/// decoded and prepared a few at a time and their pixels dropped at once, so a tile's memory holds ortho
/// patches rather than panoramas.
#[tracing::instrument(skip_all, fields(col = tile.col, row = tile.row))]
pub async fn process_tile_reporting(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    config: &WorkerConfig,
    progress: &dyn Progress,
) -> plumbline_runtime::Result<TileOutputV1> {
    let start = Instant::now();
    let Some(planned) = campaign.plan.tiles.tile(tile) else {
        return Err(invalid(format!("tile c{}_r{}: not in the campaign's plan", tile.col, tile.row)));
    };
    let Some(spec) = &campaign.manifest.panoramas else {
        return Err(invalid("panoramas: missing; tiles are made of panoramas"));
    };
    let owned = i64::try_from(planned.owned.len()).unwrap_or(i64::MAX);
    let registered = register(files, campaign, planned, spec, config, progress)
        .instrument(tracing::info_span!("stage", stage = Stage::Registration.name(), panoramas = owned))
        .await?;
    let poles = poles::process(files, campaign, tile, &planned.fetch, &config.poles, config.concurrency, progress)
        .instrument(tracing::info_span!("stage", stage = Stage::Poles.name()))
        .await?;
    let mut seconds = registered.seconds;
    seconds.push(Timed::PolesRead.took(poles.read_s));
    seconds.push(Timed::Poles.took(poles.process_s));
    seconds.push(Timed::Total.took(start.elapsed().as_secs_f64()));
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
        fingerprint: Some(crate::fingerprint(campaign, tile, config)),
    })
}

/// The height of the panoramic camera above the road that a tile's registration uses: the manifest's
/// `panoramas.camera_height_m`, else the DG camera height minus the terrain model's height under the tile's
/// first panorama. Invalid input when neither is available.
pub async fn tile_camera_height(files: &Files, campaign: &Campaign, tile: &TileId) -> plumbline_runtime::Result<f64> {
    let Some(planned) = campaign.plan.tiles.tile(tile) else {
        return Err(invalid(format!("tile c{}_r{}: not in the campaign's plan", tile.col, tile.row)));
    };
    let Some(spec) = &campaign.manifest.panoramas else {
        return Err(invalid("panoramas: missing; tiles are made of panoramas"));
    };
    let images = panoramas::planned(campaign, planned)?;
    let first = images
        .iter()
        .min_by(|a, b| a.time.total_cmp(&b.time))
        .ok_or_else(|| plumbline_runtime::Error::internal("empty tile"))?;
    panoramas::camera_height(files, campaign, spec, first).await
}

/// The registration half of a tile; `result: None` when the campaign has no aerial imagery. Every owned
/// panorama advances stage `registration` of `progress`, registered or skipped.
async fn register(
    files: &Files,
    campaign: &Campaign,
    tile: &Tile,
    spec: &Panoramas,
    config: &WorkerConfig,
    progress: &dyn Progress,
) -> plumbline_runtime::Result<Registered> {
    let mut out = Registered { result: None, skipped: Vec::new(), seconds: Vec::new() };
    let owned = tile.owned.len() as u64;
    if campaign.manifest.aerial.is_none() {
        progress.skip(Stage::Registration, owned);
        return Ok(out);
    }
    let images = panoramas::planned(campaign, tile)?;
    let Some(first) = images.iter().min_by(|a, b| a.time.total_cmp(&b.time)) else {
        return Ok(out);
    };
    let camera_height = panoramas::camera_height(files, campaign, spec, first).await?;
    let placed = panoramas::place(campaign, spec, &images, tile.owned.len(), &mut out.skipped);
    let size = match panoramas::size(files, spec, &placed).await {
        Ok(size) => size,
        Err(failures) => {
            // Nothing readable and no size in the manifest: every panorama is skipped.
            out.skipped.extend(failures);
            out.result = Some(summarised(tile.id, Vec::new(), Vec::new()));
            progress.skip(Stage::Registration, owned);
            return Ok(out);
        }
    };
    let mut rig = panoramas::rig(files, campaign, spec, size, camera_height, &mut out.skipped).await?;
    let pipeline = config.registration;
    let area = aerial::window_of(&tile.fetch, pipeline.mm.half_extent);
    rig.terrain = panoramas::terrain_model(files, campaign, area, &mut out.skipped).await?;
    let rig = Arc::new(rig);
    // The reference first: where the patches lie follows from the DG poses alone.
    let ground = ground_points(&placed, &rig, tile);
    let sigma = placed.iter().filter(|p| p.info.owned).map(|p| p.info.position_sigma).fold(0.0, f64::max);
    let reach = pipeline.aerial.frame_reach(pipeline.mm.half_extent, sigma);
    let Some(reference) = aerial::load(files, campaign, &ground, reach, area, config.concurrency).await? else {
        progress.skip(Stage::Registration, owned);
        return Ok(out);
    };
    out.skipped.extend(reference.skipped);
    let t0 = Instant::now();
    let streamed = prepare::Tile {
        files,
        id: tile.id,
        placed: &placed,
        rig: &rig,
        config: &pipeline,
        concurrency: config.concurrency,
    };
    let registered = prepare::register(&streamed, Arc::new(reference.reference), progress).await?;
    let prepare_s = t0.elapsed().as_secs_f64();
    out.skipped.extend(registered.skipped);
    let result = registered.run.result.into_latest();
    progress.skip(Stage::Registration, owned.saturating_sub(result.images.len() as u64));
    let t = &registered.run.timings;
    tracing::debug!(most_held = registered.most_held, "prepared patches held at once");
    out.seconds = vec![
        Timed::Read.took(registered.read_s + reference.read_s),
        Timed::Decode.took(registered.decode_s + reference.decode_s),
        Timed::Ortho.took(t.ortho.as_secs_f64()),
        Timed::Features.took(t.features.as_secs_f64()),
        Timed::Prepare.took(prepare_s),
        Timed::Matching.took(t.matching.as_secs_f64()),
        Timed::Triangulation.took(t.triangulation.as_secs_f64()),
        Timed::Aerial.took(t.aerial.as_secs_f64()),
        Timed::Lines.took(t.lines.as_secs_f64()),
        Timed::Registration.took(t.total.as_secs_f64()),
    ];
    out.result = Some(result);
    Ok(out)
}

/// Where the tile's MM patches lie on the road: the owned panoramas' DG camera centres lowered by the camera
/// height, and the fetch box's centre at their mean height.
fn ground_points(placed: &[panoramas::Placed], rig: &PanoramaRig, tile: &Tile) -> Vec<Point3<Map>> {
    let mut ground: Vec<Point3<Map>> = placed
        .iter()
        .filter(|p| p.info.owned)
        .map(|p| {
            let c = rig.mount.camera_pose(&p.info.pose).translation;
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

fn summarised(tile: TileId, images: Vec<ImageDiagnostic>, ties: Vec<plumbline_adjustment::TiePoint>) -> TileResultV1 {
    let summary = TileSummary::of(&images, &ties);
    TileResultV1 { tile, ties, images, summary }
}

/// [`process_tile`] with resuming: when `{output}tiles/{col}_{row}.json` already holds this tile's output
/// with the [`crate::fingerprint`] of its current inputs and parameters, return it and `true`; otherwise
/// process, write the output (pretty JSON) and return it with `false`. An existing file of other inputs, one
/// that does not parse or holds another tile is logged and replaced.
pub async fn run_tile(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    config: &WorkerConfig,
) -> plumbline_runtime::Result<(TileOutputV1, bool)> {
    run_tile_reporting(files, campaign, tile, config, &NoProgress).await
}

/// [`run_tile`], reporting to `progress` as [`process_tile_reporting`] does; a resumed tile advances the
/// stages at once by what its output holds.
pub async fn run_tile_reporting(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    config: &WorkerConfig,
    progress: &dyn Progress,
) -> plumbline_runtime::Result<(TileOutputV1, bool)> {
    let url = format!("{}{}", campaign.output, tile_key(tile));
    let fingerprint = crate::fingerprint(campaign, tile, config);
    if let Some(done) = read_finished(files, &url, tile, &fingerprint).await? {
        report_resumed(campaign, &done, progress);
        return Ok((done, true));
    }
    let output = process_tile_reporting(files, campaign, tile, config, progress).await?;
    let json = serde_json::to_vec_pretty(&TileOutput::V1(output.clone()))?;
    files.write(&url, json).await?;
    Ok((output, false))
}

/// Advance the stages by a resumed tile's output: its diagnostics and pole frames done, the rest skipped.
fn report_resumed(campaign: &Campaign, done: &TileOutputV1, progress: &dyn Progress) {
    let owned = campaign.plan.tiles.tile(&done.tile).map_or(0, |t| t.owned.len()) as u64;
    let registered = done.registration.as_ref().map_or(0, |r| r.images.len()) as u64;
    progress.advance(Stage::Registration, registered);
    progress.skip(Stage::Registration, owned.saturating_sub(registered));
    let depth = campaign.plan.depth_of(&done.tile).len() as u64;
    let frames = done.pole_frames.len() as u64;
    progress.advance(Stage::Poles, frames);
    progress.skip(Stage::Poles, depth.saturating_sub(frames));
}
