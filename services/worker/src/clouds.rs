//! The point-cloud side of a tile's poles: each manifest cloud whose header bounds reach the tile is streamed
//! through a `plumbline_poles::CloudSlicer`, which keeps the slices whose middle time falls in the tile's
//! share of the drive (`CampaignPlan::time_spans_of`), so every slice is searched by exactly one tile. Its
//! frames then go through the depth path's matching and updates.
//!
//! A cloud without GPS time (declared `time = "none"`, or a point format without it: merged or tiled
//! products) gives weaker control: its stems near the tile are found in three streamed passes and each takes
//! the time the drive passed nearest to it (`plumbline_poles::untimed_inputs`).
//! A cloud is read by range requests (`RangeReader`, 8 MiB at a time, from disk or S3) and decoded as it
//! arrives: a tile holds one window of the file and one time window of points, whatever the file's size.
//! A COPC cloud is read by octree node instead (`plumbline_poles::CopcIndex`): only the nodes whose cubes
//! come within [`REACH_M`] of the tile's fetch box are decoded. Their points are not in time order, so a
//! timed COPC tile gathers the points of its own time windows, sorts them and then slices them: it holds
//! the tile's share of the cloud, not one window.
//! A cloud in another CRS than the campaign's (its header's, or the manifest's `epsg`) is transformed to it
//! through GDAL/PROJ as it streams ([`Reproject`]). A cloud that cannot be used is a skipped item naming the
//! file and why (unreadable, not LAS, a CRS with no transformation to the campaign's); one corrupt
//! record ends that cloud's reading, keeping the slices already searched.

use std::ops::Range;
use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use plumbline_campaign::CadastreFeature;
use plumbline_campaign::manifest::{CloudTime, PointCloud};
use plumbline_campaign::{Campaign, SkippedInput};
use plumbline_campaign::{SkipReason, Stage};
use plumbline_geo::TrajectoryRecord;
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::tiling::{BBox, TileId};
use plumbline_geo::trajectory::{PositionInterpolation, Trajectory};
use plumbline_poles::cloud::frame_prefix;
use plumbline_poles::las_header::{GPS_WEEK_S, LAS_PREFIX_BYTES, LasHeader, parse_las_header};
use plumbline_poles::{
    CloudConfig, CloudCounts, CloudSlicer, CopcIndex, CopcNode, LasError, LasPoint, MatchInput, PassIndex, PoleConfig,
    StemConfig, StemDetector, match_inputs, stream_las_points_from, stream_las_xyz_from, untimed_inputs,
};
use plumbline_runtime::range_reader::{DEFAULT_WINDOW, RangeReader};
use plumbline_runtime::{CrsTransform, Files};

use crate::fetch::{blocking, reason_of_store, skipped};
use crate::output::PoleResults;
use crate::panoramas::position_sigma;

/// A cloud is read by a tile when its header bounds come this close to the tile's fetch box, metres.
const REACH_M: f64 = 30.0;

