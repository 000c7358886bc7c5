//! The MM side of a tile's registration: its owned and context panoramas placed at their DG pose, decoded to
//! gray one at a time (`crate::prepare`), and the rig they share (camera model, mount, vehicle mask, camera
//! height above the road, and the terrain model the ortho-projection follows).

use std::sync::Arc;

use plumbline_campaign::manifest::Panoramas;
use plumbline_campaign::plan::PlannedImage;
use plumbline_campaign::{Campaign, SkippedInput};
use plumbline_campaign::{SkipReason, Stage};
use plumbline_geo::camera::Equirectangular;
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::tiling::Tile;
use plumbline_geo::{PositionInterpolation, TrajectoryRecord};
use plumbline_imaging::ImagePart;
use plumbline_imaging::decode::{Bounds, DecodeError, PANORAMA_PIXELS, decode_gray_part, decode_mask, header};
use plumbline_poles::pipeline::DEFAULT_DG_SIGMA_M;
use plumbline_registration::aerial::Terrain;
use plumbline_registration::mm::{Panorama, PanoramaRig, SubCameras};
use plumbline_registration::pipeline::PanoramaInfo;
use plumbline_runtime::gdal_read::MapBox;
use plumbline_runtime::{Files, invalid};

use crate::fetch::{blocking, read_all, read_one, refused, skipped};
use crate::raster::{around, height_at, read_window, terrain};

pub(crate) const STAGE: Stage = Stage::Registration;

/// A planned panorama whose file URL and DG pose are known; its pixels are not read yet.
#[derive(Clone, Debug)]
pub(crate) struct Placed {
    /// Where its file is.
    pub url: String,
    /// Id, time, DG pose, σ, owned or context.
    pub info: PanoramaInfo,
}

