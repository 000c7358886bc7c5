//! The block's frames that see a tile, each read as the window of it the tile's registration can reach
//! (`AerialConfig::frame_reach`), so that a tile holds a few megapixels per frame whatever the frame's size.
//!
//! Tiled rasters (GeoTIFF/COG, BigTIFF, JPEG 2000 where the system GDAL reads it) go through GDAL, which reads
//! only the tiles the window touches: in place for local files, with HTTP range requests for `s3://` files
//! (`Files::remote_raster`), and from fetched bytes for other stores. 8 or 16 bit, 1–4 bands, made grey by
//! `plumbline_imaging::radiometry`. JPEG and PNG frames (what `plumbline simulate` writes) cannot be read a
//! window at a time: they are decoded whole within [`AERIAL_FRAME_PIXELS`], cropped, and the rest dropped
//! at once; at most one frame per rayon thread is decoded at a time.

use std::time::Instant;

use bytes::Bytes;
use futures::StreamExt as _;
use plumbline_campaign::SkipReason;
use plumbline_campaign::manifest::FrameBlock;
use plumbline_campaign::{Campaign, SkippedInput};
use plumbline_geo::camera::{CameraModel, Pinhole};
use plumbline_geo::tiling::BBox;
use plumbline_geo::{Map, MapFromCamera, Point3};
use plumbline_imaging::GrayImage;
use plumbline_imaging::decode::{AERIAL_FRAME_PIXELS, Bounds, DecodeError, decode_gray};
use plumbline_imaging::radiometry::gray_from_bands;
use plumbline_registration::aerial::{AerialFrame, AerialReference, FrameReach};
use plumbline_runtime::Files;
use plumbline_runtime::gdal_read::{MAGIC_BYTES, PixelSource, is_tiled_raster};

use super::{LoadedReference, STAGE, frame_camera, frame_pose, sees};
use crate::fetch::{on_rayon, read_one, refused, skipped};

/// Most pixels of one frame window (a tile's reach is usually a few megapixels; a frame that sees the tile
/// so obliquely that its window cannot be computed is read whole, up to this).
pub(crate) const WINDOW_PIXELS: usize = 64 << 20;

/// A frame's pixel window: column, row, width, height.
pub(crate) type PixelWindow = (usize, usize, usize, usize);

/// The frames of `block` that see `ground`, each read as the window that `reach` around the ground points
/// (the owned panoramas' patch centres) needs; a missing, broken or wrong-size frame is skipped.
pub(super) async fn load(
    files: &Files,
    campaign: &Campaign,
    block: &FrameBlock,
    ground: &[Point3<Map>],
    reach: FrameReach,
    concurrency: usize,
) -> plumbline_runtime::Result<LoadedReference> {
    let camera = frame_camera(&block.interior)?;
    let mut skipped_items = Vec::new();
    let heights =
        ground.iter().map(Point3::z).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| (lo.min(z), hi.max(z)));
    let area = reach_box(bounds_of(ground), reach);
    let mut chosen = Vec::new();
    for row in &campaign.aerial_frames {
        let pose = frame_pose(row);
        if !sees(&camera, &pose, ground) {
            continue;
        }
        match campaign.file_url(&block.images, &row.file) {
            Ok(url) => {
                let window = frame_window(&camera, &pose, &area, heights, reach);
                chosen.push(Wanted { id: row.image_id.clone(), pose, url, camera, window });
            }
            Err(e) => skipped_items.push(skipped(
                STAGE,
                &row.file,
                SkipReason::Url,
                format!("aerial frame {}: {e:#}", row.image_id),
            )),
        }
    }
    let threads = rayon::current_num_threads().max(1);
    let read: Vec<(Result<AerialFrame, SkippedInput>, f64, f64)> = futures::stream::iter(chosen)
        .map(|w| read_frame(files, w))
        .buffered(concurrency.clamp(1, threads))
        .collect()
        .await;
    let (mut out, mut read_s, mut decode_s) = (Vec::new(), 0.0, 0.0);
    for (frame, r, d) in read {
        read_s += r;
        decode_s += d;
        match frame {
            Ok(f) => out.push(f),
            Err(s) => skipped_items.push(s),
        }
    }
    Ok(LoadedReference { reference: AerialReference::Frames(out), skipped: skipped_items, read_s, decode_s })
}