/// Search the tile's slices of every point cloud, match them against `features` and add the updates,
/// frame reports and skipped items to `out`.
pub(crate) async fn process(
    files: &Files,
    campaign: &Campaign,
    tile: &TileId,
    fetch: &BBox,
    config: &PoleConfig,
    features: &Arc<Vec<CadastreFeature>>,
    out: &mut PoleResults,
) -> plumbline_runtime::Result<()> {
    let spans = campaign.plan.time_spans_of(tile);
    if spans.is_empty() {
        return Ok(());
    }
    let mut inputs: Vec<MatchInput> = Vec::new();
    let mut trajectory: Option<Arc<Trajectory>> = None;
    for (i, cloud) in campaign.manifest.point_clouds.iter().enumerate() {
        let t0 = Instant::now();
        let url = match campaign.url(&cloud.url) {
            Ok(url) => url,
            Err(e) => {
                out.skipped.push(skipped(Stage::Poles, cloud.url.as_str(), SkipReason::Url, format!("{e:#}")));
                continue;
            }
        };
        let header = match read_header(files, &url).await {
            Ok(h) => h,
            Err(s) => {
                out.skipped.push(s);
                continue;
            }
        };
        let reproject = match check_header(&header, cloud, campaign.manifest.crs.0, &url) {
            Ok(r) => r,
            Err(detail) => {
                out.skipped.push(skipped(Stage::Poles, &url, SkipReason::Refused, detail));
                continue;
            }
        };
        if !reaches(&header, reproject, fetch) {
            continue;
        }
        let z_unit = match height_unit(&header, &url) {
            Ok(u) => u,
            Err(detail) => {
                out.skipped.push(skipped(Stage::Poles, &url, SkipReason::Refused, detail));
                continue;
            }
        };
        let reader = match RangeReader::open(files, &url, DEFAULT_WINDOW).await {
            Ok(r) => r,
            Err(e) => {
                let reason = reason_of_store(&e);
                out.skipped.push(skipped(Stage::Poles, &url, reason, format!("{url}: cannot be read: {e:#}")));
                continue;
            }
        };
        out.read_s += t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let trajectory = Arc::clone(trajectory.get_or_insert_with(|| Arc::new(campaign.trajectory.trajectory.clone())));
        let spec = Stream {
            index: i,
            mount: scanner_mount(cloud),
            config: config.clouds,
            spans: spans.clone(),
            reproject,
            copc: header.copc,
            z_unit,
            fetch: *fetch,
        };
        let (read, found, counts) = if cloud.time != CloudTime::None && header.has_gps_time() {
            let adjusted = match cloud.time {
                CloudTime::AdjustedStandard => true,
                CloudTime::WeekSeconds => false,
                CloudTime::Header | CloudTime::None => header.adjusted_standard_gps_time,
            };
            blocking(move || timed_stream(spec, trajectory, reader, adjusted)).await?
        } else {
            untimed_stream(files, &url, spec, trajectory).await?
        };
        out.process_s += t1.elapsed().as_secs_f64();
        if let Err(e) = read {
            let detail = format!("{e} (the slices before it are used)");
            out.skipped.push(skipped(Stage::Poles, &url, SkipReason::Decode, detail));
        }
        report_counts(&url, &counts, out);
        tracing::debug!(cloud = %url, ?counts, frames = found.len(), "point cloud searched");
        inputs.extend(found);
    }
    if inputs.is_empty() {
        return Ok(());
    }
    inputs.sort_by(|a, b| a.time.total_cmp(&b.time));
    let t2 = Instant::now();
    let (features, config) = (Arc::clone(features), *config);
    let output = blocking(move || match_inputs(&inputs, &features, &config)).await?;
    out.process_s += t2.elapsed().as_secs_f64();
    out.updates.extend(output.updates);
    out.reports.extend(output.reports);
    Ok(())
}

/// How one cloud is searched.
struct Stream {
    /// Its index in the manifest (names its frames).
    index: usize,
    mount: CameraMount,
    config: CloudConfig,
    /// The tile's share of the drive.
    spans: Vec<Range<f64>>,
    /// The transformation to the campaign's CRS, when the cloud is in another.
    reproject: Option<Reproject>,
    /// A COPC cloud, read by the octree nodes near `fetch`.
    copc: bool,
    /// Metres per unit of the cloud's heights (its CRS record's vertical unit; 1 without one).
    z_unit: f64,
    /// The tile's fetch box.
    fetch: BBox,
}

/// A cloud's CRS to the campaign's: the EPSG codes, the transformation itself built on the thread that uses
/// it (GDAL handles are not `Send`).
#[derive(Clone, Copy, Debug)]
struct Reproject {
    from: u32,
    to: u32,
}

impl Reproject {
    fn transform(&self) -> Result<CrsTransform, String> {
        CrsTransform::new(self.from, self.to).map_err(|e| e.to_string())
    }
}

/// Points moved into the campaign's CRS in place, a batch at a time (the coordinate buffers are reused).
struct Transformer {
    transform: CrsTransform,
    xyz: [Vec<f64>; 3],
}

impl Transformer {
    fn new(reproject: Option<Reproject>) -> Result<Option<Self>, String> {
        reproject.map(|r| Ok(Self { transform: r.transform()?, xyz: Default::default() })).transpose()
    }

    /// Transform the positions of `items` (a batch either transforms whole or fails, naming both CRSs).
    fn apply<P>(&mut self, items: &mut [P], position: fn(&mut P) -> &mut [f64; 3]) -> Result<(), String> {
        for (axis, v) in self.xyz.iter_mut().enumerate() {
            v.clear();
            v.extend(items.iter_mut().map(|p| position(p)[axis]));
        }
        let [xs, ys, zs] = &mut self.xyz;
        self.transform.transform(xs, ys, zs).map_err(|e| e.to_string())?;
        for (k, p) in items.iter_mut().enumerate() {
            *position(p) = [xs[k], ys[k], zs[k]];
        }
        Ok(())
    }
}

type Searched = (Result<(), LasError>, Vec<MatchInput>, CloudCounts);

/// The scanner's DG position and σ at a time.
fn track(trajectory: Arc<Trajectory>, mount: CameraMount) -> impl Fn(f64) -> Option<(Vector3<f64>, f64)> {
    move |t: f64| {
        let record = trajectory.interpolate(t, PositionInterpolation::Linear).ok()?;
        Some((origin(&mount, &record), position_sigma(&record)))
    }
}

