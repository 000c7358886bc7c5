//! Plain values read from a cadastre: pole-like objects in the campaign CRS and the counted
//! diagnostics of the features that could not be used as read (Meyer et al. 2023 §3.3.2, §4.1).
//!
//! Pure data + serde so workers and reports use them without GDAL; `plumbline-runtime` fills them.

use std::collections::BTreeMap;
use std::fmt;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::manifest::PoleClass;

/// Which object of a cadastre a feature is: unique within one cadastre of a manifest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, JsonSchema)]
pub struct CadastreFeatureId {
    /// Index of the layer in the manifest's `layers`.
    pub layer: u32,
    /// The GeoPackage feature id (FID).
    pub fid: u64,
    /// Index of the point within a multipoint; 0 for a point.
    pub part: u32,
}

/// One pole-like object, as control: a 2D position in the campaign CRS with its accuracy.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CadastreFeature {
    /// Which object this is.
    pub id: CadastreFeatureId,
    /// Its class, from the manifest's `class` or its `class_attribute`.
    pub class: PoleClass,
    /// Easting in the campaign CRS, metres.
    pub easting: f64,
    /// Northing in the campaign CRS, metres.
    pub northing: f64,
    /// Standard deviation of the 2D position, metres (Meyer et al. 2023 §4.1: poles 0.10, trees 0.50).
    pub accuracy_m: f64,
    /// Diameter, metres, when the manifest names a diameter attribute and the feature has a value.
    pub diameter_m: Option<f64>,
}

/// What was wrong with a layer or feature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum DiagnosticKind {
    /// A layer named in the manifest is not in the file.
    MissingLayer,
    /// A layer has no features at all.
    EmptyLayer,
    /// A layer has no SRS and the manifest gives no EPSG override.
    MissingSrs,
    /// A layer's SRS cannot be transformed into the campaign CRS (e.g. a local engineering CRS).
    UnknownSrs,
    /// An attribute named in the manifest is not a field of the layer.
    MissingField,
    /// A feature has no geometry.
    NullGeometry,
    /// A feature's geometry is empty (`POINT EMPTY`).
    EmptyGeometry,
    /// A polygon, line or collection where a point was expected.
    NotAPoint,
    /// A multipoint with several points: each point is read as its own object.
    MultiPoint,
    /// A 3D point: its height is dropped.
    HeightDropped,
    /// A coordinate is NaN or infinite, or cannot be transformed into the campaign CRS.
    BadCoordinate,
    /// The class attribute is null or empty.
    NullClass,
    /// The class value is neither a class name nor listed in `class_values`.
    UnknownClass,
    /// The diameter attribute is null.
    NullDiameter,
    /// The diameter attribute is not a positive finite number (wrong type or value).
    BadDiameter,
    /// A feature's geometry is stored but cannot be decoded (a damaged geometry blob).
    BadGeometry,
    /// Reading the layer stopped early on a damaged file (e.g. a corrupted database page).
    ReadFailed,
    /// The manifest's `epsg` differs from the SRS the layer has (the layer's own is used).
    SrsConflict,
}

impl DiagnosticKind {
    /// Every kind.
    pub const ALL: [Self; 18] = [
        Self::MissingLayer,
        Self::EmptyLayer,
        Self::MissingSrs,
        Self::UnknownSrs,
        Self::MissingField,
        Self::NullGeometry,
        Self::EmptyGeometry,
        Self::NotAPoint,
        Self::MultiPoint,
        Self::HeightDropped,
        Self::BadCoordinate,
        Self::NullClass,
        Self::UnknownClass,
        Self::NullDiameter,
        Self::BadDiameter,
        Self::BadGeometry,
        Self::ReadFailed,
        Self::SrsConflict,
    ];

