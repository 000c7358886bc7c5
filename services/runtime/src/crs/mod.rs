//! Coordinate transformations between EPSG-coded CRSs through GDAL/PROJ; the only place plumbline touches CRS handles.
//!
//! Axis order: every spatial reference here uses GDAL's *traditional GIS order*, so geographic
//! coordinates are always `(x, y) = (longitude, latitude)` in degrees, and projected ones
//! `(easting, northing)` in the CRS's unit, whatever axis order the EPSG definition states.
//!
//! Threads: GDAL handles are neither `Send` nor `Sync`, so neither is [`CrsTransform`], and this
//! crate forbids `unsafe` to pretend otherwise. Build one per thread (construction takes about a
//! millisecond), e.g. inside `spawn_blocking` or with rayon's `map_init`.

mod convergence;

use gdal::errors::GdalError;
use gdal::spatial_ref::{AxisMappingStrategy, CoordTransform, SpatialRef};

pub use convergence::{MeridianConvergence, meridian_convergence};

/// Why a CRS operation failed; the message names the EPSG codes involved.
#[derive(Debug, thiserror::Error)]
pub enum CrsError {
    #[error("unknown CRS EPSG:{code}: {source}")]
    UnknownEpsg {
        code: u32,
        #[source]
        source: GdalError,
    },
    #[error("no transformation from EPSG:{from} to EPSG:{to}: {source}")]
    NoTransformation {
        from: u32,
        to: u32,
        #[source]
        source: GdalError,
    },
    #[error("transforming from EPSG:{from} to EPSG:{to} failed: {source}")]
    Transform {
        from: u32,
        to: u32,
        #[source]
        source: GdalError,
    },
    #[error("coordinate slices differ in length: {xs} x, {ys} y, {zs} z (z may also be empty)")]
    LengthMismatch { xs: usize, ys: usize, zs: usize },
    #[error("EPSG:{code} is not a projected CRS")]
    NotProjected { code: u32 },
}

/// A transformation from one EPSG CRS to another, in traditional GIS axis order (lon, lat).
/// Not `Send`: see the module docs.
#[derive(Debug)]
pub struct CrsTransform {
    inner: CoordTransform,
    from: u32,
    to: u32,
}

impl CrsTransform {
    /// Builds the transformation `from_epsg` → `to_epsg`.
    pub fn new(from_epsg: u32, to_epsg: u32) -> Result<Self, CrsError> {
        let source = spatial_ref(from_epsg)?;
        let target = spatial_ref(to_epsg)?;
        Self::between(&source, &target, from_epsg, to_epsg)
    }

    fn between(source: &SpatialRef, target: &SpatialRef, from: u32, to: u32) -> Result<Self, CrsError> {
        let inner =
            CoordTransform::new(source, target).map_err(|source| CrsError::NoTransformation { from, to, source })?;
        Ok(Self { inner, from, to })
    }

    /// Source EPSG code.
    pub fn from_epsg(&self) -> u32 {
        self.from
    }

    /// Target EPSG code.
    pub fn to_epsg(&self) -> u32 {
        self.to
    }

    /// Transforms points in place. `zs` is either as long as `xs` and `ys` or empty (2D).
    /// Fails, naming both codes, if any point cannot be transformed.
    pub fn transform(&self, xs: &mut [f64], ys: &mut [f64], zs: &mut [f64]) -> Result<(), CrsError> {
        if xs.len() != ys.len() || !(zs.is_empty() || zs.len() == xs.len()) {
            return Err(CrsError::LengthMismatch { xs: xs.len(), ys: ys.len(), zs: zs.len() });
        }
        if xs.is_empty() {
            return Ok(());
        }
        self.inner.transform_coords(xs, ys, zs).map_err(|source| CrsError::Transform {
            from: self.from,
            to: self.to,
            source,
        })
    }

    /// The bounding box `[min x, min y, max x, max y]` in the target CRS: the box of its corners and edge
    /// middles transformed (enough for the few-kilometre extents of clouds and rasters, whose edges bend
    /// little between projected CRSs).
    pub fn transform_bounds(&self, b: [f64; 4]) -> Result<[f64; 4], CrsError> {
        let ([x0, y0, x1, y1], xm, ym) = (b, 0.5 * (b[0] + b[2]), 0.5 * (b[1] + b[3]));
        let mut xs = [x0, xm, x1, x0, x1, x0, xm, x1];
        let mut ys = [y0, y0, y0, ym, ym, y1, y1, y1];
        self.transform(&mut xs, &mut ys, &mut [])?;
        let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let max = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Ok([min(&xs), min(&ys), max(&xs), max(&ys)])
    }

    /// Transforms one point `(x, y, z)`.
    pub fn transform_point(&self, x: f64, y: f64, z: f64) -> Result<(f64, f64, f64), CrsError> {
        let (mut xs, mut ys, mut zs) = ([x], [y], [z]);
        self.transform(&mut xs, &mut ys, &mut zs)?;
        Ok((xs[0], ys[0], zs[0]))
    }
}

