//! The pole side of a tile (Meyer et al. 2023): its depth images read with their DG records, the cadastre objects
//! around it, and a `plumbline_poles::PoleStream` per depth camera fed batch by batch; the point clouds'
//! slices of the tile (module `clouds`) are matched against the same cadastre objects.

use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::time::Instant;

use bytes::Bytes;
use plumbline_campaign::manifest::{Cadastre, DepthCamera};
use plumbline_campaign::progress::Progress;
use plumbline_campaign::{CadastreDiagnostic, CadastreFeature, Consequence};
use plumbline_campaign::{Campaign, SkippedInput};
use plumbline_campaign::{SkipReason, Stage};
use plumbline_geo::TrajectoryRecord;
use plumbline_geo::tiling::{BBox, TileId};
use plumbline_poles::{DepthFrame, FrameReport, PoleConfig, PoleStream};
use plumbline_runtime::Files;
use plumbline_runtime::cadastre::{CadastreSource, read_cadastre};

use futures::StreamExt as _;

use crate::fetch::{blocking, reason_of_store, skipped};
use crate::output::PoleResults;
use crate::panoramas::dg_at;

/// Cadastre objects are read this far beyond the tile's fetch box plus the depth range, metres (DG error).
const CADASTRE_MARGIN_M: f64 = 5.0;

/// A depth image the tile wants, with its DG record.
#[derive(Clone)]
struct Wanted {
    id: String,
    /// Where the image is read from, also for messages.
    url: String,
    dg: TrajectoryRecord,
}

/// Depth images read and decoded per batch: a batch is read while the one before is decoded, and a
/// [`PoleStream`] drops each frame's points once detected, so a tile holds two batches of images and a few
/// frames of points whatever the number of its depth images.
fn batch_size() -> usize {
    (4 * rayon::current_num_threads()).max(8)
}

/// Detect and match the poles of a tile's depth images; stage `poles` of `progress` advances by one per depth
/// image (per batch as it is decoded; skipped when it could not be read).
pub(crate) async fn process(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    fetch: &BBox,
    config: &PoleConfig,
    concurrency: usize,
    progress: &dyn Progress,
) -> plumbline_runtime::Result<PoleResults> {
    let mut out = PoleResults::default();
    let depth = campaign.plan.depth_of(tile);
    let clouds = !campaign.manifest.point_clouds.is_empty();
    let depth_here = !depth.is_empty() && !campaign.manifest.depth.is_empty();
    if !depth_here {
        progress.skip(Stage::Poles, depth.len() as u64);
    }
    if !depth_here && !clouds {
        return Ok(out);
    }
    let t0 = Instant::now();
    let range = campaign
        .manifest
        .depth
        .iter()
        .map(|c| c.intrinsics.max_range_m)
        .fold(config.detect.max_range_m.max(config.clouds.reliable_range_m), f64::max);
    let features = cadastre_features(files, campaign, fetch, range + CADASTRE_MARGIN_M, &mut out.skipped).await?;
    out.read_s = t0.elapsed().as_secs_f64();
    let features = Arc::new(features);
    if clouds {
        crate::clouds::process(files, campaign, tile, fetch, config, &features, &mut out).await?;
    }
    if !depth_here {
        return Ok(out);
    }
    let wanted = wanted_frames(campaign, depth, &mut out.skipped);
    let listed: usize = wanted.values().map(Vec::len).sum();
    progress.skip(Stage::Poles, depth.len().saturating_sub(listed) as u64);
    let urls: HashMap<String, String> = wanted.values().flatten().map(|w| (w.id.clone(), w.url.clone())).collect();
    for (camera, frames) in wanted {
        let Some(spec) = campaign.manifest.depth.get(camera).cloned() else {
            progress.skip(Stage::Poles, frames.len() as u64);
            continue;
        };
        let stream = stream_camera(files, spec, &frames, config, concurrency, progress, &mut out).await?;
        let t1 = Instant::now();
        let features = Arc::clone(&features);
        let output = blocking(move || stream.finish(&features)).await?;
        out.process_s += t1.elapsed().as_secs_f64();
        out.updates.extend(output.updates);
        out.reports.extend(output.reports);
    }
    out.skipped.extend(out.reports.iter().filter_map(|FrameReport::V1(r)| {
        let problem = r.problem.as_ref()?;
        let item = urls.get(&r.frame).unwrap_or(&r.frame);
        Some(skipped(Stage::Poles, item, SkipReason::Frame, format!("depth frame {} ({item}): {problem}", r.frame)))
    }));
    Ok(out)
}