/// The planned images of a tile: owned, then context, each in capture order.
pub(crate) fn planned<'a>(campaign: &'a Campaign, tile: &Tile) -> plumbline_runtime::Result<Vec<&'a PlannedImage>> {
    let plan = &campaign.plan;
    tile.owned
        .iter()
        .chain(&tile.context)
        .map(|id| {
            let image = usize::try_from(id.0).ok().and_then(|i| plan.panoramas.get(i));
            image
                .filter(|p| p.id == *id)
                .ok_or_else(|| plumbline_runtime::Error::internal(format!("plan: panorama {id} is not in the plan")))
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

/// Half the span the DG velocity at an image's time is differenced over, seconds.
const VELOCITY_HALF_SPAN_S: f64 = 0.05;

/// The vehicle's velocity at `time` from the DG trajectory ([`plumbline_geo::Trajectory::velocity`] over
/// ±50 ms), m/s; `None` where the trajectory does not give one.
pub(crate) fn velocity(campaign: &Campaign, time: f64) -> Option<[f64; 3]> {
    campaign.trajectory.trajectory.velocity(time, VELOCITY_HALF_SPAN_S).map(|v| [v.x(), v.y(), v.z()])
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

/// Place `images` (owned first, `owned` of them) at their DG poses. One whose URL cannot be formed or whose
/// time lies outside the trajectory is skipped and reported.
pub(crate) fn place(
    campaign: &Campaign,
    spec: &Panoramas,
    images: &[&PlannedImage],
    owned: usize,
    skipped_items: &mut Vec<SkippedInput>,
) -> Vec<Placed> {
    let mut placed = Vec::with_capacity(images.len());
    let rolling = spec.readout_s.is_some_and(|r| r > 0.0);
    for (k, image) in images.iter().enumerate() {
        let url = match campaign.file_url(&spec.images, &image.file) {
            Ok(url) => url,
            Err(e) => {
                let detail = format!("panorama {}: {e:#}", image.image_id);
                skipped_items.push(skipped(STAGE, &image.file, SkipReason::Url, detail));
                continue;
            }
        };
        match dg_at(campaign, image.time) {
            Ok(record) => {
                // Only a rolling shutter needs the velocity (the rows' times); without one it is not taken.
                let velocity = rolling.then(|| velocity(campaign, image.time)).flatten();
                if rolling && velocity.is_none() {
                    tracing::warn!(
                        panorama = %image.image_id,
                        "no DG velocity at the panorama's time: its rolling shutter is not corrected"
                    );
                }
                placed.push(Placed {
                    info: PanoramaInfo {
                        id: image.image_id.clone(),
                        time: image.time,
                        pose: record.pose(),
                        position_sigma: position_sigma(&record),
                        velocity,
                        owned: k < owned,
                    },
                    url,
                })
            }
            Err(e) => skipped_items.push(skipped(STAGE, &url, SkipReason::Time, format!("{url}: {e}"))),
        }
    }
    placed
}

/// What a panorama (and the vehicle mask) may be before it is decoded: [`PANORAMA_PIXELS`] at most.
const BUDGET: Bounds = Bounds::budget(PANORAMA_PIXELS);

/// The panorama size: the manifest's, else the header of the first panorama that can be read and fits the
/// pixel budget (no pixels are decoded). When neither exists, every panorama's failure as a skipped item.
pub(crate) async fn size(files: &Files, spec: &Panoramas, placed: &[Placed]) -> Result<(u32, u32), Vec<SkippedInput>> {
    if let Some(size) = spec.width_px.zip(spec.height_px) {
        return Ok(size);
    }
    let mut failures = Vec::new();
    for p in placed {
        let url = &p.url;
        match read_one(files, url, STAGE).await {
            Ok(bytes) => match header(url, &bytes, &BUDGET) {
                Ok(h) => return Ok((h.width, h.height)),
                Err(e) => failures.push(refused(STAGE, url, &e)),
            },
            Err(s) => failures.push(s),
        }
    }
    Err(failures)
}

/// Decode `part` of a panorama to gray within the pixel budget and the part's full size (both checked on
/// the header, before any pixel is decoded): the gray [`Panorama`] at its DG pose, or the skipped item
/// ([`SkipReason::Size`] or [`SkipReason::Decode`]).
pub(crate) fn decode(placed: &Placed, bytes: &[u8], part: &ImagePart) -> Result<Panorama, SkippedInput> {
    let url = &placed.url;
    let gray = decode_gray_part(url, bytes, &BUDGET, part).map_err(|e| refused(STAGE, url, &e))?;
    let info = &placed.info;
    Ok(Panorama {
        id: info.id.clone(),
        time: info.time,
        image: gray,
        part: *part,
        pose: info.pose,
        position_sigma: info.position_sigma,
        velocity: info.velocity,
    })
}

/// Camera height above the road: the manifest's `camera_height_m`, else the DG camera height minus the
/// terrain model's height under the first panorama; invalid input when neither is available.
pub(crate) async fn camera_height(
    files: &Files,
    campaign: &Campaign,
    spec: &Panoramas,
    first: &PlannedImage,
) -> plumbline_runtime::Result<f64> {
    if let Some(h) = spec.camera_height_m {
        return Ok(h);
    }
    let missing = "panoramas.camera_height_m: not given, and needed for the ortho-projection of the panoramas \
                   (Jende et al. 2017 §3.2) unless [aerial.orthophoto] names a terrain model";
    let Some(ortho) = campaign.manifest.aerial.as_ref().and_then(|a| a.orthophoto.as_ref()) else {
        return Err(invalid(missing));
    };
    let url = campaign.url(&ortho.terrain)?;
    let record = dg_at(campaign, first.time).map_err(invalid)?;
    let centre = mount(spec).camera_pose(&record.pose()).translation;
    let (e, n) = (centre.x(), centre.y());
    let ground = match read_window(files, &url, around(e, n, 5.0), campaign.epsg()).await {
        Ok(Some(w)) => terrain(&w).ok().and_then(|t| height_at(&t, e, n)).ok_or_else(|| "no data there".to_owned()),
        Ok(None) => Err("the position lies outside it".to_owned()),
        Err(e) if e.reason().retryable() => return Err(plumbline_runtime::Error::transient(format!("{url}: {e}"))),
        Err(e) => Err(e.to_string()),
    };
    match ground {
        Ok(z) => Ok(centre.z() - z),
        Err(why) => Err(invalid(format!(
            "{missing}; the terrain model {url} gives no height under panorama {} (E {e:.2}, N {n:.2}): {why}",
            first.image_id
        ))),
    }
}

/// The terrain model of `[aerial.orthophoto]` over `area`, for the ortho-projection to follow the relief
/// (`PanoramaRig::terrain`). `None` without one; an unreadable or non-covering model is reported and the
/// panoramas are projected on a plane. A store that fails to deliver it is reported as such
/// ([`SkipReason::Read`]), which makes the service retry the tile, as for the orthophoto's windows.
pub(crate) async fn terrain_model(
    files: &Files,
    campaign: &Campaign,
    area: MapBox,
    skipped_items: &mut Vec<SkippedInput>,
) -> plumbline_runtime::Result<Option<Arc<Terrain>>> {
    let Some(ortho) = campaign.manifest.aerial.as_ref().and_then(|a| a.orthophoto.as_ref()) else {
        return Ok(None);
    };
    let url = campaign.url(&ortho.terrain)?;
    let problem = match read_window(files, &url, area, campaign.epsg()).await {
        Ok(Some(w)) => match terrain(&w) {
            Ok(t) => return Ok(Some(Arc::new(t))),
            Err(e) => (SkipReason::Decode, format!("{url}: {e:#}")),
        },
        Ok(None) => (SkipReason::Outside, format!("{url}: the terrain model does not cover the tile")),
        Err(e) => (e.reason(), format!("{url}: {e}")),
    };
    let (why, detail) = problem;
    skipped_items.push(skipped(STAGE, &url, why, format!("{detail}; panoramas projected on a level plane")));
    Ok(None)
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
) -> plumbline_runtime::Result<PanoramaRig> {
    let camera = Equirectangular::new(size.0, size.1).map_err(|e| invalid(format!("panoramas: {e}")))?;
    let vehicle_mask = match &spec.vehicle_mask {
        Some(location) => {
            let url = campaign.url(location)?;
            let bytes = read_all(files, std::slice::from_ref(&url), 1, STAGE).await.pop();
            let mask = match bytes {
                Some(Ok(bytes)) => {
                    // The mask has the panoramas' size (the manifest's convention), checked on its header.
                    let (u, bounds) = (url.clone(), BUDGET.expecting(size.0, size.1));
                    blocking(move || decode_mask(&u, &bytes, &bounds)).await?.map_err(|e| {
                        let mut s = refused(STAGE, &url, &e);
                        if matches!(e, DecodeError::Size { .. }) {
                            s.detail.push_str(" (the panoramas' size)");
                        }
                        s.detail.push_str("; processing without a mask");
                        s
                    })
                }
                Some(Err(s)) => Err(s),
                None => Err(skipped(STAGE, &url, SkipReason::Read, format!("{url}: not read"))),
            };
            mask.map_err(|s| skipped_items.push(s)).ok()
        }
        None => None,
    };
    let sub_cameras = spec.rig.map(|r| SubCameras { count: r.cameras, radius_m: r.radius_m });
    let readout_s = spec.readout_s.unwrap_or(0.0);
    Ok(PanoramaRig { camera, mount: mount(spec), vehicle_mask, camera_height, sub_cameras, terrain: None, readout_s })
}

#[cfg(test)]
mod tests {
    use plumbline_geo::{MapFromBody, Point3, Rotation};

    use super::*;

    fn jpeg(w: u32, h: u32) -> Vec<u8> {
        let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([(x % 256) as u8, (y % 256) as u8, 90]));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Jpeg).unwrap();
        out.into_inner()
    }

    fn placed(url: &str) -> Placed {
        let pose = MapFromBody::new(Rotation::identity(), Point3::new(500.0, 800.0, 40.0));
        let info =
            PanoramaInfo { id: "pano7".into(), time: 12.5, pose, position_sigma: 0.2, velocity: None, owned: true };
        Placed { url: url.into(), info }
    }

    #[test]
    fn a_panorama_of_another_size_or_over_the_budget_is_skipped_naming_it() {
        let bytes = jpeg(64, 32);
        let p = placed("file:///c/panoramas/p7.jpg");
        let pano = decode(&p, &bytes, &ImagePart::whole(64, 32)).unwrap();
        assert_eq!((pano.id.as_str(), pano.time, pano.image.width(), pano.image.height()), ("pano7", 12.5, 64, 32));
        assert_eq!(pano.pose.translation.x(), 500.0);
        let wrong = decode(&p, &bytes, &ImagePart::whole(128, 64)).unwrap_err();
        assert_eq!((wrong.stage, &wrong.reason), (Stage::Registration, &SkipReason::Size));
        assert!(wrong.detail.contains("p7.jpg") && wrong.detail.contains("64 × 32"), "{}", wrong.detail);
        let garbage = decode(&p, b"no image", &ImagePart::whole(64, 32)).unwrap_err();
        assert_eq!(garbage.reason, SkipReason::Decode);
        // A header claiming 20000² px is refused before any pixel is decoded, whatever size the tile
        // expects.
        let forged = plumbline_testkit::images::png_claiming(20_000, 20_000);
        for size in [(64, 32), (20_000, 20_000)] {
            let bomb = decode(&p, &forged, &ImagePart::whole(size.0, size.1)).unwrap_err();
            assert_eq!(bomb.reason, SkipReason::Size);
            assert!(bomb.detail.contains("20000 × 20000 px") && bomb.detail.contains("budget"), "{}", bomb.detail);
        }
    }

    #[tokio::test]
    async fn without_a_manifest_size_the_first_header_within_the_budget_gives_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
        std::fs::write(path("bomb.png"), plumbline_testkit::images::png_claiming(20_000, 10_000)).unwrap();
        std::fs::write(path("p8.jpg"), jpeg(64, 32)).unwrap();
        let spec: Panoramas = serde_json::from_value(serde_json::json!({
            "index": "panoramas.csv",
            "images": "panoramas/",
            "mount": { "lever_arm_m": [0.0, 0.0, -2.0], "boresight_deg": [0.0, 0.0, 0.0] },
        }))
        .unwrap();
        let placed = [placed(&path("bomb.png")), placed(&path("p8.jpg"))];
        assert_eq!(size(&Files::default(), &spec, &placed).await.unwrap(), (64, 32));
        let failures = size(&Files::default(), &spec, &placed[..1]).await.unwrap_err();
        assert_eq!(failures.len(), 1);
        assert_eq!(failures[0].reason, SkipReason::Size);
        assert!(failures[0].detail.contains("bomb.png: 20000 × 10000 px"), "{}", failures[0].detail);
    }
}
