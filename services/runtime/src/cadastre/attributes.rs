//! A feature's class (fixed, or from the class attribute through `class_values`) and diameter.

use gdal::vector::{Defn, Feature, FieldValue};
use plumbline_campaign::DiagnosticKind;
use plumbline_campaign::manifest::{Cadastre, PoleClass};

/// Diameters above this are taken for a unit error (centimetres), not a pole or trunk, metres.
pub const MAX_DIAMETER_M: f64 = 5.0;

/// A problem with one attribute: kind, field name, details.
pub(crate) type AttributeProblem = (DiagnosticKind, String, String);

/// Where a layer's classes and diameters come from.
#[derive(Debug)]
pub(crate) struct Fields<'a> {
    class: ClassSource<'a>,
    diameter: Option<(usize, &'a str)>,
    spec: &'a Cadastre,
}

#[derive(Debug)]
enum ClassSource<'a> {
    Fixed(PoleClass),
    Attribute(usize, &'a str),
}

impl<'a> Fields<'a> {
    /// Finds the manifest's attributes among the layer's fields. A missing class attribute stops the
    /// layer (`Err`); a missing diameter attribute is returned as a problem and the layer is read without.
    pub(crate) fn resolve(
        defn: &Defn,
        spec: &'a Cadastre,
    ) -> Result<(Self, Option<AttributeProblem>), AttributeProblem> {
        let missing = |name: &str| {
            let names: Vec<String> = defn.fields().map(|f| f.name()).collect();
            (DiagnosticKind::MissingField, name.to_owned(), format!("no such field; the layer has {names:?}"))
        };
        let class = match (spec.class, spec.class_attribute.as_deref()) {
            (Some(class), _) => ClassSource::Fixed(class),
            (None, Some(name)) => ClassSource::Attribute(defn.field_index(name).map_err(|_| missing(name))?, name),
            (None, None) => return Err((DiagnosticKind::MissingField, "class".into(), "no class is given".into())),
        };
        let (mut diameter, mut problem) = (None, None);
        if let Some(name) = spec.diameter_attribute.as_deref() {
            match defn.field_index(name) {
                Ok(index) => diameter = Some((index, name)),
                Err(_) => problem = Some(missing(name)),
            }
        }
        Ok((Self { class, diameter, spec }, problem))
    }

    /// The feature's class.
    pub(crate) fn class(&self, feature: &Feature) -> Result<PoleClass, AttributeProblem> {
        let (index, name) = match self.class {
            ClassSource::Fixed(class) => return Ok(class),
            ClassSource::Attribute(index, name) => (index, name),
        };
        let problem = |kind, detail: String| (kind, name.to_owned(), detail);
        let text = match feature.field(index) {
            Ok(Some(value)) => value_text(value),
            Ok(None) => return Err(problem(DiagnosticKind::NullClass, "null".into())),
            Err(e) => return Err(problem(DiagnosticKind::UnknownClass, format!("unreadable value: {e}"))),
        };
        let text = text.map_err(|t| problem(DiagnosticKind::UnknownClass, format!("a {t} value")))?;
        if text.is_empty() {
            return Err(problem(DiagnosticKind::NullClass, "empty".into()));
        }
        let class = if self.spec.class_values.is_empty() {
            class_name(&text)
        } else {
            self.spec.class_values.get(&text).copied()
        };
        class.ok_or_else(|| {
            let known = if self.spec.class_values.is_empty() { "a class name" } else { "listed in class_values" };
            problem(DiagnosticKind::UnknownClass, format!("{text:?} is not {known}"))
        })
    }

    /// The feature's diameter in metres: `Ok(None)` without a diameter attribute; `Err` (the feature is
    /// still used, without diameter) for a null, non-numeric, non-positive or implausible value.
    pub(crate) fn diameter(&self, feature: &Feature) -> Result<Option<f64>, AttributeProblem> {
        let Some((index, name)) = self.diameter else { return Ok(None) };
        let problem = |kind, detail: String| (kind, name.to_owned(), detail);
        let value = match feature.field(index) {
            Ok(Some(FieldValue::RealValue(v))) => v,
            Ok(Some(FieldValue::IntegerValue(v))) => f64::from(v),
            Ok(Some(FieldValue::Integer64Value(v))) => v as f64,
            Ok(Some(FieldValue::StringValue(s))) => s
                .trim()
                .parse::<f64>()
                .map_err(|_| problem(DiagnosticKind::BadDiameter, format!("{s:?} is not a number")))?,
            Ok(None) => return Err(problem(DiagnosticKind::NullDiameter, "null".into())),
            Ok(Some(other)) => return Err(problem(DiagnosticKind::BadDiameter, format!("{other:?} is not a number"))),
            Err(e) => return Err(problem(DiagnosticKind::BadDiameter, format!("unreadable value: {e}"))),
        };
        if value.is_finite() && value > 0.0 && value <= MAX_DIAMETER_M {
            Ok(Some(value))
        } else {
            Err(problem(DiagnosticKind::BadDiameter, format!("{value} is not in (0, {MAX_DIAMETER_M}] m")))
        }
    }
}

/// A class attribute's value as text: strings trimmed, integers (and integral reals) as digits.
/// `Err` names the type of a value that is neither.
pub(crate) fn value_text(value: FieldValue) -> Result<String, &'static str> {
    match value {
        FieldValue::StringValue(s) => Ok(s.trim().to_owned()),
        FieldValue::IntegerValue(v) => Ok(v.to_string()),
        FieldValue::Integer64Value(v) => Ok(v.to_string()),
        FieldValue::RealValue(v) if v.fract() == 0.0 && v.abs() < 1e15 => Ok(format!("{v:.0}")),
        FieldValue::RealValue(_) => Err("fractional number"),
        FieldValue::DateValue(_) | FieldValue::DateTimeValue(_) => Err("date"),
        _ => Err("list"),
    }
}

/// `pole`, `light`, `sign`, `tree` (any case) as a class.
fn class_name(text: &str) -> Option<PoleClass> {
    match text.to_ascii_lowercase().as_str() {
        "pole" => Some(PoleClass::Pole),
        "light" => Some(PoleClass::Light),
        "sign" => Some(PoleClass::Sign),
        "tree" => Some(PoleClass::Tree),
        _ => None,
    }
}
