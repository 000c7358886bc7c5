//! `read_cadastre`: a manifest's cadastre layers into pole-like objects in the campaign CRS.

use gdal::spatial_ref::SpatialRef;
use gdal::vector::{Feature, Layer, LayerAccess};
use plumbline_campaign::manifest::{Cadastre, PoleClass};
use plumbline_campaign::{CadastreDiagnostic, CadastreFeature, CadastreFeatureId, Consequence, DiagnosticKind, Epsg};

use super::attributes::Fields;
use super::geometry;
use super::srs::{self, LayerFrame, LayerSrs};
use super::walk::{Diagnostics, stopped_early, walk_features};
use super::{CadastreError, CadastreRead, CadastreSource, LayerCounts, OpenCadastre};

/// Reads the layers `spec` names from `source` into the campaign CRS `campaign`.
///
/// With `bbox = Some([min_x, min_y, max_x, max_y])` in the campaign CRS, only objects inside the
/// closed box are returned: GDAL's spatial filter (the box's enclosing rectangle in the layer's CRS)
/// preselects, and the exact test follows reprojection. Features the filter excludes (including those
/// without geometry) are not examined. Layer order and FIDs give a stable order.
pub fn read_cadastre(
    source: CadastreSource<'_>,
    spec: &Cadastre,
    campaign: Epsg,
    bbox: Option<[f64; 4]>,
) -> Result<CadastreRead, CadastreError> {
    if let Some(b) = bbox
        && !(b.iter().all(|v| v.is_finite()) && b[0] <= b[2] && b[1] <= b[3])
    {
        return Err(CadastreError::BadBox { bbox: b });
    }
    let campaign_srs =
        srs::from_epsg(campaign.0).map_err(|source| CadastreError::CampaignCrs { epsg: campaign, source })?;
    let open = OpenCadastre::open(source)?;
    let mut reader = Reader {
        file: source.name(),
        spec,
        campaign_srs,
        bbox,
        out: CadastreRead::default(),
        diagnostics: Diagnostics::default(),
    };
    for (index, name) in spec.layers.iter().enumerate() {
        let counts = reader.layer(&open, index, name);
        reader.out.layers.push(counts);
    }
    reader.out.diagnostics = reader.diagnostics.finish();
    Ok(reader.out)
}

/// A feature as GDAL handed it out, with the GDAL failures raised while fetching it.
#[derive(Debug, Clone, Copy)]
struct Fetched<'a, 'f> {
    fid: u64,
    feature: &'a Feature<'f>,
    failures: &'a [String],
}

/// One object waiting for reprojection.
#[derive(Debug)]
struct Pending {
    id: CadastreFeatureId,
    xy: [f64; 2],
    class: PoleClass,
    diameter_m: Option<f64>,
}

#[derive(Debug)]
struct Reader<'a> {
    file: String,
    spec: &'a Cadastre,
    campaign_srs: SpatialRef,
    bbox: Option<[f64; 4]>,
    out: CadastreRead,
    diagnostics: Diagnostics,
}