/// A cloud with GPS time, streamed once through a [`CloudSlicer`] (on a blocking thread).
fn timed_stream(spec: Stream, trajectory: Arc<Trajectory>, reader: RangeReader, adjusted: bool) -> Searched {
    let name = format!("point_clouds[{}]", spec.index);
    let mut transformer = match Transformer::new(spec.reproject) {
        Ok(t) => t,
        Err(e) => return (Err(LasError::Reproject { file: name, problem: e }), Vec::new(), CloudCounts::default()),
    };
    let track = track(trajectory, spec.mount);
    let mut slicer = CloudSlicer::new(spec.config, &frame_prefix(spec.index), track, spec.spans);
    let mut converted: Vec<LasPoint> = Vec::new();
    let mut failed: Option<String> = None;
    // Week seconds in the campaign's CRS; `false` when the transformation failed (the reading ends there).
    let mut convert = |batch: &[LasPoint], converted: &mut Vec<LasPoint>| {
        converted.clear();
        converted.extend(batch.iter().map(|p| {
            let [x, y, z] = p.position;
            LasPoint { gps_time: week_seconds(p.gps_time, adjusted), position: [x, y, z * spec.z_unit] }
        }));
        match transformer.as_mut().map(|t| t.apply(converted, |p| &mut p.position)) {
            Some(Err(e)) => {
                failed.get_or_insert(e);
                false
            }
            _ => true,
        }
    };
    let len = reader.size();
    let read = if spec.copc {
        // Nodes come in octree order: gather the tile's time windows, then slice them in time order.
        // One vector reserved for what the nodes hold (pages never touched cost nothing, and it never grows
        // by copying), sorted in place.
        let mut kept: Vec<LasPoint> = Vec::new();
        let mut points = 0u64;
        let read = read_copc(&name, reader, len, spec.reproject, &spec.fetch, |index, source, nodes| {
            kept.reserve_exact(reservation(nodes));
            index.stream_points(&name, source, nodes, |batch| {
                points += batch.len() as u64;
                if convert(batch, &mut converted) {
                    kept.extend(converted.iter().filter(|p| slicer.needs(p.gps_time)));
                }
            })
        });
        kept.sort_unstable_by(|a, b| {
            let position = |p: &LasPoint| p.position;
            a.gps_time.total_cmp(&b.gps_time).then_with(|| {
                let (pa, pb) = (position(a), position(b));
                pa[0].total_cmp(&pb[0]).then(pa[1].total_cmp(&pb[1])).then(pa[2].total_cmp(&pb[2]))
            })
        });
        for batch in kept.chunks(65_536) {
            slicer.push(batch);
        }
        drop(kept);
        read.map(|_| points)
    } else {
        stream_las_points_from(&name, reader, len, |batch| {
            if convert(batch, &mut converted) {
                slicer.push(&converted);
            }
        })
        .map(|(_, n)| n)
    };
    let (found, mut counts) = slicer.finish();
    if spec.copc
        && let Ok(n) = read
    {
        // The slicer saw only the points kept; the count is of all points decoded.
        counts.points = n;
    }
    let read = match (read, failed) {
        (Err(e), _) => Err(e),
        (Ok(_), Some(problem)) => Err(LasError::Reproject { file: name, problem }),
        (Ok(_), None) => Ok(()),
    };
    (read, found, counts)
}

/// Points to reserve for the nodes' decoded points: their count, but no more than one per compressed byte
/// (the counts come from the file, the bytes were checked against its size).
fn reservation(nodes: &[CopcNode]) -> usize {
    let count: u64 = nodes.iter().map(|n| n.point_count).sum();
    let bytes: u64 = nodes.iter().map(CopcNode::byte_size).sum();
    usize::try_from(count.min(bytes)).unwrap_or(0)
}

/// A COPC cloud's index read from `source`, and `decode(index, source, nodes near the fetch box)`.
fn read_copc<R: std::io::Read + std::io::Seek>(
    name: &str,
    mut source: R,
    len: u64,
    reproject: Option<Reproject>,
    fetch: &BBox,
    decode: impl FnOnce(&CopcIndex, &mut R, &[CopcNode]) -> Result<u64, LasError>,
) -> Result<u64, LasError> {
    let index = CopcIndex::read(name, &mut source, len)?;
    let transform = reproject.and_then(|r| r.transform().ok());
    let nodes: Vec<CopcNode> = index
        .nodes()
        .iter()
        .filter(|n| {
            let b = [n.min[0], n.min[1], n.max[0], n.max[1]];
            match &transform {
                None => near(b, fetch),
                // A cube whose corners cannot be moved is read: its points fail alone if they must.
                Some(t) => t.transform_bounds(b).map_or(true, |b| near(b, fetch)),
            }
        })
        .copied()
        .collect();
    decode(&index, &mut source, &nodes)
}