/// The box the ground points span (the owned panoramas' patch centres and the tile's centre).
fn bounds_of(ground: &[Point3<Map>]) -> BBox {
    let mut b = BBox {
        min_east: f64::INFINITY,
        min_north: f64::INFINITY,
        max_east: f64::NEG_INFINITY,
        max_north: f64::NEG_INFINITY,
    };
    for p in ground {
        b.min_east = b.min_east.min(p.x());
        b.min_north = b.min_north.min(p.y());
        b.max_east = b.max_east.max(p.x());
        b.max_north = b.max_north.max(p.y());
    }
    b
}

/// `fetch` grown by the reach's metres.
fn reach_box(fetch: BBox, reach: FrameReach) -> BBox {
    let m = reach.metres;
    BBox {
        min_east: fetch.min_east - m,
        min_north: fetch.min_north - m,
        max_east: fetch.max_east + m,
        max_north: fetch.max_north + m,
    }
}

/// The frame pixels that `area` covers at ground heights `heights` (lowest, highest; widened by 2 m), grown
/// by the reach's pixels and clipped to the frame; `None` when part of the area does not project (it lies
/// behind or beside the camera), which calls for the whole frame.
pub(crate) fn frame_window(
    camera: &Pinhole,
    pose: &MapFromCamera,
    area: &BBox,
    heights: (f64, f64),
    reach: FrameReach,
) -> Option<PixelWindow> {
    const STEPS: usize = 8;
    let (lo, hi) = (heights.0 - 2.0, heights.1 + 2.0);
    if !(lo.is_finite() && hi.is_finite() && area.min_east.is_finite() && area.max_east.is_finite()) {
        return None;
    }
    let to_camera = pose.inverse();
    let (mut u0, mut v0, mut u1, mut v1) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
    // The border of the box at both heights: the projection of a box's inside lies within its border's.
    for k in 0..=STEPS {
        let t = k as f64 / STEPS as f64;
        let e = area.min_east + t * (area.max_east - area.min_east);
        let n = area.min_north + t * (area.max_north - area.min_north);
        for (x, y) in [(e, area.min_north), (e, area.max_north), (area.min_east, n), (area.max_east, n)] {
            for z in [lo, hi] {
                let d = to_camera.transform_point(&Point3::new(x, y, z));
                if d.z() <= 0.0 {
                    return None;
                }
                let px = camera.project(&(d - Point3::origin()))?;
                (u0, v0, u1, v1) = (u0.min(px.u), v0.min(px.v), u1.max(px.u), v1.max(px.v));
            }
        }
    }
    let (w, h) = (f64::from(camera.width), f64::from(camera.height));
    let c0 = (u0 - reach.pixels).floor().clamp(0.0, w);
    let r0 = (v0 - reach.pixels).floor().clamp(0.0, h);
    let c1 = (u1 + reach.pixels).ceil().clamp(0.0, w);
    let r1 = (v1 + reach.pixels).ceil().clamp(0.0, h);
    (c1 > c0 && r1 > r0).then_some((c0 as usize, r0 as usize, (c1 - c0) as usize, (r1 - r0) as usize))
}

/// A frame to read.
pub(super) struct Wanted {
    pub id: String,
    pub pose: MapFromCamera,
    pub url: String,
    pub camera: Pinhole,
    /// `None`: the whole frame.
    pub window: Option<PixelWindow>,
}

/// Read one frame's window; the seconds reading and decoding it.
async fn read_frame(files: &Files, w: Wanted) -> (Result<AerialFrame, SkippedInput>, f64, f64) {
    let t0 = Instant::now();
    let head = match files.read_prefix(&w.url, MAGIC_BYTES).await {
        Ok((head, _)) => head,
        Err(e) => {
            let reason = if plumbline_runtime::is_invalid(&e) { SkipReason::Missing } else { SkipReason::Read };
            let detail = format!("{}: cannot be read: {e:#}", w.url);
            return (Err(skipped(STAGE, &w.url, reason, detail)), t0.elapsed().as_secs_f64(), 0.0);
        }
    };
    if is_tiled_raster(&head) {
        return read_tiled(files, w, t0).await;
    }
    let bytes = match read_one(files, &w.url, STAGE).await {
        Ok(b) => b,
        Err(s) => return (Err(s), t0.elapsed().as_secs_f64(), 0.0),
    };
    let read_s = t0.elapsed().as_secs_f64();
    let url = w.url.clone();
    let decoded = on_rayon(move || {
        let t1 = Instant::now();
        (decode_frame(&w, &bytes), t1.elapsed().as_secs_f64())
    })
    .await;
    match decoded {
        Ok((frame, decode_s)) => (frame, read_s, decode_s),
        Err(e) => (Err(skipped(STAGE, &url, SkipReason::Decode, format!("{url}: {e:#}"))), read_s, 0.0),
    }
}

