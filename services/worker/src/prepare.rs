//! A tile's panoramas streamed through step 1, the KAZE features (Jende et al. 2017 §3.2–§3.3) and the registration,
//! one stretch of the drive at a time: the owned panoramas are taken in time order, [`SEGMENT`] at a
//! time; the segment's panoramas and their neighbours are read a few at a time, decoded and prepared (at
//! most one rayon job per rayon thread, the full panorama dropped as soon as its ortho patch and features
//! exist), the segment's pairs are registered, and every patch no later pair needs is released. A tile
//! holds the patches of about one segment, however many panoramas it owns (a drive looping through it).
//! A needed panorama that cannot be read is skipped and the pairing asked again.

use std::collections::HashSet;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Instant;

use bytes::Bytes;
use futures::StreamExt as _;
use plumbline_campaign::SkippedInput;
use plumbline_campaign::Stage;
use plumbline_campaign::progress::Progress;
use plumbline_geo::tiling::TileId;
use plumbline_registration::aerial::AerialReference;
use plumbline_registration::mm::{MmConfig, PanoramaRig, patch_part};
use plumbline_registration::output::ImageDiagnostic;
use plumbline_registration::pipeline::{
    PreparedPanorama, TileInputs, TileRegistration, panoramas_to_prepare_for, prepare_panorama, time_order,
};
use plumbline_registration::{PipelineConfig, TileRun};
use plumbline_runtime::Files;

use crate::fetch::{counted, on_rayon, read_one};
use crate::panoramas::{Placed, STAGE, decode};

/// Owned panoramas registered together: their patches, their neighbours' and the segment before's last are
/// what a tile holds (about 5 MB each at the default 3 cm over 28 m).
pub(crate) const SEGMENT: usize = 16;

/// A tile's registration and what preparing its panoramas cost.
pub(crate) struct RegisteredTile {
    /// The registration (`TileRegistration::finish`).
    pub run: TileRun,
    /// Needed panoramas that could not be read or decoded.
    pub skipped: Vec<SkippedInput>,
    /// Seconds of the reads, summed (they overlap each other and the decoding).
    pub read_s: f64,
    /// Thread-seconds decoding.
    pub decode_s: f64,
    /// Most prepared patches held at once.
    pub most_held: usize,
}

/// What streaming one panorama gave.
struct Streamed {
    index: usize,
    prepared: Result<PreparedPanorama, SkippedInput>,
    read_s: f64,
    decode_s: f64,
}

/// Everything the segments share.
pub(crate) struct Tile<'a> {
    pub files: &'a Files,
    pub id: TileId,
    pub placed: &'a [Placed],
    pub rig: &'a Arc<PanoramaRig>,
    pub config: &'a PipelineConfig,
    pub concurrency: usize,
}