/// A cloud without GPS time: its stems near the tile (three streamed passes by range reads, points beyond
/// [`REACH_M`] of the fetch box passed over), each timed by the drive's nearest pass (`untimed_inputs`).
async fn untimed_stream(
    files: &Files,
    url: &str,
    spec: Stream,
    trajectory: Arc<Trajectory>,
) -> plumbline_runtime::Result<Searched> {
    // Thin stems need the scan lines' times to be told from grazed walls (`StemConfig::thin_stems`).
    let mut detector = StemDetector::new(StemConfig { thin_stems: false, ..spec.config.stems });
    let b = spec.fetch;
    let inside = move |p: &[f64; 3]| {
        p[0] >= b.min_east - REACH_M
            && p[0] <= b.max_east + REACH_M
            && p[1] >= b.min_north - REACH_M
            && p[1] <= b.max_north + REACH_M
    };
    let mut points = 0u64;
    for pass in 0..3 {
        let reader = RangeReader::open(files, url, DEFAULT_WINDOW).await?;
        let name = url.to_owned();
        let (reproject, copc, z_unit) = (spec.reproject, spec.copc, spec.z_unit);
        let (returned, read) = blocking(move || {
            let mut transformer = match Transformer::new(reproject) {
                Ok(t) => t,
                Err(problem) => return (detector, Err(LasError::Reproject { file: name, problem })),
            };
            let (mut near, mut moved): (Vec<[f64; 3]>, Vec<[f64; 3]>) = (Vec::new(), Vec::new());
            let mut failed: Option<String> = None;
            let len = reader.size();
            let mut visit = |batch: &[[f64; 3]]| {
                near.clear();
                if let Some(t) = transformer.as_mut() {
                    moved.clear();
                    moved.extend_from_slice(batch);
                    if let Err(e) = t.apply(&mut moved, |p| p) {
                        failed.get_or_insert(e);
                        return;
                    }
                    near.extend(moved.iter().filter(|p| inside(p)));
                } else {
                    near.extend(batch.iter().filter(|p| inside(p)));
                }
                if z_unit != 1.0 {
                    near.iter_mut().for_each(|p| p[2] *= z_unit);
                }
                match pass {
                    0 => detector.ground(&near),
                    1 => detector.collect(&near),
                    _ => detector.surroundings(&near),
                }
            };
            let read = if copc {
                read_copc(&name, reader, len, reproject, &b, |index, source, nodes| {
                    index.stream_xyz(&name, source, nodes, &mut visit)
                })
            } else {
                stream_las_xyz_from(&name, reader, len, visit).map(|(_, n)| n)
            };
            let read = match (read, failed) {
                (Ok(_), Some(problem)) => Err(LasError::Reproject { file: name, problem }),
                (read, _) => read,
            };
            (detector, read)
        })
        .await?;
        detector = returned;
        match read {
            Ok(n) if pass == 0 => points = n,
            Ok(_) => {}
            Err(e) => return Ok((Err(e), Vec::new(), CloudCounts::default())),
        }
    }
    let found = blocking(move || {
        let stems = detector.finish();
        let positions = trajectory.records().iter().map(|r| (r.time, [r.position.x(), r.position.y()]));
        let passes = PassIndex::new(positions, 0.5);
        let track = track(trajectory, spec.mount);
        let prefix = frame_prefix(spec.index);
        untimed_inputs(&stems, &passes, spec.config.reliable_range_m, &spec.spans, &prefix, &track, &spec.config)
    })
    .await?;
    let (inputs, mut counts) = found;
    counts.points = points;
    Ok((Ok(()), inputs, counts))
}

/// The header from the file's first bytes (one range read).
async fn read_header(files: &Files, url: &str) -> Result<LasHeader, SkippedInput> {
    let (prefix, len) = files
        .read_prefix(url, LAS_PREFIX_BYTES as u64)
        .await
        .map_err(|e| skipped(Stage::Poles, url, reason_of_store(&e), format!("{url}: cannot be read: {e:#}")))?;
    parse_las_header(url, &prefix, Some(len)).map_err(|e| skipped(Stage::Poles, url, SkipReason::Decode, e.to_string()))
}

/// Whether the cloud's bounds (in the campaign's CRS: their corners and edge middles transformed) come within
/// [`REACH_M`] of the fetch box.
fn reaches(h: &LasHeader, reproject: Option<Reproject>, fetch: &BBox) -> bool {
    let Some(b) = campaign_bounds(h, reproject) else { return false };
    h.point_count > 0 && near(b, fetch)
}

