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
//! A cloud in another CRS than the campaign's (its header's, or the manifest's `epsg`) is transformed to it
//! through GDAL/PROJ as it streams ([`Reproject`]). A cloud that cannot be used is a skipped item naming the
//! file and why (unreadable, not LAS, COPC, a CRS with no transformation to the campaign's); one corrupt
//! record ends that cloud's reading, keeping the slices already searched.

use std::ops::Range;
use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use plumbline_campaign::CadastreFeature;
use plumbline_campaign::manifest::{CloudTime, PointCloud};
use plumbline_geo::TrajectoryRecord;
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::tiling::{BBox, TileId};
use plumbline_geo::trajectory::{PositionInterpolation, Trajectory};
use plumbline_poles::cloud::frame_prefix;
use plumbline_poles::las_header::{GPS_WEEK_S, LAS_PREFIX_BYTES, LasHeader, parse_las_header};
use plumbline_poles::{
    CloudConfig, CloudCounts, CloudSlicer, LasError, LasPoint, MatchInput, PassIndex, PoleConfig, StemConfig,
    StemDetector, match_inputs, stream_las_points_from, stream_las_xyz_from, untimed_inputs,
};
use plumbline_runtime::range_reader::{DEFAULT_WINDOW, RangeReader};
use plumbline_runtime::{CrsTransform, Files};
use plumbline_scheduler::{Campaign, SkippedInput};

use crate::fetch::{SkipReason, blocking, skipped};
use crate::panoramas::position_sigma;
use crate::poles::PoleResults;

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
) -> anyhow::Result<()> {
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
                out.skipped.push(skipped("poles", cloud.url.as_str(), SkipReason::Url, format!("{e:#}")));
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
                out.skipped.push(skipped("poles", &url, SkipReason::Refused, detail));
                continue;
            }
        };
        if !reaches(&header, reproject, fetch) {
            continue;
        }
        let reader = match RangeReader::open(files, &url, DEFAULT_WINDOW).await {
            Ok(r) => r,
            Err(e) => {
                let reason = SkipReason::of_store(&e);
                out.skipped.push(skipped("poles", &url, reason, format!("{url}: cannot be read: {e:#}")));
                continue;
            }
        };
        out.read_s += t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let trajectory = Arc::clone(trajectory.get_or_insert_with(|| Arc::new(campaign.trajectory.trajectory.clone())));
        let spec =
            Stream { index: i, mount: scanner_mount(cloud), config: config.clouds, spans: spans.clone(), reproject };
        let (read, found, counts) = if cloud.time != CloudTime::None && header.has_gps_time() {
            let adjusted = match cloud.time {
                CloudTime::AdjustedStandard => true,
                CloudTime::WeekSeconds => false,
                CloudTime::Header | CloudTime::None => header.adjusted_standard_gps_time,
            };
            blocking(move || timed_stream(spec, trajectory, reader, adjusted)).await?
        } else {
            untimed_stream(files, &url, spec, trajectory, *fetch).await?
        };
        out.process_s += t1.elapsed().as_secs_f64();
        if let Err(e) = read {
            let detail = format!("{e} (the slices before it are used)");
            out.skipped.push(skipped("poles", &url, SkipReason::Decode, detail));
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
    let len = reader.size();
    let read = stream_las_points_from(&name, reader, len, |batch| {
        converted.clear();
        converted.extend(batch.iter().map(|p| LasPoint { gps_time: week_seconds(p.gps_time, adjusted), ..*p }));
        if let Some(t) = transformer.as_mut()
            && let Err(e) = t.apply(&mut converted, |p| &mut p.position)
        {
            failed.get_or_insert(e);
            return;
        }
        slicer.push(&converted);
    });
    let (found, counts) = slicer.finish();
    let read = match (read, failed) {
        (Err(e), _) => Err(e),
        (Ok(_), Some(problem)) => Err(LasError::Reproject { file: name, problem }),
        (Ok(_), None) => Ok(()),
    };
    (read, found, counts)
}

