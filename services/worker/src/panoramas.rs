//! The MM side of a tile's registration: its owned and context panoramas read, decoded to gray and placed at
//! their DG pose, and the rig they share (camera model, mount, vehicle mask, camera height above the road).

use std::time::Instant;

use plumbline_campaign::manifest::Panoramas;
use plumbline_campaign::plan::PlannedImage;
use plumbline_geo::camera::Equirectangular;
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::tiling::Tile;
use plumbline_geo::{PositionInterpolation, TrajectoryRecord};
use plumbline_imaging::GrayImage;
use plumbline_poles::pipeline::DEFAULT_DG_SIGMA_M;
use plumbline_registration::mm::{Panorama, PanoramaRig};
use plumbline_runtime::{Files, invalid};
use plumbline_scheduler::{Campaign, SkippedInput};
use rayon::prelude::*;

use crate::fetch::{blocking, decode_gray, decode_mask, read_all, skipped};
use crate::raster::{around, height_at, read_window, terrain};

const STAGE: &str = "registration";

/// A tile's decoded panoramas.
pub(crate) struct LoadedPanoramas {
    /// In time order; owned and context.
    pub panoramas: Vec<Panorama>,
    /// The panorama size all of them have.
    pub size: Option<(u32, u32)>,
    /// What was left out.
    pub skipped: Vec<SkippedInput>,
    /// Seconds reading and decoding.
    pub read_s: f64,
    /// Seconds decoding (thread time of the blocking task).
    pub decode_s: f64,
}

/// The planned images of a tile: owned, then context, each in capture order.
pub(crate) fn planned<'a>(campaign: &'a Campaign, tile: &Tile) -> anyhow::Result<Vec<&'a PlannedImage>> {
    let plan = &campaign.plan;
    tile.owned
        .iter()
        .chain(&tile.context)
        .map(|id| {
            let image = usize::try_from(id.0).ok().and_then(|i| plan.panoramas.get(i));
            image.filter(|p| p.id == *id).ok_or_else(|| anyhow::anyhow!("plan: panorama {id} is not in the plan"))
        })
        .collect()
}

/// The DG record at an image's time.
pub(crate) fn dg_at(campaign: &Campaign, time: f64) -> Result<TrajectoryRecord, String> {
    campaign
        .trajectory
        .trajectory
        .interpolate(time, PositionInterpolation::Linear)
        .map_err(|e| format!("DG trajectory at time {time}: {e}"))
}

/// 1σ horizontal DG position error of a record, metres.
pub(crate) fn position_sigma(record: &TrajectoryRecord) -> f64 {
    record.std.map_or(DEFAULT_DG_SIGMA_M, |s| s.east.max(s.north))
}

/// The panoramic camera's mount from the manifest.
pub(crate) fn mount(spec: &Panoramas) -> CameraMount {
    let [roll, pitch, yaw] = spec.mount.boresight_deg;
    CameraMount::new(spec.mount.lever_arm_m, &Boresight::from_degrees(roll, pitch, yaw))
}

/// Read and decode `images`; one that is missing, undecodable, of the wrong size or outside the trajectory is
/// skipped and reported.
pub(crate) async fn load(
    files: &Files,
    campaign: &Campaign,
    spec: &Panoramas,
    images: &[&PlannedImage],
    concurrency: usize,
) -> anyhow::Result<LoadedPanoramas> {
    let t0 = Instant::now();
    let mut skipped_items = Vec::new();
    let mut wanted = Vec::new();
    for image in images {
        match campaign.file_url(&spec.images, &image.file) {
            Ok(url) => wanted.push(((*image).clone(), url)),
            Err(e) => {
                skipped_items.push(skipped(STAGE, &image.file, "url", format!("panorama {}: {e:#}", image.image_id)))
            }
        }
    }
    let urls: Vec<String> = wanted.iter().map(|(_, url)| url.clone()).collect();
    let bytes = read_all(files, &urls, concurrency, STAGE).await;
    let read_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let decoded: Vec<(PlannedImage, String, Result<GrayImage, SkippedInput>)> = blocking(move || {
        wanted
            .into_par_iter()
            .zip(bytes)
            .map(|((image, url), bytes)| {
                let gray = bytes.and_then(|b| decode_gray(&url, &b).map_err(|e| skipped(STAGE, &url, "decode", e)));
                (image, url, gray)
            })
            .collect()
    })
    .await?;
    let decode_s = t1.elapsed().as_secs_f64();
    let expected = spec.width_px.zip(spec.height_px);
    let mut out = LoadedPanoramas { panoramas: Vec::new(), size: expected, skipped: skipped_items, read_s, decode_s };
    for (image, url, gray) in decoded {
        match gray.and_then(|g| place(campaign, &image, &url, g, &mut out.size)) {
            Ok(p) => out.panoramas.push(p),
            Err(s) => out.skipped.push(s),
        }
    }
    out.panoramas.sort_by(|a, b| a.time.total_cmp(&b.time));
    Ok(out)
}

