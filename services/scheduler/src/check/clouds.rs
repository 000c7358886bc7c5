//! Point clouds: the LAS/LAZ header read from the file's first bytes (one range read) — version, point format,
//! count, bounds over the drive, CRS, GPS time — and a warning that the run does not use them as control.

use plumbline_campaign::Location;
use plumbline_poles::las_header::{LAS_PREFIX_BYTES, LasCrs, parse_las_header};

use super::{Checker, RASTER_REACH_M};

/// Check one point cloud's header.
pub(crate) async fn point_cloud(c: &mut Checker<'_>, field: &str, location: &Location) {
    let Some(url) = c.url(field, location) else { return };
    let (prefix, len) = match c.files.read_prefix(&url, LAS_PREFIX_BYTES as u64).await {
        Ok(read) => read,
        Err(e) => return c.problem(field, format!("`{url}`: {e:#}")),
    };
    let header = match parse_las_header(&url, &prefix, Some(len)) {
        Ok(h) => h,
        Err(e) => return c.problem(field, e),
    };
    let (min, max) = (header.min, header.max);
    if let Some(drive) = c.drive
        && header.point_count > 0
        && !drive.overlaps([min[0], min[1], max[0], max[1]], RASTER_REACH_M)
    {
        c.problem(
            field,
            format!(
                "`{url}` covers E {:.0}–{:.0}, N {:.0}–{:.0}, which misses the drive ({}): another CRS?",
                min[0],
                max[0],
                min[1],
                max[1],
                drive.describe()
            ),
        );
    }
    match &header.crs {
        LasCrs::GeoKeys { epsg: Some(epsg) } if *epsg != c.epsg => {
            let campaign = c.epsg;
            c.problem(field, format!("`{url}` is in EPSG:{epsg}, the campaign in EPSG:{campaign}"));
        }
        LasCrs::Missing => c.warning(field, format!("`{url}` names no CRS; it is taken to be the campaign's")),
        _ => {}
    }
    if !header.has_gps_time() {
        c.warning(field, format!("`{url}`: point format {} has no GPS time", header.point_format));
    }
    c.warning(
        field,
        format!(
            "`{url}` (LAS {}.{}, format {}, {} points) is not read as control by this version: the run uses depth \
             images for poles (`plumbline poles detect` makes a pole and tree inventory of the cloud)",
            header.version.0, header.version.1, header.point_format, header.point_count
        ),
    );
}