/// A cloud without GPS time: its stems near the tile (three streamed passes by range reads, points beyond
/// [`REACH_M`] of the fetch box passed over), each timed by the drive's nearest pass (`untimed_inputs`).
async fn untimed_stream(
    files: &Files,
    url: &str,
    spec: Stream,
    trajectory: Arc<Trajectory>,
    fetch: BBox,
) -> anyhow::Result<Searched> {
    // Thin stems need the scan lines' times to be told from grazed walls (`StemConfig::thin_stems`).
    let mut detector = StemDetector::new(StemConfig { thin_stems: false, ..spec.config.stems });
    let b = fetch;
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
        let reproject = spec.reproject;
        let (returned, read) = blocking(move || {
            let mut transformer = match Transformer::new(reproject) {
                Ok(t) => t,
                Err(problem) => return (detector, Err(LasError::Reproject { file: name, problem })),
            };
            let (mut near, mut moved): (Vec<[f64; 3]>, Vec<[f64; 3]>) = (Vec::new(), Vec::new());
            let mut failed: Option<String> = None;
            let len = reader.size();
            let read = stream_las_xyz_from(&name, reader, len, |batch| {
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
                match pass {
                    0 => detector.ground(&near),
                    1 => detector.collect(&near),
                    _ => detector.surroundings(&near),
                }
            });
            let read = match (read, failed) {
                (Ok(_), Some(problem)) => Err(LasError::Reproject { file: name, problem }),
                (read, _) => read,
            };
            (detector, read)
        })
        .await?;
        detector = returned;
        match read {
            Ok((_, n)) if pass == 0 => points = n,
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
        .map_err(|e| skipped("poles", url, SkipReason::of_store(&e), format!("{url}: cannot be read: {e:#}")))?;
    parse_las_header(url, &prefix, Some(len)).map_err(|e| skipped("poles", url, SkipReason::Decode, e.to_string()))
}

/// Whether the cloud's bounds (in the campaign's CRS: their corners and edge middles transformed) come within
/// [`REACH_M`] of the fetch box.
fn reaches(h: &LasHeader, reproject: Option<Reproject>, fetch: &BBox) -> bool {
    let Some([min_e, min_n, max_e, max_n]) = campaign_bounds(h, reproject) else { return false };
    h.point_count > 0
        && min_e <= fetch.max_east + REACH_M
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
/// when its CRS (the manifest's `epsg`, else the header's) is another; an error when it cannot be read (COPC,
/// unless declared without time: the time-less path reads points in any order) or no transformation exists.
fn check_header(h: &LasHeader, cloud: &PointCloud, campaign_epsg: u32, url: &str) -> Result<Option<Reproject>, String> {
    if h.copc && cloud.time != CloudTime::None {
        return Err(format!(
            "{url} is a COPC cloud (points by octree node, not in GPS-time order): read only with `time = \"none\"`"
        ));
    }
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
        out.skipped.push(skipped("poles", url, SkipReason::Time, detail));
    }
    if c.ambiguous > 0 {
        let detail = format!(
            "{url}: {} stems lie near two passes of the drive and were not used (the cloud has no GPS time to say \
             which pass scanned them)",
            c.ambiguous
        );
        out.skipped.push(skipped("poles", url, SkipReason::Time, detail));
    }
    if c.off_trajectory > 0 {
        let detail = format!("{url}: {} time slices lie outside the DG trajectory and were not used", c.off_trajectory);
        out.skipped.push(skipped("poles", url, SkipReason::Time, detail));
    }
}

#[cfg(test)]
mod tests {
    use plumbline_poles::{LasEncoding, encode_las, stream_las_points};
    use plumbline_runtime::{S3Options, Secret, write_url};
    use plumbline_testkit::MotoServer;

    use super::*;

    /// A LAZ on a real S3-compatible server is streamed by range requests of one window each, never fetched
    /// whole, and gives the points a whole read gives.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_cloud_on_s3_streams_by_range_requests() {
        let server = MotoServer::start();
        server.create_bucket("clouds");
        let s3 = S3Options {
            endpoint: Some(server.endpoint()),
            region: Some("eu-central-1".to_owned()),
            access_key_id: Some("plumbline-test".to_owned()),
            secret_access_key: Some(Secret::new("plumbline-test-secret")),
            allow_http: false,
            virtual_hosted_style: false,
        };
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

    /// A real COPC file (the poles crate's `tests/data/autzen.copc.laz`) is refused for the timed path, whose
    /// slices need points in time order, and taken by the time-less one, which reads any order.
    #[test]
    fn a_copc_cloud_is_read_only_without_time() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../workflow/poles/tests/data/autzen.copc.laz");
        let bytes = std::fs::read(path).unwrap();
        let header = parse_las_header("autzen.copc.laz", &bytes, Some(bytes.len() as u64)).unwrap();
        // Its CRS record is compound (Oregon GIC Lambert in feet + NAVD88 height): the horizontal part counts.
        assert_eq!(header.crs.epsg(plumbline_runtime::epsg_of_wkt), Some(2992));
        let cloud = |time| PointCloud {
            url: "lidar/autzen.copc.laz".into(),
            epsg: Some(plumbline_campaign::Epsg(2992)),
            time,
            format: None,
            mount: None,
        };
        let refused = check_header(&header, &cloud(CloudTime::Header), 2992, "autzen.copc.laz").unwrap_err();
        assert!(refused.contains("COPC") && refused.contains("time = \"none\""), "{refused}");
        assert!(check_header(&header, &cloud(CloudTime::None), 2992, "autzen.copc.laz").unwrap().is_none());
    }

    #[test]
    fn adjusted_standard_gps_time_becomes_week_seconds() {
        // GPS week 2000 starts 2000 · 604 800 s after the GPS epoch; 345 600 s into it is Thursday 0 h.
        let standard = 2000.0 * GPS_WEEK_S + 345_600.25;
        assert!((week_seconds(standard - 1e9, true) - 345_600.25).abs() < 1e-6);
        assert_eq!(week_seconds(345_600.25, false), 345_600.25);
    }
}