/// Check the size (the manifest's, else the first panorama's) and attach the DG pose.
fn place(
    campaign: &Campaign,
    image: &PlannedImage,
    url: &str,
    gray: GrayImage,
    size: &mut Option<(u32, u32)>,
) -> Result<Panorama, SkippedInput> {
    let found = (gray.width() as u32, gray.height() as u32);
    let (w, h) = *size.get_or_insert(found);
    if found != (w, h) {
        let detail = format!("{url}: panorama is {} × {} px, expected {w} × {h} px", found.0, found.1);
        return Err(skipped(STAGE, url, "size", detail));
    }
    let record = dg_at(campaign, image.time).map_err(|e| skipped(STAGE, url, "time", format!("{url}: {e}")))?;
    Ok(Panorama {
        id: image.image_id.clone(),
        time: image.time,
        image: gray,
        pose: record.pose(),
        position_sigma: position_sigma(&record),
    })
}

/// Camera height above the road: the manifest's `camera_height_m`, else the DG camera height minus the
/// terrain model's height under the first panorama; invalid input when neither is available.
pub(crate) async fn camera_height(
    files: &Files,
    campaign: &Campaign,
    spec: &Panoramas,
    first: &PlannedImage,
) -> anyhow::Result<f64> {
    if let Some(h) = spec.camera_height_m {
        return Ok(h);
    }
    let missing = "panoramas.camera_height_m: not given, and needed for the ortho-projection of the panoramas \
                   (paper 000 §3.2) unless [aerial.orthophoto] names a terrain model";
    let Some(ortho) = campaign.manifest.aerial.as_ref().and_then(|a| a.orthophoto.as_ref()) else {
        return Err(invalid(missing));
    };
    let url = campaign.url(&ortho.terrain)?;
    let record = dg_at(campaign, first.time).map_err(invalid)?;
    let centre = mount(spec).camera_pose(&record.pose()).translation;
    let (e, n) = (centre.x(), centre.y());
    let ground = match read_window(files, &url, around(e, n, 5.0)).await {
        Ok(Some(w)) => terrain(&w).ok().and_then(|t| height_at(&t, e, n)).ok_or_else(|| "no data there".to_owned()),
        Ok(None) => Err("the position lies outside it".to_owned()),
        Err(e) => Err(format!("{e:#}")),
    };
    match ground {
        Ok(z) => Ok(centre.z() - z),
        Err(why) => Err(invalid(format!(
            "{missing}; the terrain model {url} gives no height under panorama {} (E {e:.2}, N {n:.2}): {why}",
            first.image_id
        ))),
    }
}

/// The rig: camera of `size`, the manifest's mount, the vehicle mask when it can be read (else skipped and
/// reported, and the panoramas are processed without a mask).
pub(crate) async fn rig(
    files: &Files,
    campaign: &Campaign,
    spec: &Panoramas,
    size: (u32, u32),
    camera_height: f64,
    skipped_items: &mut Vec<SkippedInput>,
) -> anyhow::Result<PanoramaRig> {
    let camera = Equirectangular::new(size.0, size.1).map_err(|e| invalid(format!("panoramas: {e}")))?;
    let vehicle_mask = match &spec.vehicle_mask {
        Some(location) => {
            let url = campaign.url(location)?;
            let bytes = read_all(files, std::slice::from_ref(&url), 1, STAGE).await.pop();
            let mask = match bytes {
                Some(Ok(bytes)) => {
                    let u = url.clone();
                    blocking(move || decode_mask(&u, &bytes)).await?.map_err(|e| skipped(STAGE, &url, "decode", e))
                }
                Some(Err(s)) => Err(s),
                None => Err(skipped(STAGE, &url, "read", format!("{url}: not read"))),
            };
            let mask = mask.and_then(|m| {
                if (m.width(), m.height()) == (size.0 as usize, size.1 as usize) {
                    Ok(m)
                } else {
                    let detail = format!(
                        "{url}: vehicle mask is {} × {} px, the panoramas {} × {} px; processing without a mask",
                        m.width(),
                        m.height(),
                        size.0,
                        size.1
                    );
                    Err(skipped(STAGE, &url, "size", detail))
                }
            });
            mask.map_err(|s| skipped_items.push(s)).ok()
        }
        None => None,
    };
    Ok(PanoramaRig { camera, mount: mount(spec), vehicle_mask, camera_height })
}