/// Prepare and register the tile's owned panoramas segment by segment against `reference`; stage
/// `registration` of `progress` advances by one per registered panorama.
pub(crate) async fn register(
    tile: &Tile<'_>,
    reference: Arc<AerialReference>,
    progress: &dyn Progress,
) -> plumbline_runtime::Result<RegisteredTile> {
    let placed = tile.placed;
    let mut done: Vec<Option<PreparedPanorama>> = vec![None; placed.len()];
    // Through step 1 (successfully or not), whether its patch is still held or already released.
    let mut ready = vec![false; placed.len()];
    let mut failed = HashSet::new();
    let (mut skipped, mut read_s, mut decode_s, mut most_held) = (Vec::new(), 0.0, 0.0, 0);
    let by_time = time_order(placed, |p| (p.info.time, p.info.id.as_str()));
    let owned: Vec<usize> = by_time.iter().copied().filter(|&k| placed[k].info.owned).collect();
    let mut registration = TileRegistration::new(tile.id);
    let segments: Vec<&[usize]> = owned.chunks(SEGMENT).collect();
    for (s, segment) in segments.iter().enumerate() {
        let ids: Vec<String> = segment.iter().map(|&k| placed[k].info.id.clone()).collect();
        // Prepare the segment's panoramas and their neighbours; a failure may change a neighbour: ask again.
        loop {
            let alive: Vec<usize> = (0..placed.len()).filter(|k| !failed.contains(k)).collect();
            let infos: Vec<_> = alive.iter().map(|&k| placed[k].info.clone()).collect();
            let id_refs: Vec<&str> = ids.iter().map(String::as_str).collect();
            let needed = panoramas_to_prepare_for(&infos, &id_refs, tile.rig, tile.config);
            let todo: Vec<usize> =
                alive.iter().zip(needed).filter(|&(&k, need)| need && !ready[k]).map(|(&k, _)| k).collect();
            if todo.is_empty() {
                break;
            }
            for st in stream(tile, &todo).await? {
                read_s += st.read_s;
                decode_s += st.decode_s;
                match st.prepared {
                    Ok(p) => {
                        done[st.index] = Some(p);
                        ready[st.index] = true;
                    }
                    Err(skip) => {
                        failed.insert(st.index);
                        skipped.push(skip);
                    }
                }
            }
        }
        most_held = most_held.max(done.iter().flatten().filter(|p| p.error().is_none() && p.is_prepared()).count());
        let alive: Vec<usize> = (0..placed.len()).filter(|k| !failed.contains(k)).collect();
        let panoramas: Vec<PreparedPanorama> = alive.iter().map(|&k| taken(&mut done, placed, k)).collect();
        let (config, rig, reference_run) = (*tile.config, Arc::clone(tile.rig), Arc::clone(&reference));
        let (back, panoramas) = counted(progress, Stage::Registration, move |count| {
            let inputs = TileInputs { rig: &rig, reference: &reference_run, config: &config };
            let id_refs: Vec<&str> = ids.iter().map(String::as_str).collect();
            let counted = |_: &ImageDiagnostic| {
                count.fetch_add(1, Ordering::Relaxed);
            };
            registration.register(&panoramas, &id_refs, &inputs, &counted);
            (registration, panoramas)
        })
        .await?;
        registration = back;
        for (k, p) in alive.iter().zip(panoramas) {
            done[*k] = Some(p);
        }
        // Release every patch before the next segment's first owned panorama's previous one.
        if let Some(next) = segments.get(s + 1).and_then(|n| n.first()) {
            let live: Vec<usize> = by_time.iter().copied().filter(|k| !failed.contains(k)).collect();
            let keep_from = live.iter().position(|k| k == next).unwrap_or(0);
            for &k in &live[..keep_from.saturating_sub(1)] {
                if let Some(p) = done[k].as_mut() {
                    p.release();
                }
            }
        }
    }
    let panoramas: Vec<PreparedPanorama> =
        (0..placed.len()).filter(|k| !failed.contains(k)).map(|k| taken(&mut done, placed, k)).collect();
    let config = *tile.config;
    let run = on_rayon(move || registration.finish(&panoramas, &config)).await?;
    Ok(RegisteredTile { run, skipped, read_s, decode_s, most_held })
}

/// The panorama at `k`, prepared or a placeholder, taken out of `done`.
fn taken(done: &mut [Option<PreparedPanorama>], placed: &[Placed], k: usize) -> PreparedPanorama {
    done[k].take().unwrap_or_else(|| PreparedPanorama::unprepared(placed[k].info.clone()))
}

