//! A feature's geometry as the 2D points of pole-like objects, or the reason it is not one.
//!
//! Decisions: a 3D point keeps its x/y (height dropped, noted); a multipoint with one point is a
//! point; a multipoint with several points gives each point as its own object (noted), never the
//! centroid — a centroid of two poles is a place where no pole stands, and a wrong control point is
//! worse than a missing one; polygons, lines and collections are skipped.

use gdal::vector::{Geometry, OGRwkbGeometryType, geometry_type_flatten, geometry_type_has_z, geometry_type_to_name};
use plumbline_campaign::DiagnosticKind;

/// The points of one feature, with the problems that did not stop it being used.
#[derive(Debug, Default)]
pub(crate) struct FeaturePoints {
    /// x/y in the layer's CRS.
    pub points: Vec<[f64; 2]>,
    /// Kept-with-note problems: height dropped, multipoint split.
    pub notes: Vec<(DiagnosticKind, String)>,
}

/// Why a feature's geometry gives no point.
pub(crate) type GeometryProblem = (DiagnosticKind, String);

/// The name of a geometry's type, e.g. `Point`, `3D Point`, `Multi Point`, `Polygon`; `none` for null.
pub(crate) fn type_name(geometry: Option<&Geometry>) -> String {
    present(geometry).map_or_else(|| "none".to_owned(), |g| geometry_type_to_name(g.geometry_type()))
}

/// The geometry unless it is null. The `gdal` crate hands out a geometry wrapping a null handle for a
/// feature without geometry; GDAL answers `wkbUnknown` for its type, which no real geometry has.
fn present(geometry: Option<&Geometry>) -> Option<&Geometry> {
    geometry.filter(|g| g.geometry_type() != OGRwkbGeometryType::wkbUnknown)
}

/// The points of `geometry` as GDAL fetched it, `failures` being the GDAL failures raised by the fetch: a
/// geometry missing because its stored blob could not be decoded is [`DiagnosticKind::BadGeometry`], not a
/// null geometry.
pub(crate) fn points_fetched(
    geometry: Option<&Geometry>,
    failures: &[String],
) -> Result<FeaturePoints, GeometryProblem> {
    if present(geometry).is_none()
        && let Some(message) = failures.last()
    {
        let detail = format!("the stored geometry cannot be decoded: GDAL: {message}");
        return Err((DiagnosticKind::BadGeometry, detail));
    }
    points(geometry)
}

/// The points of `geometry`.
pub(crate) fn points(geometry: Option<&Geometry>) -> Result<FeaturePoints, GeometryProblem> {
    let Some(g) = present(geometry) else {
        return Err((DiagnosticKind::NullGeometry, "the feature has no geometry".to_owned()));
    };
    if g.is_empty() {
        return Err((DiagnosticKind::EmptyGeometry, format!("empty {}", type_name(Some(g)))));
    }
    let mut out = FeaturePoints::default();
    match geometry_type_flatten(g.geometry_type()) {
        OGRwkbGeometryType::wkbPoint => out.points.push(xy(g)?),
        OGRwkbGeometryType::wkbMultiPoint => {
            for i in 0..g.geometry_count() {
                let part = g.get_geometry(i);
                if !part.is_empty() {
                    out.points.push(xy(&part)?);
                }
            }
            if out.points.len() > 1 {
                let detail = format!("{} points, each read as its own object", out.points.len());
                out.notes.push((DiagnosticKind::MultiPoint, detail));
            }
        }
        _ => return Err((DiagnosticKind::NotAPoint, format!("a {} where a point was expected", type_name(Some(g))))),
    }
    if geometry_type_has_z(g.geometry_type()) {
        out.notes.push((DiagnosticKind::HeightDropped, format!("{}: height dropped", type_name(Some(g)))));
    }
    Ok(out)
}

fn xy(point: &Geometry) -> Result<[f64; 2], GeometryProblem> {
    let (x, y, _) = point.get_point(0);
    if x.is_finite() && y.is_finite() {
        Ok([x, y])
    } else {
        Err((DiagnosticKind::BadCoordinate, format!("coordinates ({x}, {y}) are not finite")))
    }
}