/// Metres per unit of a cloud's heights: the unit its CRS record names (a WKT's vertical CRS, e.g. US survey
/// feet in a compound CRS, or the GeoKeys' VerticalUnitsGeoKey), 1 without one; an error naming an unknown
/// unit code.
fn height_unit(h: &LasHeader, url: &str) -> Result<f64, String> {
    match h.crs.height_unit(plumbline_runtime::vertical_unit_of_wkt) {
        Ok(Some((name, m))) if m != 1.0 => {
            tracing::info!(cloud = %url, unit = %name, metres = m, "heights converted to metres");
            Ok(m)
        }
        Ok(_) => Ok(1.0),
        Err(e) => Err(format!("{url}: {e}")),
    }
}

/// Whether horizontal bounds (min east, min north, max east, max north) come within [`REACH_M`] of the fetch
/// box.
fn near([min_e, min_n, max_e, max_n]: [f64; 4], fetch: &BBox) -> bool {
    min_e <= fetch.max_east + REACH_M
        && max_e >= fetch.min_east - REACH_M
        && min_n <= fetch.max_north + REACH_M
        && max_n >= fetch.min_north - REACH_M
}

/// The header's horizontal bounds in the campaign's CRS (min east, min north, max east, max north); `None`
/// when they cannot be transformed.
fn campaign_bounds(h: &LasHeader, reproject: Option<Reproject>) -> Option<[f64; 4]> {
    let b = [h.min[0], h.min[1], h.max[0], h.max[1]];
    match reproject {
        None => Some(b),
        Some(r) => r.transform().ok()?.transform_bounds(b).ok(),
    }
}

/// Whether a cloud can give control in a campaign of `campaign_epsg`: the transformation its points need
/// when its CRS (the manifest's `epsg`, else the header's) is another; an error when no transformation
/// exists.
fn check_header(h: &LasHeader, cloud: &PointCloud, campaign_epsg: u32, url: &str) -> Result<Option<Reproject>, String> {
    let from = cloud.epsg.map(|e| e.0).or_else(|| h.crs.epsg(plumbline_runtime::epsg_of_wkt));
    match from {
        Some(from) if from != campaign_epsg => {
            let r = Reproject { from, to: campaign_epsg };
            r.transform().map_err(|e| format!("{url} is in EPSG:{from}: {e}"))?;
            Ok(Some(r))
        }
        _ => Ok(None),
    }
}

/// A point time in GPS seconds of the week: adjusted standard GPS time is GPS seconds since 1980-01-06 minus
/// 10⁹, so adding 10⁹ back and taking the remainder of a week gives the week seconds (the trajectory's scale).
fn week_seconds(t: f64, adjusted: bool) -> f64 {
    if adjusted { (t + 1e9).rem_euclid(GPS_WEEK_S) } else { t }
}

/// The scanner's mount (the navigation reference point when the manifest gives none).
fn scanner_mount(cloud: &PointCloud) -> CameraMount {
    let (lever, [r, p, y]) = cloud.mount.map_or(([0.0; 3], [0.0; 3]), |m| (m.lever_arm_m, m.boresight_deg));
    CameraMount::new(lever, &Boresight::from_degrees(r, p, y))
}

/// The scanner centre at a DG record.
fn origin(mount: &CameraMount, record: &TrajectoryRecord) -> Vector3<f64> {
    mount.camera_pose(&record.pose()).translation.p
}

/// Points that could not be used are counted as a skipped item (never silently dropped).
fn report_counts(url: &str, c: &CloudCounts, out: &mut PoleResults) {
    if c.late > 0 {
        let detail = format!(
            "{url}: {} of {} points came after their time slice was searched (the cloud is not in GPS-time order) \
             and were not used",
            c.late, c.points
        );
        out.skipped.push(skipped(Stage::Poles, url, SkipReason::Time, detail));
    }
    if c.ambiguous > 0 {
        let detail = format!(
            "{url}: {} stems lie near two passes of the drive and were not used (the cloud has no GPS time to say \
             which pass scanned them)",
            c.ambiguous
        );
        out.skipped.push(skipped(Stage::Poles, url, SkipReason::Time, detail));
    }
    if c.off_trajectory > 0 {
        let detail = format!("{url}: {} time slices lie outside the DG trajectory and were not used", c.off_trajectory);
        out.skipped.push(skipped(Stage::Poles, url, SkipReason::Time, detail));
    }
}

#[cfg(test)]
mod tests {
    use plumbline_geo::Trajectory;
    use plumbline_poles::{LasEncoding, encode_las, stream_las_points};
    use plumbline_runtime::{S3Options, Secret, write_url};
    use plumbline_testkit::MotoServer;

    use super::*;