/// Read, decode and prepare `todo` (indices into the tile's placed panoramas), in order.
async fn stream(tile: &Tile<'_>, todo: &[usize]) -> plumbline_runtime::Result<Vec<Streamed>> {
    let (files, placed, rig, config, concurrency) = (tile.files, tile.placed, tile.rig, tile.config, tile.concurrency);
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
            let read = read.map_err(plumbline_runtime::Error::from);
            let (rig, mm) = (Arc::clone(rig), config.mm);
            async move {
                let (k, bytes, read_s) = read?;
                let one = placed[k].clone();
                let (prepared, decode_s) = match bytes {
                    Ok(bytes) => on_rayon(move || decode_and_prepare(&one, bytes, &rig, &mm)).await?,
                    Err(s) => (Err(s), 0.0),
                };
                Ok::<_, plumbline_runtime::Error>(Streamed { index: k, prepared, read_s, decode_s })
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
) -> (Result<PreparedPanorama, SkippedInput>, f64) {
    let t0 = Instant::now();
    let part = patch_part(&one.info.pose, rig, mm.gsd, mm.half_extent);
    let pano = decode(one, &bytes, &part);
    drop(bytes);
    let decode_s = t0.elapsed().as_secs_f64();
    (pano.map(|p| prepare_panorama(&p, one.info.owned, rig, mm)), decode_s)
}

#[cfg(test)]
mod tests {
    use plumbline_campaign::SkipReason;
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

    /// Register `placed` (256 × 128 panoramas, 3 m patches) with no aerial frame: every panorama is prepared
    /// and paired, and discarded after step 4 for want of aerial images.
    async fn register_without_reference(placed: &[Placed]) -> RegisteredTile {
        let rig = Arc::new(PanoramaRig {
            camera: Equirectangular::new(256, 128).unwrap(),
            mount: CameraMount::new([0.0, 0.0, 0.0], &Boresight::from_degrees(0.0, 0.0, 0.0)),
            vehicle_mask: None,
            camera_height: 2.5,
            sub_cameras: None,
            terrain: None,
            readout_s: 0.0,
        });
        let mut config = PipelineConfig::default();
        config.mm.half_extent = 3.0;
        let tile = Tile {
            files: &Files::default(),
            id: TileId { col: 0, row: 0 },
            placed,
            rig: &rig,
            config: &config,
            concurrency: 2,
        };
        let reference = Arc::new(AerialReference::Frames(Vec::new()));
        register(&tile, reference, &plumbline_campaign::progress::NoProgress).await.unwrap()
    }

    /// Among a tile's panoramas, a forged 20000² header and a real 12000² decompression bomb are
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
                let info = PanoramaInfo { id, time: k as f64, pose, position_sigma: 0.2, velocity: None, owned: true };
                Placed { url: path.to_str().unwrap().to_owned(), info }
            })
            .collect();
        let out = register_without_reference(&placed).await;
        let plumbline_registration::TileResult::V1(result) = &out.run.result;
        let ids: Vec<&str> = result.images.iter().map(|d| d.image.as_str()).collect();
        assert_eq!(ids, ["p1", "p3", "p5"]);
        // Each was prepared: what stopped it came after step 1 (no aerial frame), not a missing patch.
        assert!(result.images.iter().all(|d| !format!("{:?}", d.discarded).contains("not prepared")), "{result:?}");
        let skipped: Vec<(&str, &SkipReason)> = out.skipped.iter().map(|s| (s.item.as_str(), &s.reason)).collect();
        assert_eq!(skipped, [(placed[1].url.as_str(), &SkipReason::Size), (placed[3].url.as_str(), &SkipReason::Size)]);
        for (s, claim) in out.skipped.iter().zip(["20000 × 20000 px", "12000 × 12000 px"]) {
            assert_eq!(s.stage, STAGE);
            assert!(s.detail.contains(&s.item) && s.detail.contains(claim), "{}", s.detail);
            assert!(s.detail.contains("exceeds the pixel budget of 134.2 M px"), "{}", s.detail);
        }
    }

    /// `n` owned panoramas 2 m apart along a street, as JPEG files under `dir`.
    fn street(dir: &std::path::Path, n: usize) -> Vec<Placed> {
        let bytes = jpeg();
        (0..n)
            .map(|k| {
                let path = dir.join(format!("s{k:03}.jpg"));
                std::fs::write(&path, &bytes).unwrap();
                let pose = MapFromBody::new(Rotation::identity(), Point3::new(500.0 + 2.0 * k as f64, 800.0, 40.0));
                let info = PanoramaInfo {
                    id: format!("s{k:03}"),
                    time: k as f64,
                    pose,
                    position_sigma: 0.2,
                    velocity: None,
                    owned: true,
                };
                Placed { url: path.to_str().unwrap().to_owned(), info }
            })
            .collect()
    }

    /// A tile holds the prepared patches of about one segment whether it owns 40 or 160 panoramas
    /// (a drive looping through a tile), and every owned panorama is still registered.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn prepared_patches_held_do_not_grow_with_the_panoramas_of_a_tile() {
        let dir = tempfile::tempdir().unwrap();
        let mut held = Vec::new();
        for n in [40, 160] {
            let placed = street(dir.path(), n);
            let out = register_without_reference(&placed).await;
            let plumbline_registration::TileResult::V1(result) = &out.run.result;
            assert_eq!(result.images.len(), n);
            assert!(out.skipped.is_empty(), "{:?}", out.skipped);
            // Every pair had both patches: nothing failed for a panorama that was not (or no longer) prepared.
            let unprepared = result.images.iter().filter(|d| format!("{:?}", d.discarded).contains("ortho/features"));
            assert_eq!(unprepared.count(), 0, "{:?}", result.images);
            held.push(out.most_held);
        }
        // A segment, its next neighbour and the previous segment's last.
        assert!(held.iter().all(|&h| h <= SEGMENT + 2), "{held:?}");
        assert_eq!(held[0], held[1], "{held:?}");
    }
}