/// One camera's depth images (in time order) through a [`PoleStream`], batch by batch; an image that cannot
/// be read is skipped.
async fn stream_camera(
    files: &Files,
    spec: DepthCamera,
    frames: &[Wanted],
    config: &PoleConfig,
    concurrency: usize,
    progress: &dyn Progress,
    out: &mut PoleResults,
) -> plumbline_runtime::Result<PoleStream> {
    let spec = Arc::new(spec);
    let mut stream = PoleStream::new(config);
    let mut batches = frames.chunks(batch_size());
    let mut reading = batches.next().map(|b| read_batch(files, b, concurrency));
    while let Some(batch) = reading.take() {
        let (read, read_s) = batch.await?;
        // The next batch is read while this one is decoded.
        reading = batches.next().map(|b| read_batch(files, b, concurrency));
        out.read_s += read_s;
        let mut readable = Vec::with_capacity(read.len());
        for (wanted, png) in read {
            match png {
                Ok(png) => readable.push((wanted, png)),
                Err(s) => {
                    progress.skip(Stage::Poles, 1);
                    out.skipped.push(s);
                }
            }
        }
        let count = readable.len() as u64;
        let (spec, t1) = (Arc::clone(&spec), Instant::now());
        stream = blocking(move || {
            let refs: Vec<DepthFrame<'_>> =
                readable.iter().map(|(w, png)| DepthFrame { id: &w.id, png, dg: &w.dg }).collect();
            stream.push_depth(&spec, &refs);
            stream
        })
        .await?;
        out.process_s += t1.elapsed().as_secs_f64();
        progress.advance(Stage::Poles, count);
    }
    Ok(stream)
}

/// A batch of depth images and the seconds reading them took.
type ReadBatch = (Vec<(Wanted, Result<Bytes, SkippedInput>)>, f64);

/// Read a batch of depth images on a task of its own, so that it proceeds while the batch before is decoded.
fn read_batch(files: &Files, batch: &[Wanted], concurrency: usize) -> tokio::task::JoinHandle<ReadBatch> {
    let (files, batch) = (files.clone(), batch.to_vec());
    tokio::spawn(async move {
        let t0 = Instant::now();
        let read = futures::stream::iter(batch.into_iter().map(move |w| {
            let files = files.clone();
            async move {
                let png = crate::fetch::read_one(&files, &w.url, Stage::Poles).await;
                (w, png)
            }
        }))
        .buffered(concurrency.max(1))
        .collect()
        .await;
        (read, t0.elapsed().as_secs_f64())
    })
}

/// The tile's depth images by camera, in time order; images of an unknown camera, outside their images
/// prefix or at times off the trajectory are skipped.
fn wanted_frames(
    campaign: &Campaign,
    depth: &[usize],
    skipped_items: &mut Vec<SkippedInput>,
) -> BTreeMap<usize, Vec<Wanted>> {
    let mut by_camera: BTreeMap<usize, Vec<Wanted>> = BTreeMap::new();
    for image in depth.iter().filter_map(|&k| campaign.plan.depth.get(k)) {
        let Some(camera) = campaign.manifest.depth.get(image.camera) else {
            let detail = format!("depth image {}: camera {} is not in the manifest", image.image_id, image.camera);
            skipped_items.push(skipped(Stage::Poles, &image.file, SkipReason::Camera, detail));
            continue;
        };
        let url = match campaign.file_url(&camera.images, &image.file) {
            Ok(url) => url,
            Err(e) => {
                skipped_items.push(skipped(Stage::Poles, &image.file, SkipReason::Url, format!("{e:#}")));
                continue;
            }
        };
        match dg_at(campaign, image.time) {
            Ok(dg) => by_camera.entry(image.camera).or_default().push(Wanted { id: image.image_id.clone(), url, dg }),
            Err(e) => skipped_items.push(skipped(Stage::Poles, &url, SkipReason::Time, format!("{url}: {e}"))),
        }
    }
    by_camera.values_mut().for_each(|frames| frames.sort_by(|a, b| a.dg.time.total_cmp(&b.dg.time)));
    by_camera
}