/// The spatial reference of `code`, in traditional GIS axis order.
fn spatial_ref(code: u32) -> Result<SpatialRef, CrsError> {
    crate::gdal_messages::route_gdal_messages();
    let mut srs = SpatialRef::from_epsg(code).map_err(|source| CrsError::UnknownEpsg { code, source })?;
    srs.set_axis_mapping_strategy(AxisMappingStrategy::TraditionalGisOrder);
    Ok(srs)
}

/// Whether `epsg` is a projected CRS (easting/northing), as opposed to geographic, geocentric, ….
pub fn is_projected(epsg: u32) -> Result<bool, CrsError> {
    Ok(spatial_ref(epsg)?.is_projected())
}

/// The CRS's name, e.g. `ETRS89 / UTM zone 32N` for 25832.
pub fn crs_name(epsg: u32) -> Result<String, CrsError> {
    Ok(spatial_ref(epsg)?.name().unwrap_or_else(|| format!("EPSG:{epsg}")))
}

/// The OGC WKT of `epsg` (as a LAS file's `LASF_Projection` record carries it).
pub fn wkt_of_epsg(epsg: u32) -> Result<String, CrsError> {
    let srs = spatial_ref(epsg)?;
    srs.to_wkt().map_err(|source| CrsError::UnknownEpsg { code: epsg, source })
}

/// The EPSG code of a CRS given as WKT (e.g. a LAS file's `LASF_Projection` record), when GDAL/PROJ can
/// identify one; `None` for a WKT it cannot parse or a CRS without a code. A compound CRS (horizontal plus
/// vertical, as LAS deliveries often record) without a code of its own gives its horizontal part's.
pub fn epsg_of_wkt(wkt: &str) -> Option<u32> {
    crate::gdal_messages::route_gdal_messages();
    let code = |s: &SpatialRef| match s.auth_name().as_deref() {
        Some("EPSG") => s.auth_code().ok().and_then(|c| u32::try_from(c).ok()),
        _ => None,
    };
    let own = SpatialRef::from_wkt(wkt)
        .ok()
        .and_then(|mut srs| code(&srs).or_else(|| srs.auto_identify_epsg().ok().and_then(|()| code(&srs))));
    own.or_else(|| horizontal_part(wkt).and_then(epsg_of_wkt))
}

/// The horizontal element of a compound CRS's WKT — the first projected or geographic CRS inside WKT 1
/// `COMPD_CS[…]` or WKT 2 `COMPOUNDCRS[…]`, brackets matched outside quoted names; `None` for another WKT.
fn horizontal_part(wkt: &str) -> Option<&str> {
    let head = wkt.trim_start();
    if !(head.starts_with("COMPD_CS[") || head.starts_with("COMPOUNDCRS[")) {
        return None;
    }
    let inner = &head[head.find('[')? + 1..];
    element(inner, &["PROJCS[", "PROJCRS[", "GEOGCS[", "GEOGCRS[", "GEODCRS["])
}

/// The first element of `wkt` opening with one of `keys`, up to its matching bracket (brackets inside
/// quoted names do not count).
fn element<'a>(wkt: &'a str, keys: &[&str]) -> Option<&'a str> {
    let start = keys.iter().filter_map(|k| wkt.find(k)).min()?;
    let (mut depth, mut quoted) = (0usize, false);
    for (i, ch) in wkt[start..].char_indices() {
        match ch {
            '"' => quoted = !quoted,
            '[' if !quoted => depth += 1,
            ']' if !quoted => {
                depth = depth.checked_sub(1)?;
                if depth == 0 {
                    return wkt.get(start..start + i + 1);
                }
            }
            _ => {}
        }
    }
    None
}

/// The unit of heights a CRS's WKT gives (its vertical CRS's unit, WKT 1 `VERT_CS` or WKT 2 `VERTCRS`, alone or
/// in a compound CRS): the unit's name and metres per unit. `None` when the WKT has no vertical CRS (heights
/// are then taken to be metres) or its unit cannot be read.
pub fn vertical_unit_of_wkt(wkt: &str) -> Option<(String, f64)> {
    let vertical = element(wkt, &["VERT_CS[", "VERTCRS[", "VERTICALCRS["])?;
    let unit = element(vertical, &["UNIT["])?;
    let body = &unit[unit.find('[')? + 1..unit.len() - 1];
    let (name, rest) = body.trim_start().strip_prefix('"')?.split_once('"')?;
    let factor: f64 = rest.trim_start().strip_prefix(',')?.split([',', ']']).next()?.trim().parse().ok()?;
    (factor.is_finite() && factor > 0.0).then(|| (name.to_owned(), factor))
}

/// Metres per unit of a projected CRS's coordinates (1 for metres, 0.3048 for the international foot).
pub fn linear_unit_m(epsg: u32) -> Result<f64, CrsError> {
    Ok(spatial_ref(epsg)?.linear_units())
}
