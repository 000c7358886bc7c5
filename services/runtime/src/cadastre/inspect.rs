//! `inspect_cadastre`: what a GeoPackage holds — layers, geometry types, CRS, fields, class values — and
//! the problems [`super::read_cadastre`] would meet, without a manifest.

use std::collections::BTreeMap;

use gdal::vector::{Layer, LayerAccess, field_type_to_name};
use plumbline_campaign::{CadastreDiagnostic, Consequence, DiagnosticKind};
use serde::Serialize;

use super::attributes::value_text;
use super::srs::{self, LayerSrs};
use super::walk::{Diagnostics, stopped_early, walk_features};
use super::{CadastreError, CadastreSource, OpenCadastre, geometry};

/// Distinct values listed per class field; the rest are counted as `other`.
const MAX_CLASS_VALUES: usize = 100;

/// What one file holds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CadastreInspection {
    /// The file as named by the caller.
    pub file: String,
    /// Every layer, in the file's order.
    pub layers: Vec<LayerInspection>,
    /// Every problem found, by layer and FID.
    pub diagnostics: Vec<CadastreDiagnostic>,
}

/// One layer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LayerInspection {
    /// The layer's name.
    pub name: String,
    /// Its CRS.
    pub crs: LayerCrs,
    /// Number of features.
    pub feature_count: usize,
    /// Features by geometry type name (`Point`, `3D Point`, `Multi Point`, `Polygon`, `none`).
    pub geometry_counts: BTreeMap<String, usize>,
    /// Attribute fields in order.
    pub fields: Vec<FieldInfo>,
    /// Values of the class attribute, or of text fields named like a class (class, type, art).
    pub class_values: Vec<ClassValues>,
}

/// A layer's CRS; both `None` when it has none.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct LayerCrs {
    /// The EPSG code, when the SRS has one.
    pub epsg: Option<u32>,
    /// The SRS's name.
    pub name: Option<String>,
}

/// An attribute field.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct FieldInfo {
    /// Field name.
    pub name: String,
    /// OGR type name (`String`, `Real`, `Integer`, …).
    pub type_name: String,
}

/// The values found in one class-like field.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ClassValues {
    /// Field name.
    pub field: String,
    /// Count per distinct value (at most 100 values).
    pub values: BTreeMap<String, usize>,
    /// Features whose value is null or empty.
    pub nulls: usize,
    /// Features with values beyond the first 100 distinct ones.
    pub other: usize,
}

impl ClassValues {
    /// Counts one feature's value; true when it is null or empty.
    fn count(&mut self, value: Option<String>) -> bool {
        match value.filter(|v| !v.is_empty()) {
            None => {
                self.nulls += 1;
                return true;
            }
            Some(v) if self.values.len() < MAX_CLASS_VALUES || self.values.contains_key(&v) => {
                *self.values.entry(v).or_insert(0) += 1;
            }
            Some(_) => self.other += 1,
        }
        false
    }
}

/// Inspects every layer of `source`; `class_attribute` names the class field (otherwise text fields
/// named like class/type/art are summarised). Fails only when the file cannot be opened as a GeoPackage.
pub fn inspect_cadastre(
    source: CadastreSource<'_>,
    class_attribute: Option<&str>,
) -> Result<CadastreInspection, CadastreError> {
    let open = OpenCadastre::open(source)?;
    let mut out = CadastreInspection { file: source.name(), layers: Vec::new(), diagnostics: Vec::new() };
    let mut diagnostics = Diagnostics::default();
    for mut layer in open.dataset.layers() {
        let mut sink = Sink { file: &out.file, layer: layer.name(), out: &mut diagnostics };
        let inspection = inspect_layer(&mut layer, class_attribute, &mut sink);
        out.layers.push(inspection);
    }
    out.diagnostics = diagnostics.finish();
    Ok(out)
}

/// Collects one layer's diagnostics.
#[derive(Debug)]
struct Sink<'a> {
    file: &'a str,
    layer: String,
    out: &'a mut Diagnostics,
}

impl Sink<'_> {
    fn report(
        &mut self,
        kind: DiagnosticKind,
        consequence: Consequence,
        fid: Option<u64>,
        field: Option<String>,
        detail: String,
    ) {
        let (file, layer) = (self.file.to_owned(), self.layer.clone());
        self.out.push(CadastreDiagnostic { kind, consequence, file, layer, fid, field, detail });
    }
}