    /// The kind's name in files (as serde writes it).
    pub const fn name(self) -> &'static str {
        match self {
            Self::MissingLayer => "missing_layer",
            Self::EmptyLayer => "empty_layer",
            Self::MissingSrs => "missing_srs",
            Self::UnknownSrs => "unknown_srs",
            Self::MissingField => "missing_field",
            Self::NullGeometry => "null_geometry",
            Self::EmptyGeometry => "empty_geometry",
            Self::NotAPoint => "not_a_point",
            Self::MultiPoint => "multi_point",
            Self::HeightDropped => "height_dropped",
            Self::BadCoordinate => "bad_coordinate",
            Self::NullClass => "null_class",
            Self::UnknownClass => "unknown_class",
            Self::NullDiameter => "null_diameter",
            Self::BadDiameter => "bad_diameter",
            Self::BadGeometry => "bad_geometry",
            Self::ReadFailed => "read_failed",
            Self::SrsConflict => "srs_conflict",
        }
    }
}

/// What happened to the item a diagnostic names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Consequence {
    /// The whole layer was not read.
    LayerSkipped,
    /// The feature was not used.
    FeatureSkipped,
    /// The layer or feature was still used, as documented for the kind (e.g. without a diameter).
    Kept,
}

/// One counted problem, naming file, layer, feature id and field.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CadastreDiagnostic {
    /// What was wrong.
    pub kind: DiagnosticKind,
    /// What happened to the layer or feature.
    pub consequence: Consequence,
    /// The file (path or URL as the caller named it).
    pub file: String,
    /// The layer.
    pub layer: String,
    /// The feature id, for feature-level problems.
    pub fid: Option<u64>,
    /// The attribute, for attribute problems.
    pub field: Option<String>,
    /// Details: the value found, the geometry type, the GDAL message.
    pub detail: String,
}

impl fmt::Display for CadastreDiagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: layer {:?}", self.file, self.layer)?;
        if let Some(fid) = self.fid {
            write!(f, ", feature {fid}")?;
        }
        if let Some(field) = &self.field {
            write!(f, ", field {field:?}")?;
        }
        write!(f, ": {:?} ({:?}): {}", self.kind, self.consequence, self.detail)
    }
}

/// How many diagnostics of each kind `diagnostics` holds.
pub fn count_diagnostics(diagnostics: &[CadastreDiagnostic]) -> BTreeMap<DiagnosticKind, usize> {
    let mut counts = BTreeMap::new();
    for d in diagnostics {
        *counts.entry(d.kind).or_insert(0) += 1;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn diagnostic(kind: DiagnosticKind, fid: Option<u64>) -> CadastreDiagnostic {
        let consequence = Consequence::FeatureSkipped;
        let (file, layer, field, detail) = ("a.gpkg".into(), "lights".into(), Some("art".into()), "x".into());
        CadastreDiagnostic { kind, consequence, file, layer, fid, field, detail }
    }

    #[test]
    fn counts_by_kind_and_display_names_file_layer_fid_field() {
        let list = [
            diagnostic(DiagnosticKind::NullGeometry, Some(3)),
            diagnostic(DiagnosticKind::UnknownClass, Some(4)),
            diagnostic(DiagnosticKind::NullGeometry, Some(9)),
        ];
        let counts = count_diagnostics(&list);
        assert_eq!(counts[&DiagnosticKind::NullGeometry], 2);
        assert_eq!(counts[&DiagnosticKind::UnknownClass], 1);
        assert_eq!(counts.len(), 2);
        let text = list[1].to_string();
        assert!(text.contains("a.gpkg") && text.contains("\"lights\"") && text.contains("feature 4"), "{text}");
        assert!(text.contains("\"art\"") && text.contains("UnknownClass"), "{text}");
    }

    #[test]
    fn kind_names_are_the_serde_names() {
        for kind in DiagnosticKind::ALL {
            assert_eq!(serde_json::to_value(kind).ok(), Some(serde_json::Value::from(kind.name())));
        }
    }

    #[test]
    fn serde_round_trip_uses_snake_case_kinds() {
        let d = diagnostic(DiagnosticKind::HeightDropped, None);
        let json = serde_json::to_string(&d).unwrap();
        assert!(json.contains("\"height_dropped\""), "{json}");
        assert_eq!(serde_json::from_str::<CadastreDiagnostic>(&json).unwrap(), d);
    }
}
