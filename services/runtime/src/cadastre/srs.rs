//! A cadastre layer's SRS: missing, unknown or usable, the manifest's EPSG override, and the
//! transformations between the layer's coordinates and the campaign CRS (both in GIS axis order).

use gdal::spatial_ref::{AxisMappingStrategy, CoordTransform, SpatialRef};
use plumbline_campaign::{DiagnosticKind, Epsg};

/// A layer's SRS as the file states it.
#[derive(Debug)]
pub(crate) enum LayerSrs {
    /// No SRS, or GeoPackage's "Undefined geographic/Cartesian SRS" (srs_id 0 / -1).
    Missing,
    /// An SRS, with its EPSG code when it has one.
    Defined { srs: SpatialRef, epsg: Option<u32>, name: String },
}

impl LayerSrs {
    /// Classifies the layer's SRS as GDAL reports it.
    pub(crate) fn classify(srs: Option<SpatialRef>) -> Self {
        let Some(srs) = srs else { return Self::Missing };
        let name = srs.name().unwrap_or_default();
        let epsg = match srs.auth_name().as_deref() {
            Some("EPSG") => srs.auth_code().ok().and_then(|c| u32::try_from(c).ok()),
            _ => None,
        };
        if epsg.is_none() && name.starts_with("Undefined ") {
            return Self::Missing;
        }
        Self::Defined { srs, epsg, name }
    }
}

/// Transformations layer CRS ↔ campaign CRS.
#[derive(Debug)]
pub(crate) struct LayerFrame {
    to_campaign: CoordTransform,
    from_campaign: CoordTransform,
}

/// Why a layer's coordinates cannot be placed in the campaign CRS.
pub(crate) type SrsProblem = (DiagnosticKind, String);

/// GIS axis order (x = longitude/easting) for `srs`, as GeoPackage stores coordinates.
pub(crate) fn gis_order(mut srs: SpatialRef) -> SpatialRef {
    srs.set_axis_mapping_strategy(AxisMappingStrategy::TraditionalGisOrder);
    srs
}

/// The SRS of `epsg` in GIS axis order.
pub(crate) fn from_epsg(epsg: u32) -> Result<SpatialRef, gdal::errors::GdalError> {
    crate::gdal_messages::route_gdal_messages();
    SpatialRef::from_epsg(epsg).map(gis_order)
}

impl LayerFrame {
    /// The frame of a layer: its own SRS when usable, else the manifest's `override_epsg`.
    pub(crate) fn resolve(
        layer: LayerSrs,
        override_epsg: Option<Epsg>,
        campaign: &SpatialRef,
    ) -> Result<Self, SrsProblem> {
        let own = match layer {
            LayerSrs::Missing => Err((DiagnosticKind::MissingSrs, "the layer has no SRS".to_owned())),
            LayerSrs::Defined { srs, name, .. } => Self::between(gis_order(srs), campaign)
                .map_err(|e| (DiagnosticKind::UnknownSrs, format!("SRS {name:?} cannot be transformed: {e}"))),
        };
        match (own, override_epsg) {
            (Ok(frame), _) => Ok(frame),
            (Err((kind, detail)), None) => Err((kind, format!("{detail}, and the manifest gives no epsg"))),
            (Err(_), Some(epsg)) => from_epsg(epsg.0)
                .map_err(|e| e.to_string())
                .and_then(|srs| Self::between(srs, campaign))
                .map_err(|e| (DiagnosticKind::UnknownSrs, format!("the manifest's {epsg} is unusable: {e}"))),
        }
    }

    fn between(layer: SpatialRef, campaign: &SpatialRef) -> Result<Self, String> {
        if layer.is_local() {
            return Err("a local engineering CRS has no relation to the campaign CRS".to_owned());
        }
        let to_campaign = CoordTransform::new(&layer, campaign).map_err(|e| e.to_string())?;
        let from_campaign = CoordTransform::new(campaign, &layer).map_err(|e| e.to_string())?;
        Ok(Self { to_campaign, from_campaign })
    }

    /// Transforms points into the campaign CRS; `None` for each point that cannot be transformed.
    pub(crate) fn to_campaign(&self, points: &[[f64; 2]]) -> Vec<Option<[f64; 2]>> {
        let mut xs: Vec<f64> = points.iter().map(|p| p[0]).collect();
        let mut ys: Vec<f64> = points.iter().map(|p| p[1]).collect();
        if points.is_empty() {
            return Vec::new();
        }
        if self.to_campaign.transform_coords(&mut xs, &mut ys, &mut []).is_ok() {
            return xs.into_iter().zip(ys).map(|(x, y)| finite([x, y])).collect();
        }
        // One bad point fails the whole batch: redo point by point to find it.
        points.iter().map(|p| self.one(*p)).collect()
    }

    fn one(&self, p: [f64; 2]) -> Option<[f64; 2]> {
        let (mut x, mut y) = ([p[0]], [p[1]]);
        self.to_campaign.transform_coords(&mut x, &mut y, &mut []).ok()?;
        finite([x[0], y[0]])
    }

    /// A rectangle in the layer's CRS that encloses the campaign-CRS `bbox`, with a margin of 1 % of
    /// its size or 10⁻⁶ of its coordinates (edges densified, a superset; the exact test follows reprojection).
    pub(crate) fn bbox_in_layer(&self, bbox: [f64; 4]) -> Option<[f64; 4]> {
        let b = self.from_campaign.transform_bounds(&bbox, 21).ok()?;
        // Relative margin too: a box of one point must still catch that point after the round trip.
        let scale = b.iter().fold(1e-9_f64, |m, v| m.max(1e-6 * v.abs()));
        let (mx, my) = ((0.01 * (b[2] - b[0])).max(scale), (0.01 * (b[3] - b[1])).max(scale));
        let b = [b[0] - mx, b[1] - my, b[2] + mx, b[3] + my];
        b.iter().all(|v| v.is_finite()).then_some(b)
    }
}

fn finite(p: [f64; 2]) -> Option<[f64; 2]> {
    (p[0].is_finite() && p[1].is_finite()).then_some(p)
}