/// A JPEG or PNG frame decoded whole to grey within [`AERIAL_FRAME_PIXELS`] and the interior orientation's
/// size (both checked on the header, before any pixel is decoded), then cropped to its window.
pub(super) fn decode_frame(w: &Wanted, bytes: &Bytes) -> Result<AerialFrame, SkippedInput> {
    let bounds = Bounds::budget(AERIAL_FRAME_PIXELS).expecting(w.camera.width, w.camera.height);
    let image = decode_gray(&w.url, bytes, &bounds).map_err(|e| {
        let mut s = refused(STAGE, &w.url, &e);
        if matches!(e, DecodeError::Size { .. }) {
            s.detail.push_str(" (the interior orientation's size)");
        }
        s
    })?;
    let (image, origin) = match w.window {
        Some((c0, r0, cw, ch)) => (GrayImage::from_fn(cw, ch, |c, r| image.get(c0 + c, r0 + r)), [c0, r0]),
        None => (image, [0, 0]),
    };
    Ok(AerialFrame { id: w.id.clone(), image, origin, camera: w.camera, pose: w.pose })
}

/// A tiled raster frame's window through GDAL: opened in place (local), over the network with range requests
/// (`s3://`), or from its fetched bytes (other stores).
async fn read_tiled(files: &Files, w: Wanted, t0: Instant) -> (Result<AerialFrame, SkippedInput>, f64, f64) {
    let input = match files.pixel_input(&w.url).await {
        Ok(input) => input,
        Err(e) => {
            let reason = if plumbline_runtime::is_invalid(&e) { SkipReason::Missing } else { SkipReason::Read };
            let detail = format!("{}: cannot be read: {e:#}", w.url);
            return (Err(skipped(STAGE, &w.url, reason, detail)), t0.elapsed().as_secs_f64(), 0.0);
        }
    };
    let read_s = t0.elapsed().as_secs_f64();
    let url = w.url.clone();
    let decoded = tokio::task::spawn_blocking(move || {
        let t1 = Instant::now();
        let frame = input
            .open(&w.url)
            .map_err(|e| skipped(STAGE, &w.url, SkipReason::Decode, e.to_string()))
            .and_then(|s| window_of_source(&s, &w));
        (frame, t1.elapsed().as_secs_f64())
    })
    .await;
    match decoded {
        // GDAL's reads happen while decoding: the blocking time is both; it is reported as decoding.
        Ok((frame, decode_s)) => (frame, read_s, decode_s),
        Err(e) => (Err(skipped(STAGE, &url, SkipReason::Decode, format!("worker task failed: {e}"))), read_s, 0.0),
    }
}

/// The frame's window from an open raster: the raster must have the interior orientation's size; the window
/// is at most [`WINDOW_PIXELS`].
fn window_of_source(source: &PixelSource, w: &Wanted) -> Result<AerialFrame, SkippedInput> {
    let (width, height) = source.size();
    let (cw, ch) = (w.camera.width as usize, w.camera.height as usize);
    if (width, height) != (cw, ch) {
        let detail = format!("{}: {width}×{height} px, the interior orientation says {cw}×{ch}", w.url);
        return Err(skipped(STAGE, &w.url, SkipReason::Size, detail));
    }
    let (c0, r0, ww, wh) = w.window.unwrap_or((0, 0, width, height));
    if ww.saturating_mul(wh) > WINDOW_PIXELS {
        let detail = format!(
            "{}: the tile needs a {ww}×{wh} px window of the frame, more than the budget of {:.1} M px",
            w.url,
            WINDOW_PIXELS as f64 / 1e6
        );
        return Err(skipped(STAGE, &w.url, SkipReason::Size, detail));
    }
    let decode = |e: String| skipped(STAGE, &w.url, SkipReason::Decode, e);
    let eight_bit = source.is_eight_bit().map_err(|e| decode(e.to_string()))?;
    let bands = source.read_f32((c0, r0, ww, wh), 3).map_err(|e| decode(e.to_string()))?;
    let image = gray_from_bands(ww, wh, &bands, eight_bit).map_err(|e| decode(format!("{}: {e}", w.url)))?;
    Ok(AerialFrame { id: w.id.clone(), image, origin: [c0, r0], camera: w.camera, pose: w.pose })
}