fn inspect_layer(layer: &mut Layer<'_>, class_attribute: Option<&str>, sink: &mut Sink<'_>) -> LayerInspection {
    let crs = if layer.defn().geom_fields().count() == 0 {
        let detail = "the layer is a table without geometry column".to_owned();
        sink.report(DiagnosticKind::NotAPoint, Consequence::LayerSkipped, None, None, detail);
        LayerCrs { epsg: None, name: None }
    } else {
        layer_crs(layer, sink)
    };
    let fields: Vec<FieldInfo> = layer
        .defn()
        .fields()
        .map(|f| FieldInfo { name: f.name(), type_name: field_type_to_name(f.field_type()) })
        .collect();
    let class_fields = class_fields(&fields, class_attribute, sink);
    let mut class_values: Vec<ClassValues> = class_fields
        .iter()
        .map(|(_, name)| ClassValues { field: name.clone(), values: BTreeMap::new(), nulls: 0, other: 0 })
        .collect();
    let mut geometry_counts = BTreeMap::new();
    let mut feature_count = 0;
    let announced = layer.feature_count();
    let end = walk_features(layer, |fid, feature, failures| {
        feature_count += 1;
        *geometry_counts.entry(geometry::type_name(feature.geometry())).or_insert(0) += 1;
        match geometry::points_fetched(feature.geometry(), failures) {
            Ok(points) => {
                points.notes.into_iter().for_each(|(k, d)| sink.report(k, Consequence::Kept, Some(fid), None, d))
            }
            Err((kind, detail)) => sink.report(kind, Consequence::FeatureSkipped, Some(fid), None, detail),
        }
        for ((index, name), values) in class_fields.iter().zip(&mut class_values) {
            let value = feature.field(*index).ok().flatten().and_then(|v| value_text(v).ok());
            if values.count(value) && class_attribute.is_some() {
                let (kind, field) = (DiagnosticKind::NullClass, Some(name.clone()));
                sink.report(kind, Consequence::FeatureSkipped, Some(fid), field, "null or empty".into());
            }
        }
    });
    if let Some(d) = stopped_early(sink.file, &sink.layer, &end, announced) {
        sink.out.push(d);
    }
    if feature_count == 0 && end.stopped_by.is_none() {
        sink.report(DiagnosticKind::EmptyLayer, Consequence::Kept, None, None, "no features".into());
    }
    LayerInspection { name: layer.name(), crs, feature_count, geometry_counts, fields, class_values }
}

/// The layer's CRS, reporting a missing one or one that cannot be transformed to WGS 84.
fn layer_crs(layer: &Layer<'_>, sink: &mut Sink<'_>) -> LayerCrs {
    match LayerSrs::classify(layer.spatial_ref()) {
        LayerSrs::Missing => {
            sink.report(
                DiagnosticKind::MissingSrs,
                Consequence::LayerSkipped,
                None,
                None,
                "no SRS (a manifest epsg can supply it)".into(),
            );
            LayerCrs { epsg: None, name: None }
        }
        LayerSrs::Defined { srs: layer_srs, epsg, name } => {
            let usable = srs::from_epsg(4326).ok().is_some_and(|wgs84| {
                let layer_srs = srs::gis_order(layer_srs);
                !layer_srs.is_local() && gdal::spatial_ref::CoordTransform::new(&layer_srs, &wgs84).is_ok()
            });
            if !usable {
                let detail = format!("SRS {name:?} cannot be transformed to a geodetic CRS");
                sink.report(DiagnosticKind::UnknownSrs, Consequence::LayerSkipped, None, None, detail);
            }
            LayerCrs { epsg, name: Some(name) }
        }
    }
}

/// The fields whose values are summarised: the named class attribute, else text fields named like a class.
fn class_fields(fields: &[FieldInfo], class_attribute: Option<&str>, sink: &mut Sink<'_>) -> Vec<(usize, String)> {
    let chosen: Vec<(usize, String)> = fields
        .iter()
        .enumerate()
        .filter(|(_, f)| match class_attribute {
            Some(name) => f.name == name,
            None => f.type_name == "String" && looks_like_class(&f.name),
        })
        .map(|(i, f)| (i, f.name.clone()))
        .collect();
    if let Some(name) = class_attribute
        && chosen.is_empty()
    {
        let names: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
        sink.report(
            DiagnosticKind::MissingField,
            Consequence::LayerSkipped,
            None,
            Some(name.to_owned()),
            format!("no such field; the layer has {names:?}"),
        );
    }
    chosen
}

/// Field names that usually hold an object's class: class, klasse, type, typ, art (German), kategorie.
fn looks_like_class(name: &str) -> bool {
    let name = name.to_ascii_lowercase();
    ["class", "klass", "type", "typ", "kategor", "categor"].iter().any(|w| name.contains(w))
        || name == "art"
        || name.ends_with("art") && name.len() > 3 && !name.ends_with("start")
        || name.starts_with("art_")
}

#[cfg(test)]
mod tests {
    use super::looks_like_class;

    #[test]
    fn class_like_field_names() {
        for name in ["art", "Objektart", "ART_CODE", "klasse", "Typ", "object_type", "Kategorie", "class"] {
            assert!(looks_like_class(name), "{name}");
        }
        for name in ["name", "dm", "start", "height", "fid", "artikel"] {
            assert!(!looks_like_class(name), "{name}");
        }
    }
}
