//! Orthophoto and terrain model: GDAL opens them, they are in the campaign CRS, overlap the drive, and have
//! the bands and pixel types the run reads. Only metadata is read: a VRT mosaic from an object store is opened
//! without its tiles.

use plumbline_campaign::Location;
use plumbline_runtime::gdal_read::{RasterSource, Tiles};
use plumbline_runtime::vrt::is_xml;

use super::{Checker, RASTER_REACH_M};

/// What the raster is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Role {
    /// The true orthophoto: 1, 3 or 4 bands of 8 or 16 bits.
    Orthophoto,
    /// The terrain model: heights in band 1.
    Terrain,
}

/// What the check learned of a raster.
#[derive(Debug)]
struct Metadata {
    epsg: Option<u32>,
    extent: [f64; 4],
    size: (usize, usize),
    bands: usize,
    pixel_type: String,
}

/// Open the raster a manifest field names and check it for its role.
pub(crate) async fn raster(c: &mut Checker<'_>, field: &str, location: &Location, role: Role) {
    let Some(url) = c.url(field, location) else { return };
    let opened = if let Some(path) = url.strip_prefix("file://") {
        let path = std::path::PathBuf::from(path);
        tokio::task::spawn_blocking(move || RasterSource::open_local(&path, Tiles::None).and_then(|s| metadata(&s)))
            .await
    } else {
        let Some(bytes) = c.read(field, &url).await else { return };
        let name = url.clone();
        tokio::task::spawn_blocking(move || {
            let source = if is_xml(&bytes) {
                RasterSource::open_mosaic_bytes(&name, &bytes, Vec::new())
            } else {
                RasterSource::open_bytes(&name, bytes.to_vec())
            };
            source.and_then(|s| metadata(&s))
        })
        .await
    };
    let m = match opened {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => return c.problem(field, e),
        Err(e) => return c.problem(field, format!("`{url}`: the reading task failed: {e}")),
    };
    match m.epsg {
        Some(epsg) if epsg == c.epsg => {}
        Some(epsg) => {
            let epsg_c = c.epsg;
            return c.problem(
                field,
                format!(
                    "`{url}` is in EPSG:{epsg}, the campaign in EPSG:{epsg_c}; reproject it (e.g. `gdalwarp -t_srs \
                     EPSG:{epsg_c}`)"
                ),
            );
        }
        None => {
            return c.problem(field, format!("`{url}` has no CRS with an EPSG code; expected EPSG:{}", c.epsg));
        }
    }
    if let Some(drive) = c.drive
        && !drive.overlaps(m.extent, RASTER_REACH_M)
    {
        let e = m.extent;
        c.problem(
            field,
            format!(
                "`{url}` covers E {:.0}–{:.0}, N {:.0}–{:.0}, which misses the drive ({})",
                e[0],
                e[2],
                e[1],
                e[3],
                drive.describe()
            ),
        );
    }
    match role {
        Role::Orthophoto => {
            if ![1, 3, 4].contains(&m.bands) || !["Byte", "UInt16"].contains(&m.pixel_type.as_str()) {
                c.problem(
                    field,
                    format!(
                        "`{url}` has {} band(s) of {}; an orthophoto is 1 (gray), 3 (RGB) or 4 (RGB + NIR or alpha) \
                         bands of Byte or UInt16",
                        m.bands, m.pixel_type
                    ),
                );
            }
        }
        Role::Terrain => {
            if m.bands != 1 {
                c.warning(field, format!("`{url}` has {} bands; heights are read from band 1", m.bands));
            }
            if m.pixel_type == "Byte" {
                c.warning(field, format!("`{url}` holds 8-bit heights (0–255 m): is this a terrain model?"));
            }
        }
    }
    tracing::debug!(field, size = ?m.size, "raster checked");
}

fn metadata(s: &RasterSource) -> Result<Metadata, plumbline_runtime::gdal_read::GdalReadError> {
    let e = s.extent();
    Ok(Metadata {
        epsg: s.epsg(),
        extent: [e.min_e, e.min_n, e.max_e, e.max_n],
        size: s.size(),
        bands: s.band_count(),
        pixel_type: s.pixel_type()?,
    })
}
