//! The `[[cadastres]]` of a manifest: GeoPackage point layers of pole-like objects (street lights,
//! sign posts, trees) used as 2D control, each with a class and an accuracy per class.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::epsg::Epsg;
use crate::location::Location;
use crate::manifest::trajectory::check_file_epsg;
use crate::problem::{Checker, FieldPath};

/// One GeoPackage with one or more point layers of pole-like objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Cadastre {
    /// The GeoPackage file (`.gpkg`).
    pub url: Location,
    /// Names of the point layers to read; at least one.
    #[schemars(length(min = 1))]
    pub layers: Vec<String>,
    /// Attribute holding each object's class; its values are class names (`pole`, `light`, `sign`,
    /// `tree`) unless `class_values` maps them. Give this or `class`.
    pub class_attribute: Option<String>,
    /// Maps values of `class_attribute` to classes, e.g. { "Lichtmast" = "light" }; values not
    /// listed are skipped.
    #[serde(default)]
    pub class_values: BTreeMap<String, PoleClass>,
    /// The class of every object in these layers. Give this or `class_attribute`.
    pub class: Option<PoleClass>,
    /// Standard deviation of the objects' 2D positions per class, metres.
    #[serde(default)]
    pub accuracy: ClassAccuracy,
    /// Attribute holding the object's diameter in metres (e.g. a trunk), when the layers have one.
    pub diameter_attribute: Option<String>,
    /// EPSG code of the layers' coordinates, only for files whose SRS is missing.
    pub epsg: Option<Epsg>,
}

/// Kinds of pole-like objects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum PoleClass {
    /// Utility and electricity poles, bollards.
    Pole,
    /// Street lights.
    Light,
    /// Sign posts and traffic lights.
    Sign,
    /// Tree trunks.
    Tree,
}

/// 2D position standard deviation of cadastre objects by class, metres; Meyer et al. 2023 §4.1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ClassAccuracy {
    /// Poles, metres.
    #[serde(default = "default_pole_accuracy_m")]
    pub poles: f64,
    /// Street lights, metres.
    #[serde(default = "default_pole_accuracy_m")]
    pub lights: f64,
    /// Sign posts, metres.
    #[serde(default = "default_pole_accuracy_m")]
    pub signs: f64,
    /// Trees (unknown trunk diameter, trunks not vertical), metres.
    #[serde(default = "default_tree_accuracy_m")]
    pub trees: f64,
}

fn default_pole_accuracy_m() -> f64 {
    0.10
}
fn default_tree_accuracy_m() -> f64 {
    0.50
}

impl Default for ClassAccuracy {
    fn default() -> Self {
        let pole = default_pole_accuracy_m();
        Self { poles: pole, lights: pole, signs: pole, trees: default_tree_accuracy_m() }
    }
}

impl ClassAccuracy {
    /// The standard deviation for objects of `class`, metres.
    pub fn of(&self, class: PoleClass) -> f64 {
        match class {
            PoleClass::Pole => self.poles,
            PoleClass::Light => self.lights,
            PoleClass::Sign => self.signs,
            PoleClass::Tree => self.trees,
        }
    }

    fn check(&self, at: &FieldPath, c: &mut Checker) {
        let named = [("poles", self.poles), ("lights", self.lights), ("signs", self.signs), ("trees", self.trees)];
        for (name, value) in named {
            c.positive(&at.field(name), value, 10.0, " m");
        }
    }
}

impl Cadastre {
    pub(crate) fn check(&self, at: &FieldPath, c: &mut Checker) {
        c.location(&at.field("url"), &self.url);
        if self.url.extension().as_deref() != Some("gpkg") {
            c.report(&at.field("url"), format!("{} is not a .gpkg file", self.url), "a GeoPackage (.gpkg)");
        }
        self.check_layers(&at.field("layers"), c);
        self.check_class(at, c);
        self.accuracy.check(&at.field("accuracy"), c);
        if let Some(name) = &self.diameter_attribute {
            c.not_blank(&at.field("diameter_attribute"), name);
        }
        if let Some(epsg) = self.epsg {
            check_file_epsg(&at.field("epsg"), epsg, c);
        }
    }

    fn check_layers(&self, at: &FieldPath, c: &mut Checker) {
        if self.layers.is_empty() {
            c.report(at, "no layer is named", "at least one layer name, e.g. layers = [\"strassenbeleuchtung\"]");
        }
        for (i, layer) in self.layers.iter().enumerate() {
            c.not_blank(&at.index(i), layer);
            if self.layers[..i].contains(layer) {
                c.report(&at.index(i), format!("layer {layer:?} is listed twice"), "each layer once");
            }
        }
    }

    fn check_class(&self, at: &FieldPath, c: &mut Checker) {
        match (&self.class_attribute, self.class) {
            (None, None) => c.report(at, "neither class_attribute nor class is given", "one of them"),
            (Some(_), Some(_)) => {
                c.report(&at.field("class"), "both class_attribute and class are given", "only one of them")
            }
            (Some(name), None) => c.not_blank(&at.field("class_attribute"), name),
            (None, Some(_)) if !self.class_values.is_empty() => c.report(
                &at.field("class_values"),
                "given without class_attribute",
                "class_values only with class_attribute",
            ),
            (None, Some(_)) => {}
        }
    }
}