impl Reader<'_> {
    fn layer(&mut self, open: &OpenCadastre, index: usize, name: &str) -> LayerCounts {
        let mut counts = LayerCounts { layer: name.to_owned(), ..LayerCounts::default() };
        let Ok(mut layer) = open.dataset.layer_by_name(name) else {
            let names: Vec<String> = open.dataset.layers().map(|l| l.name()).collect();
            self.layer_problem(name, DiagnosticKind::MissingLayer, None, format!("the file has layers {names:?}"));
            return counts;
        };
        if layer.defn().geom_fields().count() == 0 {
            let detail = "the layer is a table without geometry column".to_owned();
            self.layer_problem(name, DiagnosticKind::NotAPoint, None, detail);
            return counts;
        }
        let own_srs = LayerSrs::classify(layer.spatial_ref());
        if let (LayerSrs::Defined { epsg: Some(own), .. }, Some(given)) = (&own_srs, self.spec.epsg)
            && *own != given.0
        {
            let detail = format!(
                "the layer's own SRS is EPSG:{own}, the manifest's epsg is {given}: the layer's own is used (`epsg` \
                 only supplies a missing SRS)"
            );
            self.push(name, DiagnosticKind::SrsConflict, Consequence::Kept, None, None, detail);
        }
        let frame = match LayerFrame::resolve(own_srs, self.spec.epsg, &self.campaign_srs) {
            Ok(frame) => frame,
            Err((kind, detail)) => {
                self.layer_problem(name, kind, None, detail);
                return counts;
            }
        };
        let fields = match Fields::resolve(layer.defn(), self.spec) {
            Ok((fields, problem)) => {
                if let Some((kind, field, detail)) = problem {
                    self.push(name, kind, Consequence::Kept, None, Some(field), detail);
                }
                fields
            }
            Err((kind, field, detail)) => {
                self.layer_problem(name, kind, Some(field), detail);
                return counts;
            }
        };
        counts.read = true;
        if layer.feature_count() == 0 {
            self.push(name, DiagnosticKind::EmptyLayer, Consequence::Kept, None, None, "no features".into());
            return counts;
        }
        let layer_index = u32::try_from(index).unwrap_or(u32::MAX);
        let pending = self.features(&mut layer, &frame, &fields, layer_index, &mut counts);
        self.project(name, &frame, pending, &mut counts);
        counts
    }

    fn features(
        &mut self,
        layer: &mut Layer<'_>,
        frame: &LayerFrame,
        fields: &Fields<'_>,
        layer_index: u32,
        counts: &mut LayerCounts,
    ) -> Vec<Pending> {
        if let Some(bbox) = self.bbox {
            match frame.bbox_in_layer(bbox) {
                Some(b) => layer.set_spatial_filter_rect(b[0], b[1], b[2], b[3]),
                // The box cannot be expressed in the layer's CRS: read everything, filter exactly below.
                None => layer.clear_spatial_filter(),
            }
        }
        let name = layer.name();
        let announced = if self.bbox.is_none() { layer.feature_count() } else { 0 };
        let mut pending = Vec::new();
        let end = walk_features(layer, |fid, feature, failures| {
            counts.examined += 1;
            let fetched = Fetched { fid, feature, failures };
            if !self.feature(&name, &fetched, fields, layer_index, &mut pending) {
                counts.skipped += 1;
            }
        });
        if let Some(d) = stopped_early(&self.file, &name, &end, announced) {
            self.diagnostics.push(d);
        }
        pending
    }

    /// Adds the feature's objects to `pending`; false when it was skipped.
    fn feature(
        &mut self,
        layer: &str,
        fetched: &Fetched<'_, '_>,
        fields: &Fields<'_>,
        layer_index: u32,
        pending: &mut Vec<Pending>,
    ) -> bool {
        let Fetched { fid, feature, failures } = *fetched;
        let points = match geometry::points_fetched(feature.geometry(), failures) {
            Ok(points) => points,
            Err((kind, detail)) => {
                self.push(layer, kind, Consequence::FeatureSkipped, Some(fid), None, detail);
                return false;
            }
        };
        let class = match fields.class(feature) {
            Ok(class) => class,
            Err((kind, field, detail)) => {
                self.push(layer, kind, Consequence::FeatureSkipped, Some(fid), Some(field), detail);
                return false;
            }
        };
        for (kind, detail) in points.notes {
            self.push(layer, kind, Consequence::Kept, Some(fid), None, detail);
        }
        let diameter_m = fields.diameter(feature).unwrap_or_else(|(kind, field, detail)| {
            self.push(layer, kind, Consequence::Kept, Some(fid), Some(field), detail);
            None
        });
        for (part, xy) in points.points.into_iter().enumerate() {
            let id = CadastreFeatureId { layer: layer_index, fid, part: u32::try_from(part).unwrap_or(u32::MAX) };
            pending.push(Pending { id, xy, class, diameter_m });
        }
        true
    }

    /// Reprojects the layer's objects, then applies the exact box test.
    fn project(&mut self, layer: &str, frame: &LayerFrame, pending: Vec<Pending>, counts: &mut LayerCounts) {
        let xy: Vec<[f64; 2]> = pending.iter().map(|p| p.xy).collect();
        let projected = frame.to_campaign(&xy);
        let mut failed_fid = None;
        for (p, position) in pending.into_iter().zip(projected) {
            let Some([easting, northing]) = position else {
                let detail = format!("({}, {}) cannot be transformed into the campaign CRS", p.xy[0], p.xy[1]);
                self.push(
                    layer,
                    DiagnosticKind::BadCoordinate,
                    Consequence::FeatureSkipped,
                    Some(p.id.fid),
                    None,
                    detail,
                );
                if failed_fid != Some(p.id.fid) {
                    counts.skipped += 1;
                }
                failed_fid = Some(p.id.fid);
                continue;
            };
            if !self.bbox.is_none_or(|b| b[0] <= easting && easting <= b[2] && b[1] <= northing && northing <= b[3]) {
                counts.outside_bbox += 1;
                continue;
            }
            let accuracy_m = self.spec.accuracy.of(p.class); // Meyer et al. 2023 §4.1
            counts.used += 1;
            let feature =
                CadastreFeature { id: p.id, class: p.class, easting, northing, accuracy_m, diameter_m: p.diameter_m };
            self.out.features.push(feature);
        }
    }

    fn layer_problem(&mut self, layer: &str, kind: DiagnosticKind, field: Option<String>, detail: String) {
        self.push(layer, kind, Consequence::LayerSkipped, None, field, detail);
    }

    fn push(
        &mut self,
        layer: &str,
        kind: DiagnosticKind,
        consequence: Consequence,
        fid: Option<u64>,
        field: Option<String>,
        detail: String,
    ) {
        let (file, layer) = (self.file.clone(), layer.to_owned());
        self.diagnostics.push(CadastreDiagnostic { kind, consequence, file, layer, fid, field, detail });
    }
}