    /// The S3 test server (stopped when dropped) with a bucket, and the options that reach it.
    fn s3_with_bucket(bucket: &str) -> (MotoServer, S3Options) {
        let server = MotoServer::start();
        server.create_bucket(bucket);
        let s3 = S3Options {
            endpoint: Some(server.endpoint()),
            region: Some("eu-central-1".to_owned()),
            access_key_id: Some("plumbline-test".to_owned()),
            secret_access_key: Some(Secret::new("plumbline-test-secret")),
            allow_http: false,
            virtual_hosted_style: false,
        };
        (server, s3)
    }

    /// A LAZ on a real S3-compatible server is streamed by range requests of one window each, never fetched
    /// whole, and gives the points a whole read gives.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_cloud_on_s3_streams_by_range_requests() {
        let (_server, s3) = s3_with_bucket("clouds");
        let points: Vec<LasPoint> = (0..300_000)
            .map(|i| {
                let f = f64::from(i);
                LasPoint {
                    position: [565_000.0 + (f * 0.37).sin() * 20.0, 5_933_000.0 + f * 1e-3, 8.0],
                    gps_time: f * 1e-4,
                }
            })
            .collect();
        let encoding = LasEncoding { compressed: true, wkt: None, adjusted_standard_week: None };
        let laz = encode_las(&points, &encoding).unwrap();
        let size = laz.len() as u64;
        let url = "s3://clouds/lidar/strip_000.laz";
        write_url(url, &s3, bytes::Bytes::from(laz.clone())).await.unwrap();

