//! A tile's panoramas streamed through step 1 and the KAZE features (paper 000 §3.2–§3.3): read a few at a
//! time, decoded and prepared as at most one rayon job per rayon thread, the full panorama dropped as soon
//! as its ortho patch and features exist. Only owned panoramas and the context panoramas an owned one
//! pairs with are read; a needed panorama that cannot be read is skipped and the pairing asked again.

use std::collections::HashSet;
use std::sync::Arc;
use std::time::Instant;

use bytes::Bytes;
use futures::StreamExt as _;
use plumbline_registration::PipelineConfig;
use plumbline_registration::mm::{MmConfig, PanoramaRig};
use plumbline_registration::pipeline::{PreparedPanorama, panoramas_to_prepare, prepare_panorama};
use plumbline_runtime::Files;
use plumbline_scheduler::SkippedInput;

use crate::fetch::{on_rayon, read_one};
use crate::panoramas::{Placed, STAGE, decode};

/// A tile's panoramas after step 1.
pub(crate) struct PreparedTile {
    /// Every placed panorama that could be read (when needed), prepared or not, in the placed order.
    pub panoramas: Vec<PreparedPanorama>,
    /// Needed panoramas that could not be read or decoded.
    pub skipped: Vec<SkippedInput>,
    /// Seconds of the reads, summed (they overlap each other and the decoding).
    pub read_s: f64,
    /// Thread-seconds decoding.
    pub decode_s: f64,
}

/// What streaming one panorama gave.
struct Streamed {
    index: usize,
    prepared: Result<PreparedPanorama, SkippedInput>,
    read_s: f64,
    decode_s: f64,
}

/// Prepare what the tile's registration needs of `placed` (owned panoramas and their neighbours), every
/// panorama of size `size`. At most `concurrency` reads and `rayon::current_num_threads()` decoded panoramas
/// are in flight at once.
pub(crate) async fn prepare(
    files: &Files,
    placed: &[Placed],
    rig: &Arc<PanoramaRig>,
    config: &PipelineConfig,
    size: (u32, u32),
    concurrency: usize,
) -> anyhow::Result<PreparedTile> {
    let mut out = PreparedTile { panoramas: Vec::new(), skipped: Vec::new(), read_s: 0.0, decode_s: 0.0 };
    let mut done: Vec<Option<PreparedPanorama>> = vec![None; placed.len()];
    let mut failed = HashSet::new();
    loop {
        let alive: Vec<usize> = (0..placed.len()).filter(|k| !failed.contains(k)).collect();
        let infos: Vec<_> = alive.iter().map(|&k| placed[k].info.clone()).collect();
        let needed = panoramas_to_prepare(&infos, rig, config);
        let todo: Vec<usize> =
            alive.iter().zip(needed).filter(|&(&k, need)| need && done[k].is_none()).map(|(&k, _)| k).collect();
        if todo.is_empty() {
            break;
        }
        for s in stream(files, placed, &todo, rig, config, size, concurrency).await? {
            out.read_s += s.read_s;
            out.decode_s += s.decode_s;
            match s.prepared {
                Ok(p) => done[s.index] = Some(p),
                Err(skip) => {
                    failed.insert(s.index);
                    out.skipped.push(skip);
                }
            }
        }
    }
    out.panoramas = done
        .into_iter()
        .enumerate()
        .filter(|(k, _)| !failed.contains(k))
        .map(|(k, p)| p.unwrap_or_else(|| PreparedPanorama::unprepared(placed[k].info.clone())))
        .collect();
    Ok(out)
}

/// Read, decode and prepare `todo` (indices into `placed`), in order.
async fn stream(
    files: &Files,
    placed: &[Placed],
    todo: &[usize],
    rig: &Arc<PanoramaRig>,
    config: &PipelineConfig,
    size: (u32, u32),
    concurrency: usize,
) -> anyhow::Result<Vec<Streamed>> {
    let threads = rayon::current_num_threads().max(1);
    futures::stream::iter(todo.iter().copied())
        .map(|k| {
            // A task of its own, so that the read proceeds (and is timed) while the decoders are busy.
            let (files, url) = (files.clone(), placed[k].url.clone());
            let read = tokio::spawn(async move {
                let t0 = Instant::now();
                (read_one(&files, &url, STAGE).await, t0.elapsed().as_secs_f64())
            });
            async move { read.await.map(|(bytes, read_s)| (k, bytes, read_s)) }
        })
        .buffered(concurrency.max(1))
        .map(|read| {
            let read = read.map_err(|e| anyhow::anyhow!("worker task failed: {e}"));
            let (rig, mm) = (Arc::clone(rig), config.mm);
            async move {
                let (k, bytes, read_s) = read?;
                let one = placed[k].clone();
                let (prepared, decode_s) = match bytes {
                    Ok(bytes) => on_rayon(move || decode_and_prepare(&one, bytes, &rig, &mm, size)).await?,
                    Err(s) => (Err(s), 0.0),
                };
                anyhow::Ok(Streamed { index: k, prepared, read_s, decode_s })
            }
        })
        .buffered(threads)
        .collect::<Vec<_>>()
        .await
        .into_iter()
        .collect()
}