#[cfg(test)]
mod tests {
    use plumbline_geo::{OmegaPhiKappa, Pose};
    use plumbline_runtime::gdal_write::{Raster, RasterData, geotiff};
    use plumbline_runtime::{S3Options, Secret};
    use plumbline_testkit::{FlakyProxy, MotoServer};

    use super::*;

    const W: usize = 2048;
    const H: usize = 1536;

    /// A noisy 16-bit 4-band (RGB + NIR) frame of 12-bit data: deflate cannot shrink it much.
    fn frame_bands() -> Vec<Vec<u16>> {
        (0..4u64)
            .map(|b| {
                (0..(W * H) as u64)
                    .map(|k| {
                        let x = (k ^ (b << 40)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                        ((x >> 52) as u16) + 200
                    })
                    .collect()
            })
            .collect()
    }

    fn frame_tiff(bands: &[Vec<u16>]) -> Vec<u8> {
        let raster = Raster {
            width: W,
            height: H,
            geotransform: [0.0, 1.0, 0.0, 0.0, 0.0, -1.0],
            epsg: 25832,
            data: RasterData::U16(bands.to_vec()),
            nodata: None,
        };
        geotiff(&raster).unwrap()
    }

    /// A camera of the frame's size looking straight down from 500 m.
    fn wanted(url: &str, window: Option<PixelWindow>) -> Wanted {
        let camera =
            Pinhole::new(W as u32, H as u32, 2000.0, 2000.0, W as f64 / 2.0, H as f64 / 2.0, 0.0, 0.0).unwrap();
        let pose = Pose::new(OmegaPhiKappa::from_degrees(0.0, 0.0, 0.0).to_rotation(), Point3::new(0.0, 0.0, 500.0));
        Wanted { id: "f1".into(), pose, url: url.into(), camera, window }
    }

    fn expected(bands: &[Vec<u16>], (c0, r0, w, h): PixelWindow) -> GrayImage {
        let cut: Vec<Vec<f32>> = bands[..3]
            .iter()
            .map(|b| (0..w * h).map(|k| f32::from(b[(r0 + k / w) * W + c0 + k % w])).collect())
            .collect();
        gray_from_bands(w, h, &cut, false).unwrap()
    }

    /// A 16-bit 4-band tiled GeoTIFF frame is read as the window the tile needs — in place from a
    /// local file and with range requests from an S3 store, which transfer a fraction of the file — and both
    /// give the window's grey values (luma of RGB, NIR ignored, stretched to 0–255).
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn tiled_16_bit_frames_are_read_a_window_at_a_time_locally_and_from_s3() {
        let bands = frame_bands();
        let tiff = frame_tiff(&bands);
        let window = (700, 500, 300, 200);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f1.tif");
        std::fs::write(&path, &tiff).unwrap();
        let (local, _, _) = read_frame(&Files::default(), wanted(path.to_str().unwrap(), Some(window))).await;
        let local = local.unwrap();
        assert_eq!((local.origin, local.image.width(), local.image.height()), ([700, 500], 300, 200));
        assert_eq!(local.image, expected(&bands, window));

        let moto = MotoServer::start();
        moto.create_bucket("frames");
        let proxy = FlakyProxy::start(moto.endpoint().trim_start_matches("http://"));
        let s3 = S3Options {
            endpoint: Some(proxy.endpoint()),
            region: Some("eu-central-1".to_owned()),
            access_key_id: Some("plumbline-test".to_owned()),
            secret_access_key: Some(Secret::new("plumbline-test-secret")),
            allow_http: true,
            virtual_hosted_style: false,
        };
        let files = Files::new(s3);
        files.write("s3://frames/block/f1.tif", tiff.clone()).await.unwrap();
        let before = proxy.downstream_bytes();
        let (remote, _, _) = read_frame(&files, wanted("s3://frames/block/f1.tif", Some(window))).await;
        let transferred = proxy.downstream_bytes() - before;
        let remote = remote.unwrap();
        assert_eq!(remote.origin, local.origin);
        assert_eq!(remote.image, local.image);
        // Four 256² tiles of 4 × 16 bit of the 48 the frame has, the header and the HTTP overhead.
        assert!((transferred as f64) < 0.25 * tiff.len() as f64, "{transferred} of {} bytes read", tiff.len());
    }

    /// A frame of another size than its interior orientation, or one whose window exceeds the budget, is
    /// skipped for its size naming the file; a file that is no raster is undecodable.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn frames_of_the_wrong_size_or_too_large_a_window_are_skipped_for_their_size() {
        let bands = frame_bands();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f1.tif");
        std::fs::write(&path, frame_tiff(&bands)).unwrap();
        let url = path.to_str().unwrap();
        let mut smaller = wanted(url, Some((0, 0, 10, 10)));
        smaller.camera.width = 1000;
        let (frame, _, _) = read_frame(&Files::default(), smaller).await;
        let s = frame.unwrap_err();
        assert_eq!(s.reason, SkipReason::Size);
        assert!(
            s.detail.contains("2048×1536") && s.detail.contains("1000×1536") && s.detail.contains(url),
            "{}",
            s.detail
        );
        let broken = dir.path().join("broken.tif");
        let mut bytes = frame_tiff(&bands)[..4096].to_vec();
        bytes.extend_from_slice(&[0xFF; 64]);
        std::fs::write(&broken, bytes).unwrap();
        let (frame, _, _) = read_frame(&Files::default(), wanted(broken.to_str().unwrap(), Some((0, 0, 10, 10)))).await;
        assert_eq!(frame.unwrap_err().reason, SkipReason::Decode);
    }

