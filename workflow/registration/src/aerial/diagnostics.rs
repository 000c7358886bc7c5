//! Why an aerial image or a whole MM patch was not used: typed, serialisable, part of the tile result.

use std::fmt;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// What happened with one aerial image overlapping the recording location.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct AerialImageDiagnostic {
    /// Frame (or orthophoto) id.
    pub frame: String,
    /// Whether the initial transformation was found and passed the plausibility check (Jende et al. 2017 §3.7).
    pub passed: bool,
    /// Why the image contributed no correspondences (None = it did).
    pub rejection: Option<ImageRejection>,
    /// KAZE correspondences supporting the initial transformation.
    pub initial_inliers: usize,
    /// NCC of the whole-patch correlation when it replaced a failed KAZE transformation.
    pub fallback_ncc: Option<f64>,
    /// Ground offset the initial transformation implies against the DG georeferencing, metres.
    pub offset_m: Option<f64>,
    /// MM corners whose template lies on valid MM cells and whose transfer lands in the aerial patch.
    pub candidates: usize,
    /// Candidates matched by NCC above the threshold (before RANSAC).
    pub matched: usize,
    /// Correspondences kept after RANSAC and the consistency check (Jende et al. 2017 §3.8).
    pub correspondences: usize,
}

/// Why one aerial image was not used.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ImageRejection {
    /// Too few KAZE features to match in the MM or the aerial patch.
    FewFeatures {
        /// Features in the MM patch.
        mm: usize,
        /// Features in the aerial patch.
        aerial: usize,
    },
    /// No similarity with enough KAZE inliers (Jende et al. 2017 §3.7).
    NoTransform {
        /// Descriptor matches tried.
        matches: usize,
        /// Inliers of the best transformation.
        inliers: usize,
    },
    /// The initial transformation failed the plausibility check (Jende et al. 2017 §3.7).
    Implausible {
        /// Ground offset implied, metres.
        offset_m: f64,
        /// Largest accepted offset, metres.
        bound_m: f64,
        /// Rotation against the expected orientation, degrees.
        rotation_deg: f64,
        /// Scale against the expected one.
        scale: f64,
    },
    /// Fewer corner correspondences than required (Jende et al. 2017 §3.8: ten).
    TooFewCorrespondences {
        /// Correspondences left.
        found: usize,
        /// Correspondences required.
        needed: usize,
    },
    /// The aerial image is unusable (its size does not match its camera).
    InvalidImage {
        /// What is wrong.
        reason: String,
    },
    /// Less than a quarter of the aerial patch lies inside the image.
    PatchOutside,
    /// An image primitive failed (message of the imaging error).
    Imaging {
        /// What failed.
        message: String,
    },
}

impl fmt::Display for ImageRejection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::FewFeatures { mm, aerial } => write!(f, "too few KAZE features (MM {mm}, aerial {aerial})"),
            Self::NoTransform { matches, inliers } => {
                write!(f, "no initial transformation ({inliers} inliers of {matches} matches)")
            }
            Self::Implausible { offset_m, bound_m, rotation_deg, scale } => write!(
                f,
                "implausible initial transformation: offset {offset_m:.2} m (bound {bound_m:.2} m), \
                 rotation {rotation_deg:.2}°, scale {scale:.3}"
            ),
            Self::TooFewCorrespondences { found, needed } => {
                write!(f, "{found} correspondences, {needed} needed")
            }
            Self::InvalidImage { reason } => write!(f, "invalid aerial image: {reason}"),
            Self::PatchOutside => write!(f, "the aerial patch lies mostly outside the image"),
            Self::Imaging { message } => write!(f, "imaging: {message}"),
        }
    }
}

/// Why a whole MM patch produced no aerial points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum AerialDiscard {
    /// The patch itself is unusable (no points, sizes disagree, non-finite values).
    InvalidPatch {
        /// What is wrong.
        reason: String,
    },
    /// No aerial image covers the recording location.
    NoOverlap,
    /// Fewer aerial images than required passed the initial transformation (Jende et al. 2017 §3.7).
    TooFewPlausible {
        /// Images that passed.
        passed: usize,
        /// Images required.
        needed: usize,
    },
    /// Fewer aerial images than required kept correspondences, or fewer correspondences than required
    /// remained in all images together (Jende et al. 2017 §3.8).
    TooFewCorrespondences {
        /// Images with correspondences.
        images: usize,
        /// Images required.
        needed: usize,
        /// Correspondences kept in all images together (0 in results written before it was reported).
        #[serde(default)]
        correspondences: usize,
        /// Correspondences required in all images together.
        #[serde(default)]
        needed_correspondences: usize,
    },
    /// Matching succeeded but no point survived the triangulation's blunder checks (Jende et al. 2017 §3.9).
    NoTriangulatedPoints,
}

impl fmt::Display for AerialDiscard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidPatch { reason } => write!(f, "invalid MM patch: {reason}"),
            Self::NoOverlap => write!(f, "no aerial image overlaps the recording location"),
            Self::TooFewPlausible { passed, needed } => {
                write!(f, "{passed} aerial images passed the initial transformation, {needed} needed")
            }
            Self::TooFewCorrespondences { images, needed, correspondences, needed_correspondences } => write!(
                f,
                "{correspondences} correspondences in {images} aerial images kept, \
                 {needed_correspondences} in {needed} images needed"
            ),
            Self::NoTriangulatedPoints => write!(f, "no point survived the triangulation's blunder checks"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diagnostics_serialise_with_a_kind_tag_and_read_back() {
        let d = AerialImageDiagnostic {
            frame: "aerial0007".into(),
            passed: true,
            rejection: Some(ImageRejection::TooFewCorrespondences { found: 4, needed: 10 }),
            initial_inliers: 23,
            fallback_ncc: None,
            offset_m: Some(0.81),
            candidates: 30,
            matched: 12,
            correspondences: 4,
        };
        let json = serde_json::to_value(&d).unwrap();
        assert_eq!(json["rejection"]["kind"], "too_few_correspondences");
        assert_eq!(serde_json::from_value::<AerialImageDiagnostic>(json).unwrap(), d);
        let why = AerialDiscard::TooFewPlausible { passed: 1, needed: 2 };
        let json = serde_json::to_string(&why).unwrap();
        assert_eq!(json, r#"{"kind":"too_few_plausible","passed":1,"needed":2}"#);
        assert_eq!(why.to_string(), "1 aerial images passed the initial transformation, 2 needed");
        let schema = serde_json::to_value(schemars::schema_for!(AerialImageDiagnostic)).unwrap();
        assert!(schema.to_string().contains("implausible"), "{schema}");
    }
}
