//! The `parameters` of a manifest: algorithm settings grouped by stage, each with the default the
//! papers use, so that a manifest names only what it changes.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::manifest::aerial::AERIAL_GSD_RANGE_M;
use crate::problem::{Checker, FieldPath};

/// Algorithm parameters by stage.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Parameters {
    /// Registration of street-level and aerial images (Jende et al. 2017).
    #[serde(default)]
    pub registration: Registration,
    /// Pole detection and cadastre matching (Meyer et al. 2023).
    #[serde(default)]
    pub poles: PoleParameters,
    /// Global trajectory adjustment.
    #[serde(default)]
    pub adjustment: Adjustment,
}

/// Parameters of the MM↔MM and MM↔aerial registration; Jende et al. 2017 §3.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Registration {
    /// Ground sampling distance of the panoramas' ortho-projection for MM↔MM matching, metres (§3.2).
    #[serde(default = "default_mm_gsd_m")]
    pub mm_gsd_m: f64,
    /// Ground sampling distance for MM↔aerial matching, metres; by default `aerial.frames.gsd_m`,
    /// else 0.12 (§3.2).
    pub aerial_gsd_m: Option<f64>,
    /// Aerial images a transformation must be plausible in before an MM image is kept (§3.7), unless
    /// `single_aerial_rays` lets one do.
    #[serde(default = "default_min_aerial_images")]
    pub min_aerial_images: u32,
    /// Where only one aerial frame passes (a block flown at 60 % / 30 % overlap shows many street points in
    /// two frames only), its points still count, each as its single aerial ray: the adjustment takes the
    /// position across the ray from it and the height from the panoramas (§3.9 triangulates from two).
    /// `false`: `min_aerial_images` frames are required.
    #[serde(default = "default_true")]
    pub single_aerial_rays: bool,
    /// Correspondences an MM↔aerial image pair needs to count (§3.8).
    #[serde(default = "default_min_correspondences")]
    pub min_correspondences: u32,
}

/// Parameters of pole detection; Meyer et al. 2023.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PoleParameters {
    /// Poles farther from the sensor are not detected, metres (depth camera range, §3.1.2).
    #[serde(default = "default_pole_max_range_m")]
    pub max_range_m: f64,
}

/// Parameters of the global least-squares adjustment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Adjustment {
    /// Robust loss that down-weights large residuals.
    #[serde(default)]
    pub loss: RobustLoss,
    /// Huber threshold in standardised residuals (used when `loss` is `huber`).
    #[serde(default = "default_huber_k")]
    pub huber_k: f64,
    /// Significance level of data snooping (Baarda's test on standardised residuals).
    #[serde(default = "default_snooping_alpha")]
    pub snooping_alpha: f64,
    /// Gauss–Newton iterations at most.
    #[serde(default = "default_max_iterations")]
    pub max_iterations: u32,
    /// Use the image-derived motion between consecutive panoramas (Jende et al. 2017 §3.3) as relative observations
    /// of the trajectory, besides flagging DG jumps with it; `false` uses it for the flags only.
    #[serde(default = "default_image_motions")]
    pub image_motions: bool,
}

/// Robust loss of the adjustment.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum RobustLoss {
    /// Plain least squares.
    None,
    /// Huber: quadratic up to `huber_k`, linear beyond.
    #[default]
    Huber,
}

fn default_mm_gsd_m() -> f64 {
    0.03
}
fn default_min_aerial_images() -> u32 {
    2
}
fn default_min_correspondences() -> u32 {
    10
}
fn default_pole_max_range_m() -> f64 {
    10.0
}
fn default_huber_k() -> f64 {
    1.5
}
fn default_snooping_alpha() -> f64 {
    0.001
}
fn default_max_iterations() -> u32 {
    20
}
fn default_image_motions() -> bool {
    true
}

fn default_true() -> bool {
    true
}

impl Default for Registration {
    fn default() -> Self {
        Self {
            mm_gsd_m: default_mm_gsd_m(),
            aerial_gsd_m: None,
            min_aerial_images: default_min_aerial_images(),
            single_aerial_rays: true,
            min_correspondences: default_min_correspondences(),
        }
    }
}

impl Default for PoleParameters {
    fn default() -> Self {
        Self { max_range_m: default_pole_max_range_m() }
    }
}

impl Default for Adjustment {
    fn default() -> Self {
        Self {
            loss: RobustLoss::default(),
            huber_k: default_huber_k(),
            snooping_alpha: default_snooping_alpha(),
            max_iterations: default_max_iterations(),
            image_motions: default_image_motions(),
        }
    }
}

impl Parameters {
    pub(crate) fn check(&self, at: &FieldPath, c: &mut Checker) {
        let registration = at.field("registration");
        let r = &self.registration;
        c.in_range(&registration.field("mm_gsd_m"), r.mm_gsd_m, 0.005, 0.5, " m");
        if let Some(gsd) = r.aerial_gsd_m {
            let (min, max) = AERIAL_GSD_RANGE_M;
            c.in_range(&registration.field("aerial_gsd_m"), gsd, min, max, " m");
        }
        c.count(&registration.field("min_aerial_images"), r.min_aerial_images, 1, 100);
        c.count(&registration.field("min_correspondences"), r.min_correspondences, 3, 100_000);
        c.positive(&at.field("poles").field("max_range_m"), self.poles.max_range_m, 200.0, " m");
        let adjustment = at.field("adjustment");
        let a = &self.adjustment;
        c.positive(&adjustment.field("huber_k"), a.huber_k, 10.0, "");
        c.positive(&adjustment.field("snooping_alpha"), a.snooping_alpha, 0.1, "");
        c.count(&adjustment.field("max_iterations"), a.max_iterations, 1, 1_000);
    }
}
