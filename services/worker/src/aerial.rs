//! The aerial reference of a tile (Jende et al. 2017 §3.6–§3.9): the frames of the block that see the tile, decoded
//! with their interior and exterior orientation, or windows of the orthophoto and its terrain model.

use std::time::Instant;

use plumbline_campaign::manifest::{InteriorOrientation, Orthophoto as OrthophotoSpec};
use plumbline_campaign::tables::ExteriorRow;
use plumbline_campaign::{Campaign, SkippedInput};
use plumbline_campaign::{SkipReason, Stage};
use plumbline_geo::camera::{CameraModel, MetricInterior, Pinhole};
use plumbline_geo::tiling::BBox;
use plumbline_geo::{Map, MapFromCamera, OmegaPhiKappa, Point3, Pose};
use plumbline_registration::aerial::{AerialReference, FrameReach, Orthophoto};
use plumbline_runtime::gdal_read::MapBox;
use plumbline_runtime::{Files, file_name, invalid};

use crate::fetch::skipped;
use crate::raster::{gray, read_window, terrain};

const STAGE: Stage = Stage::Registration;

/// A tile's aerial reference and what it cost.
pub(crate) struct LoadedReference {
    /// Frames or an orthophoto window.
    pub reference: AerialReference,
    /// Frames or windows left out.
    pub skipped: Vec<SkippedInput>,
    /// Seconds reading.
    pub read_s: f64,
    /// Seconds decoding.
    pub decode_s: f64,
}

/// The pinhole model of the block's camera: the manifest's metric interior orientation
/// (Grejner-Brzezinska and Toth 2000, Table 2) in pixels, as the simulator flies it
/// (`plumbline_synth::aerial::small_format_distorted`).
pub fn frame_camera(interior: &InteriorOrientation) -> plumbline_runtime::Result<Pinhole> {
    let metric = MetricInterior {
        focal_mm: interior.focal_length_mm,
        xp_mm: interior.principal_point_mm[0],
        yp_mm: interior.principal_point_mm[1],
        k1: interior.k1,
        k2: interior.k2,
        pixel_mm: interior.pixel_size_mm,
        width: interior.width_px,
        height: interior.height_px,
    };
    Pinhole::from_metric(&metric).map_err(|e| invalid(format!("aerial.frames.interior: {e}")))
}

/// A frame's exterior orientation: projection centre and omega-phi-kappa (ARCHITECTURE.md § Angles).
pub fn frame_pose(row: &ExteriorRow) -> MapFromCamera {
    let [omega, phi, kappa] = row.opk_deg;
    let [x, y, z] = row.centre;
    Pose::new(OmegaPhiKappa::from_degrees(omega, phi, kappa).to_rotation(), Point3::new(x, y, z))
}

/// Whether any of `ground` projects inside the frame.
pub(crate) fn sees(camera: &Pinhole, pose: &MapFromCamera, ground: &[Point3<Map>]) -> bool {
    let to_camera = pose.inverse();
    ground.iter().any(|p| {
        let d = to_camera.transform_point(p);
        d.z() > 0.0 && camera.project(&(d - Point3::origin())).is_some_and(|px| camera.contains(px))
    })
}

/// The reference for a tile whose MM patches lie around `ground` (box centre and owned panoramas on the
/// road) within `area`: the frames that see them, each read as the window that `reach` around the ground
/// points needs, or else the orthophoto's window over `area`; `None` when the manifest names no aerial imagery.
pub(crate) async fn load(
    files: &Files,
    campaign: &Campaign,
    ground: &[Point3<Map>],
    reach: FrameReach,
    area: MapBox,
    concurrency: usize,
) -> plumbline_runtime::Result<Option<LoadedReference>> {
    let Some(aerial) = &campaign.manifest.aerial else {
        return Ok(None);
    };
    let mut loaded = match &aerial.frames {
        Some(block) => frames::load(files, campaign, block, ground, reach, concurrency).await?,
        None => LoadedReference {
            reference: AerialReference::Frames(Vec::new()),
            skipped: Vec::new(),
            read_s: 0.0,
            decode_s: 0.0,
        },
    };
    let no_frames = matches!(&loaded.reference, AerialReference::Frames(f) if f.is_empty());
    if let (true, Some(ortho)) = (no_frames, &aerial.orthophoto) {
        let t0 = Instant::now();
        let (reference, problems) = orthophoto(files, campaign, ortho, area).await?;
        loaded.read_s += t0.elapsed().as_secs_f64();
        loaded.skipped.extend(problems);
        if let Some(reference) = reference {
            loaded.reference = reference;
        }
    }
    Ok(Some(loaded))
}

/// Windows of the orthophoto and its terrain model over `area`. An unreadable orthophoto gives no reference
/// (reported); an unreadable terrain model gives an orthophoto without terrain (reported). A store that fails to
/// deliver either is reported as such ([`SkipReason::Read`]), which makes the service retry the tile.
async fn orthophoto(
    files: &Files,
    campaign: &Campaign,
    spec: &OrthophotoSpec,
    area: MapBox,
) -> plumbline_runtime::Result<(Option<AerialReference>, Vec<SkippedInput>)> {
    let (image_url, terrain_url) = (campaign.url(&spec.image)?, campaign.url(&spec.terrain)?);
    let mut problems = Vec::new();
    let image = match read_window(files, &image_url, area, campaign.epsg()).await {
        Ok(Some(w)) => match gray(&w) {
            Ok(g) => (g, w.geotransform),
            Err(e) => {
                problems.push(skipped(STAGE, &image_url, SkipReason::Decode, format!("{image_url}: {e:#}")));
                return Ok((None, problems));
            }
        },
        Ok(None) => {
            let detail = format!("{image_url}: the orthophoto does not cover the tile ({area:?})");
            problems.push(skipped(STAGE, &image_url, SkipReason::Outside, detail));
            return Ok((None, problems));
        }
        Err(e) => {
            problems.push(skipped(STAGE, &image_url, e.reason(), format!("{image_url}: {e}")));
            return Ok((None, problems));
        }
    };
    let terrain = match read_window(files, &terrain_url, area, campaign.epsg()).await {
        Ok(Some(w)) => terrain(&w).map_err(|e| (SkipReason::Decode, format!("{terrain_url}: {e:#}"))),
        Ok(None) => Err((SkipReason::Outside, format!("{terrain_url}: the terrain model does not cover the tile"))),
        Err(e) => Err((e.reason(), format!("{terrain_url}: {e}"))),
    };
    let terrain = terrain.map_err(|(why, detail)| problems.push(skipped(STAGE, &terrain_url, why, detail))).ok();
    let (image, geotransform) = image;
    let id = file_name(&image_url).to_owned();
    Ok((Some(AerialReference::Orthophoto(Orthophoto { id, image, geotransform, terrain })), problems))
}

/// A tile's fetch box grown by `margin` metres, as a raster window.
pub(crate) fn window_of(fetch: &BBox, margin: f64) -> MapBox {
    MapBox {
        min_e: fetch.min_east - margin,
        min_n: fetch.min_north - margin,
        max_e: fetch.max_east + margin,
        max_n: fetch.max_north + margin,
    }
}

mod frames;
#[cfg(test)]
mod tests;