    /// The window covers every point of the area at the ground heights (the projection of its border), grown
    /// by the reach's pixels, and is clipped to the frame; an area behind the camera or where it does not image
    /// asks for the whole frame.
    #[test]
    fn the_window_covers_the_area_and_its_margin_and_nothing_far_beyond() {
        let w = wanted("f1.tif", None);
        let reach = FrameReach { metres: 0.0, pixels: 20.0 };
        let area = BBox { min_east: -20.0, min_north: -10.0, max_east: 30.0, max_north: 15.0 };
        let (c0, r0, ww, wh) = frame_window(&w.camera, &w.pose, &area, (0.0, 3.0), reach).unwrap();
        let to_camera = w.pose.inverse();
        for (e, n, z) in [(-20.0, -10.0, 0.0), (30.0, 15.0, 3.0), (5.0, 2.0, 1.0), (-20.0, 15.0, 3.0)] {
            let d = to_camera.transform_point(&Point3::new(e, n, z)) - Point3::origin();
            let px = w.camera.project(&d).unwrap();
            assert!(px.u >= (c0 + 20) as f64 && px.u <= (c0 + ww - 20) as f64, "{px:?} {c0} {ww}");
            assert!(px.v >= (r0 + 20) as f64 && px.v <= (r0 + wh - 20) as f64, "{px:?} {r0} {wh}");
        }
        // 50 m × 25 m at 500 m with f = 2000 px: about 200 × 100 px (+ the heights), plus 2 × 20 px.
        assert!(ww < 260 && wh < 160, "{ww}×{wh}");
        // Half of a wider area lies in the frame: the window is clipped to the frame's border there.
        let wide = BBox { min_east: 0.0, min_north: -10.0, max_east: 400.0, max_north: 15.0 };
        let (c0, _, ww, _) = frame_window(&w.camera, &w.pose, &wide, (0.0, 3.0), reach).unwrap();
        assert_eq!(c0 + ww, W);
        // An area reaching where the camera model does not image (a kilometre off at 500 m): the whole frame.
        let huge = BBox { min_east: -1000.0, min_north: -1000.0, max_east: 1000.0, max_north: 1000.0 };
        assert_eq!(frame_window(&w.camera, &w.pose, &huge, (0.0, 0.0), reach), None);
        let above = frame_window(&w.camera, &w.pose, &area, (600.0, 600.0), reach);
        assert_eq!(above, None);
    }
}