/// Decode one panorama (timed), prepare it and drop its pixels.
fn decode_and_prepare(
    one: &Placed,
    bytes: Bytes,
    rig: &PanoramaRig,
    mm: &MmConfig,
    size: (u32, u32),
) -> (Result<PreparedPanorama, SkippedInput>, f64) {
    let t0 = Instant::now();
    let pano = decode(one, &bytes, size);
    drop(bytes);
    let decode_s = t0.elapsed().as_secs_f64();
    (pano.map(|p| prepare_panorama(&p, one.info.owned, rig, mm)), decode_s)
}

#[cfg(test)]
mod tests {
    use plumbline_geo::camera::Equirectangular;
    use plumbline_geo::dg::{Boresight, CameraMount};
    use plumbline_geo::{MapFromBody, Point3, Rotation};
    use plumbline_registration::pipeline::PanoramaInfo;
    use plumbline_testkit::images::{png_bomb, png_claiming};

    use super::*;

    /// A textured 256 × 128 panorama as JPEG.
    fn jpeg() -> Vec<u8> {
        let img = image::RgbImage::from_fn(256, 128, |x, y| {
            let v = ((x * 37 + y * 91) % 251) as u8;
            image::Rgb([v, v / 2, 255 - v])
        });
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Jpeg).unwrap();
        out.into_inner()
    }

    /// Issue 18: among a tile's panoramas, a forged 20000² header and a real 12000² decompression bomb are
    /// skipped for their size (nothing allocated for their pixels) while the others are decoded and prepared.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn bomb_panoramas_are_skipped_with_their_reason_and_the_others_are_prepared() {
        let dir = tempfile::tempdir().unwrap();
        let files = [
            ("p1.jpg", jpeg()),
            ("p2.png", png_claiming(20_000, 20_000)),
            ("p3.jpg", jpeg()),
            ("p4.png", png_bomb(12_000, 12_000)),
            ("p5.jpg", jpeg()),
        ];
        let placed: Vec<Placed> = files
            .iter()
            .enumerate()
            .map(|(k, (name, bytes))| {
                let path = dir.path().join(name);
                std::fs::write(&path, bytes).unwrap();
                let pose = MapFromBody::new(Rotation::identity(), Point3::new(500.0 + 5.0 * k as f64, 800.0, 40.0));
                let id = name.trim_end_matches(".jpg").trim_end_matches(".png").to_owned();
                let info = PanoramaInfo { id, time: k as f64, pose, position_sigma: 0.2, owned: true };
                Placed { url: path.to_str().unwrap().to_owned(), info }
            })
            .collect();
        let rig = Arc::new(PanoramaRig {
            camera: Equirectangular::new(256, 128).unwrap(),
            mount: CameraMount::new([0.0, 0.0, 0.0], &Boresight::from_degrees(0.0, 0.0, 0.0)),
            vehicle_mask: None,
            camera_height: 2.5,
        });
        let mut config = PipelineConfig::default();
        config.mm.half_extent = 3.0;
        let out = prepare(&Files::default(), &placed, &rig, &config, (256, 128), 2).await.unwrap();
        let ids: Vec<&str> = out.panoramas.iter().map(PreparedPanorama::id).collect();
        assert_eq!(ids, ["p1", "p3", "p5"]);
        assert!(out.panoramas.iter().all(PreparedPanorama::is_prepared));
        let skipped: Vec<(&str, &str)> = out.skipped.iter().map(|s| (s.item.as_str(), s.reason.as_str())).collect();
        assert_eq!(skipped, [(placed[1].url.as_str(), "size"), (placed[3].url.as_str(), "size")]);
        for (s, claim) in out.skipped.iter().zip(["20000 × 20000 px", "12000 × 12000 px"]) {
            assert_eq!(s.stage, STAGE);
            assert!(s.detail.contains(&s.item) && s.detail.contains(claim), "{}", s.detail);
            assert!(s.detail.contains("exceeds the pixel budget of 134.2 M px"), "{}", s.detail);
        }
    }
}
