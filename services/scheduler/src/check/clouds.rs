//! Point clouds: the LAS/LAZ header read from the file's first bytes (one range read) — version, point format,
//! count, bounds over the drive (in the campaign's CRS: a cloud in another is transformed as the run streams
//! it, so only a CRS with no transformation is refused), CRS (the header's or the manifest's `epsg`), GPS time (without it, or with
//! `time = "none"`, the run times stems by the drive's nearest pass: a warning).

use plumbline_campaign::manifest::{CloudFormat, CloudTime, PointCloud};
use plumbline_poles::las_header::{LAS_PREFIX_BYTES, LasCrs, parse_las_header};

use plumbline_runtime::CrsTransform;

use super::{Checker, RASTER_REACH_M};

/// Check one point cloud's header.
pub(crate) async fn point_cloud(c: &mut Checker<'_>, field: &str, cloud: &PointCloud) {
    let Some(url) = c.url(field, &cloud.url) else { return };
    let (prefix, len) = match c.files.read_prefix(&url, LAS_PREFIX_BYTES as u64).await {
        Ok(read) => read,
        Err(e) => return c.problem(field, format!("`{url}`: {e:#}")),
    };
    let header = match parse_las_header(&url, &prefix, Some(len)) {
        Ok(h) => h,
        Err(e) => return c.problem(field, e),
    };
    let found = if header.copc {
        CloudFormat::Copc
    } else if header.compressed {
        CloudFormat::Laz
    } else {
        CloudFormat::Las
    };
    if let Some(declared) = cloud.format
        && declared != found
    {
        c.problem(
            &format!("{field}.format"),
            format!("`{url}` is declared `{}`, but its header says {}", declared.name(), found.name()),
        );
    }
    let campaign = c.epsg;
    let header_epsg = header.crs.epsg(plumbline_runtime::epsg_of_wkt);
    match (cloud.epsg, header_epsg) {
        (None, None) if matches!(header.crs, LasCrs::Missing) => {
            c.warning(field, format!("`{url}` names no CRS; it is taken to be the campaign's (set `epsg` to say so)"))
        }
        (None, None) => c.warning(
            field,
            format!("`{url}`: its CRS record names no EPSG code; it is taken to be the campaign's (set `epsg`)"),
        ),
        _ => {}
    }
    // A cloud in another CRS is transformed as it streams: its bounds are checked where they land.
    let from = cloud.epsg.map(|e| e.0).or(header_epsg).unwrap_or(campaign);
    let mut bounds = [header.min[0], header.min[1], header.max[0], header.max[1]];
    if from != campaign {
        match CrsTransform::new(from, campaign).and_then(|t| t.transform_bounds(bounds)) {
            Ok(b) => bounds = b,
            Err(e) => {
                let given = if cloud.epsg.is_some() { "`epsg` says" } else { "its header says" };
                return c.problem(field, format!("`{url}` is in EPSG:{from} ({given}): {e}"));
            }
        }
    }
    if let Some(drive) = c.drive
        && header.point_count > 0
        && !drive.overlaps(bounds, RASTER_REACH_M)
    {
        let crs = if from == campaign { String::new() } else { format!(" (EPSG:{from} moved into EPSG:{campaign})") };
        c.problem(
            field,
            format!(
                "`{url}` covers E {:.0}–{:.0}, N {:.0}–{:.0}{crs}, which misses the drive ({}): another CRS?",
                bounds[0],
                bounds[2],
                bounds[1],
                bounds[3],
                drive.describe()
            ),
        );
    }
    if cloud.time == CloudTime::None || !header.has_gps_time() {
        let why = if cloud.time == CloudTime::None {
            "is declared without GPS time".to_owned()
        } else {
            format!("has no GPS time (point format {})", header.point_format)
        };
        c.warning(
            field,
            format!(
                "`{url}` {why}: each stem takes the time the drive passed nearest to it, weaker control than GPS \
                 time gives (a stem scanned from another pass carries that pass's DG error)"
            ),
        );
    }
}