/// The cadastre objects within `margin` of the fetch box, from every cadastre of the manifest. Layer indices
/// are numbered on across cadastres so that feature ids stay unique; every dropped feature or layer and every
/// unreadable cadastre is skipped and reported.
async fn cadastre_features(
    files: &Files,
    campaign: &Campaign,
    fetch: &BBox,
    margin: f64,
    skipped_items: &mut Vec<SkippedInput>,
) -> plumbline_runtime::Result<Vec<CadastreFeature>> {
    let bbox = [fetch.min_east - margin, fetch.min_north - margin, fetch.max_east + margin, fetch.max_north + margin];
    let mut features = Vec::new();
    let mut layer_offset = 0u32;
    for spec in &campaign.manifest.cadastres {
        let url = campaign.url(&spec.url)?;
        let offset = layer_offset;
        layer_offset += spec.layers.len() as u32;
        let bytes = match files.read(&url).await {
            Ok(b) => b,
            Err(e) => {
                let reason = reason_of_store(&e);
                skipped_items.push(skipped(Stage::Cadastre, &url, reason, format!("{url}: cannot be read: {e:#}")));
                continue;
            }
        };
        match read_one(url.clone(), bytes, spec.clone(), campaign.manifest.crs, bbox).await? {
            Ok((read, diagnostics)) => {
                skipped_items.extend(diagnostics.iter().filter_map(diagnostic_skip));
                features.extend(read.into_iter().map(|mut f| {
                    f.id.layer += offset;
                    f
                }));
            }
            Err(e) => skipped_items.push(skipped(Stage::Cadastre, &url, SkipReason::Open, e)),
        }
    }
    Ok(features)
}

type CadastreResult = Result<(Vec<CadastreFeature>, Vec<CadastreDiagnostic>), String>;

/// One cadastre through GDAL, on a blocking thread.
async fn read_one(
    url: String,
    bytes: Bytes,
    spec: Cadastre,
    crs: plumbline_campaign::Epsg,
    bbox: [f64; 4],
) -> plumbline_runtime::Result<CadastreResult> {
    blocking(move || {
        let source = CadastreSource::Bytes { name: &url, bytes: &bytes };
        read_cadastre(source, &spec, crs, Some(bbox)).map(|r| (r.features, r.diagnostics)).map_err(|e| e.to_string())
    })
    .await
}

/// A diagnostic that dropped a feature or layer, as a skipped item naming file, layer, feature and field.
fn diagnostic_skip(d: &CadastreDiagnostic) -> Option<SkippedInput> {
    if d.consequence == Consequence::Kept {
        return None;
    }
    let mut item = format!("{} layer {}", d.file, d.layer);
    if let Some(fid) = d.fid {
        item.push_str(&format!(" fid {fid}"));
    }
    if let Some(field) = &d.field {
        item.push_str(&format!(" field {field}"));
    }
    Some(skipped(Stage::Cadastre, &item, SkipReason::Cadastre(d.kind), d.to_string()))
}

#[cfg(test)]
mod tests {
    use plumbline_campaign::DiagnosticKind;

    use super::*;

    fn diagnostic(
        kind: DiagnosticKind,
        consequence: Consequence,
        fid: Option<u64>,
        field: Option<&str>,
    ) -> CadastreDiagnostic {
        CadastreDiagnostic {
            kind,
            consequence,
            file: "file:///c/poles.gpkg".into(),
            layer: "trees".into(),
            fid,
            field: field.map(str::to_owned),
            detail: "value \"oak?\"".into(),
        }
    }

    #[test]
    fn dropped_features_and_layers_are_skipped_items_naming_file_layer_fid_and_field() {
        let d = diagnostic(DiagnosticKind::UnknownClass, Consequence::FeatureSkipped, Some(17), Some("class"));
        let s = diagnostic_skip(&d).unwrap();
        assert_eq!((s.stage, &s.reason), (Stage::Cadastre, &SkipReason::Cadastre(DiagnosticKind::UnknownClass)));
        assert_eq!(s.item, "file:///c/poles.gpkg layer trees fid 17 field class");
        assert!(
            s.detail.contains("poles.gpkg") && s.detail.contains("17") && s.detail.contains("oak?"),
            "{}",
            s.detail
        );
        let layer = diagnostic(DiagnosticKind::MissingLayer, Consequence::LayerSkipped, None, None);
        assert_eq!(diagnostic_skip(&layer).unwrap().item, "file:///c/poles.gpkg layer trees");
        // A feature that is still used (e.g. its height dropped) is not a skipped input.
        let kept = diagnostic(DiagnosticKind::HeightDropped, Consequence::Kept, Some(3), None);
        assert!(diagnostic_skip(&kept).is_none());
    }
}