        let files = Files::new(s3);
        let reader = RangeReader::open(&files, url, 64 * 1024).await.unwrap();
        let (fetched, window) = (reader.fetched(), reader.window());
        assert!(size > 8 * window, "the file ({size} bytes) should span many windows");
        let streamed = blocking(move || {
            let mut got = Vec::new();
            stream_las_points_from(url, reader, size, |b| got.extend_from_slice(b)).map(|_| got)
        })
        .await
        .unwrap()
        .unwrap();
        let mut whole = Vec::new();
        stream_las_points("strip_000.laz", laz, |b| whole.extend_from_slice(b)).unwrap();
        assert_eq!(streamed.len(), points.len());
        assert_eq!(streamed, whole);
        // Each window once, plus the few the header and chunk-table checks read out of order.
        assert!(fetched.requests() >= size / window, "{} requests", fetched.requests());
        assert!(fetched.bytes() < size + 4 * window, "{} bytes fetched of {size}", fetched.bytes());
    }

    /// A COPC cloud on a real S3-compatible server: a tile reads its hierarchy and only the nodes near its
    /// fetch box, by range requests — under a third of the file for a box over 100 m of a 1.5 km strip — and
    /// gets every point inside the box.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_copc_cloud_on_s3_is_read_by_the_nodes_a_tile_needs() {
        use plumbline_poles::encode_copc;
        let (_server, s3) = s3_with_bucket("clouds");
        // A 1.5 km strip eastwards, ±10 m across, points 1 ms apart, on the millimetre grid.
        let points: Vec<LasPoint> = (0..1_500_000)
            .map(|i| {
                let f = f64::from(i);
                let position = [565_000.0 + f * 1e-3, 5_933_000.0 + (f * 0.37).sin() * 10.0, (f * 0.11).cos() * 3.0];
                LasPoint { position: position.map(|v| (v * 1000.0).round() / 1000.0), gps_time: f * 1e-3 }
            })
            .collect();
        let copc =
            encode_copc(&points, &LasEncoding { compressed: true, wkt: None, adjusted_standard_week: None }).unwrap();
        let size = copc.len() as u64;
        let url = "s3://clouds/lidar/strip_000.copc.laz";
        write_url(url, &s3, bytes::Bytes::from(copc)).await.unwrap();
        let files = Files::new(s3);
        let reader = RangeReader::open(&files, url, 64 * 1024).await.unwrap();
        let fetched = reader.fetched();
        let fetch = BBox { min_east: 565_700.0, min_north: 5_932_900.0, max_east: 565_800.0, max_north: 5_933_100.0 };
        let got = blocking(move || {
            let mut got: Vec<[f64; 3]> = Vec::new();
            read_copc(url, reader, size, None, &fetch, |index, source, nodes| {
                index.stream_xyz(url, source, nodes, |b| got.extend_from_slice(b))
            })
            .map(|_| got)
        })
        .await
        .unwrap()
        .unwrap();
        let inside = |p: &[f64; 3]| p[0] >= fetch.min_east && p[0] <= fetch.max_east;
        let wanted = points.iter().filter(|p| inside(&p.position)).count();
        assert!(wanted > 90_000, "{wanted}");
        assert_eq!(got.iter().filter(|p| inside(p)).count(), wanted);
        eprintln!("{} of {} points decoded, {} of {size} bytes fetched", got.len(), points.len(), fetched.bytes());
        // 14 % of the points and 20 % of the bytes when written.
        assert!(got.len() < points.len() / 4, "{} of {} points decoded", got.len(), points.len());
        assert!(fetched.bytes() < size / 3, "{} bytes fetched of {size}", fetched.bytes());
    }

    /// A cloud in UTM zone 33N (its WKT says so) in a zone-32N campaign is moved into the campaign's CRS: its
    /// bounds for the tile test, its points as they stream; a code PROJ does not know is refused, naming it.
    #[test]
    fn a_cloud_in_another_crs_is_transformed_into_the_campaigns() {
        let to_33 = CrsTransform::new(25832, 25833).unwrap();
        let campaign_xy = [(565_000.0, 5_933_000.0), (565_040.0, 5_933_030.0)];
        let points: Vec<LasPoint> = campaign_xy
            .iter()
            .map(|&(x, y)| {
                let (e, n, _) = to_33.transform_point(x, y, 0.0).unwrap();
                LasPoint { position: [e, n, 12.5], gps_time: 1.0 }
            })
            .collect();
        let wkt = Some(plumbline_runtime::crs::wkt_of_epsg(25833).unwrap());
        let las = encode_las(&points, &LasEncoding { compressed: false, wkt, adjusted_standard_week: None }).unwrap();
        let header = parse_las_header("a.las", &las, Some(las.len() as u64)).unwrap();
        let cloud =
            PointCloud { url: "lidar/a.las".into(), epsg: None, time: CloudTime::Header, format: None, mount: None };
        let reproject = check_header(&header, &cloud, 25832, "a.las").unwrap().unwrap();
        assert_eq!((reproject.from, reproject.to), (25833, 25832));
        assert_eq!(check_header(&header, &cloud, 25833, "a.las").unwrap().map(|r| r.from), None);
        // The bounds land around the campaign coordinates (zone 33's box turns by the grids' convergence, so
        // its transformed box is a little larger), and reach a tile there only.
        let b = campaign_bounds(&header, Some(reproject)).unwrap();
        let (lo, hi) = ([565_000.0, 5_933_000.0], [565_040.0, 5_933_030.0]);
        assert!(
            (0..2).all(|k| b[k] <= lo[k] && b[k] > lo[k] - 3.0 && b[k + 2] >= hi[k] && b[k + 2] < hi[k] + 3.0),
            "{b:?}"
        );
        let tile = BBox { min_east: 565_060.0, min_north: 5_933_000.0, max_east: 565_300.0, max_north: 5_933_200.0 };
        assert!(reaches(&header, Some(reproject), &tile));
        assert!(!reaches(&header, None, &tile), "untransformed, the cloud lies in zone 33's coordinates");
        let mut t = Transformer::new(Some(reproject)).unwrap().unwrap();
        let mut moved = points.clone();
        t.apply(&mut moved, |p| &mut p.position).unwrap();
        for (p, (x, y)) in moved.iter().zip(campaign_xy) {
            assert!((p.position[0] - x).abs() < 0.01 && (p.position[1] - y).abs() < 0.01, "{p:?}");
            assert_eq!(p.position[2], 12.5);
        }
        let unknown = PointCloud { epsg: Some(plumbline_campaign::Epsg(999_999)), ..cloud };
        let refused = check_header(&header, &unknown, 25832, "a.las").unwrap_err();
        assert!(refused.contains("EPSG:999999"), "{refused}");
    }

    /// A real COPC file (the poles crate's `tests/data/autzen.copc.laz`) is taken for both paths; its CRS
    /// record is compound (Oregon GIC Lambert in feet + NAVD88 height in US survey feet): the horizontal part
    /// gives the code, the vertical part the heights' unit.
    #[test]
    fn a_copc_cloud_is_taken_with_or_without_time() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../workflow/poles/tests/data/autzen.copc.laz");
        let bytes = std::fs::read(path).unwrap();
        let header = parse_label(&bytes);
        assert_eq!(header.crs.epsg(plumbline_runtime::epsg_of_wkt), Some(2992));
        // Its heights are NAVD88 in US survey feet: the run takes them in metres.
        assert!((height_unit(&header, "autzen.copc.laz").unwrap() - 0.304_800_609_601_219).abs() < 1e-15);
        for time in [CloudTime::Header, CloudTime::None] {
            let cloud = PointCloud {
                url: "lidar/autzen.copc.laz".into(),
                epsg: Some(plumbline_campaign::Epsg(2992)),
                time,
                format: None,
                mount: None,
            };
            assert!(check_header(&header, &cloud, 2992, "autzen.copc.laz").unwrap().is_none());
        }
    }

    fn parse_label(bytes: &[u8]) -> LasHeader {
        parse_las_header("autzen.copc.laz", bytes, Some(bytes.len() as u64)).unwrap()
    }

    /// A timed COPC cloud, read by the nodes near the tile and sorted, gives the tile the same slices as the
    /// same points streamed from LAZ: a 60 s drive along a street of posts, the tile taking its middle third
    /// (a third of the cloud lies beyond the fetch box's reach and is not decoded).
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_timed_copc_cloud_gives_the_slices_laz_gives() {
        use plumbline_geo::attitude::Attitude;
        use plumbline_geo::frames::Point3;
        use plumbline_geo::trajectory::ValidationLimits;
        use plumbline_poles::encode_copc;
        // 60 s at 10 m/s eastwards, the scanner 2 m above flat ground; 200 profiles a second, each 180 beams
        // over the full circle reaching the ground 8 m away or a post of 0.15 m (every 20 m, 5 m north).
        let (e0, n0) = (565_000.0, 5_933_000.0);
        let records: Vec<TrajectoryRecord> = (0..=600)
            .map(|k| {
                let t = 1000.0 + f64::from(k) * 0.1;
                TrajectoryRecord {
                    time: t,
                    position: Point3::new(e0 + 10.0 * (t - 1000.0), n0, 2.0),
                    attitude: Attitude::from_degrees(0.0, 0.0, 90.0),
                    std: None,
                }
            })
            .collect();
        let trajectory = Arc::new(Trajectory::new(records, &ValidationLimits::default()).unwrap());
        let mut points = Vec::new();
        for p in 0..12_000 {
            let t = 1000.0 + f64::from(p) / 200.0;
            let x = e0 + 10.0 * (t - 1000.0);
            let post = ((x / 20.0).round() * 20.0, n0 + 5.0);
            for a in 0..180 {
                let bearing = f64::from(a * 2).to_radians();
                let (dx, dy) = (bearing.cos(), bearing.sin());
                let along = (post.0 - x) * dx + (post.1 - n0) * dy;
                let off = ((post.0 - x) * dy - (post.1 - n0) * dx).abs();
                if along > 0.0 && off < 0.075 {
                    let at = along - (0.075f64.powi(2) - off * off).sqrt();
                    for h in 0..30 {
                        let position = [x + at * dx, n0 + at * dy, f64::from(h) * 0.1];
                        points.push(LasPoint { position, gps_time: t });
                    }
                } else {
                    points.push(LasPoint { position: [x + 8.0 * dx, n0 + 8.0 * dy, 0.0], gps_time: t });
                }
            }
        }
        let encoding = LasEncoding { compressed: true, wkt: None, adjusted_standard_week: None };
        let laz = encode_las(&points, &encoding).unwrap();
        let copc = encode_copc(&points, &encoding).unwrap();
        let fetch = BBox { min_east: e0 + 200.0, min_north: n0 - 100.0, max_east: e0 + 400.0, max_north: n0 + 100.0 };
        let spec = |copc| Stream {
            index: 0,
            mount: CameraMount::new([0.0; 3], &Boresight::from_degrees(0.0, 0.0, 0.0)),
            config: CloudConfig::default(),
            spans: vec![1020.0..1040.0],
            reproject: None,
            copc,
            z_unit: 1.0,
            fetch,
        };
        let dir = tempfile::tempdir().unwrap();
        let files = Files::new(S3Options::default());
        let mut results = Vec::new();
        for (name, bytes, copc) in [("s.laz", laz, false), ("s.copc.laz", copc, true)] {
            let path = dir.path().join(name);
            std::fs::write(&path, bytes).unwrap();
            let reader = RangeReader::open(&files, path.to_str().unwrap(), 64 * 1024).await.unwrap();
            let (spec, trajectory) = (spec(copc), Arc::clone(&trajectory));
            results.push(blocking(move || timed_stream(spec, trajectory, reader, false)).await.unwrap());
        }
        let (read_copc, from_copc, copc_counts) = results.pop().unwrap();
        let (read_laz, from_laz, laz_counts) = results.pop().unwrap();
        read_laz.unwrap();
        read_copc.unwrap();
        assert!(from_laz.len() >= 15, "{} slices with stems", from_laz.len());
        assert_eq!(from_copc, from_laz);
        assert_eq!(laz_counts.points, points.len() as u64);
        assert!(copc_counts.points < points.len() as u64 * 3 / 4, "{copc_counts:?}");
    }

    #[test]
    fn adjusted_standard_gps_time_becomes_week_seconds() {
        // GPS week 2000 starts 2000 · 604 800 s after the GPS epoch; 345 600 s into it is Thursday 0 h.
        let standard = 2000.0 * GPS_WEEK_S + 345_600.25;
        assert!((week_seconds(standard - 1e9, true) - 345_600.25).abs() < 1e-6);
        assert_eq!(week_seconds(345_600.25, false), 345_600.25);
    }
}
