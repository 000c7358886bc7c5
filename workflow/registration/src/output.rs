//! Step 9 of Jende et al. 2017 §3: the versioned per-tile result — tie observations for the adjustment
//! (`plumbline_adjustment::TiePoint`) and a diagnostic per panorama saying what each step found and why an
//! image was discarded. Schema: `schemas/tile-result.v1.schema.json`.

use std::collections::BTreeMap;
use std::fmt;

use plumbline_adjustment::TiePoint;
use plumbline_geo::tiling::TileId;
use plumbline_navigation::ImageMotion;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::aerial::{AerialDiscard, AerialImageDiagnostic};
use crate::mm::TransformSource;

/// The result of registering one tile, versioned on the wire (`"version": "1"`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
pub enum TileResult {
    /// Version 1.
    #[serde(rename = "1")]
    V1(TileResultV1),
}

impl TileResult {
    /// The newest version's content (upgrading older ones when there are any).
    pub fn into_latest(self) -> TileResultV1 {
        match self {
            TileResult::V1(v) => v,
        }
    }
}

/// Version 1 of the tile result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TileResultV1 {
    /// The tile.
    pub tile: TileId,
    /// Tie points: rays from two panoramas, with aerial-derived coordinates when matched (Jende et al. 2017 §3.9).
    pub ties: Vec<TiePoint>,
    /// One diagnostic per panorama, in time order.
    pub images: Vec<ImageDiagnostic>,
    /// Counts over the tile.
    pub summary: TileSummary,
}

/// What the pipeline found for one panorama (its MM patch is the ortho-image of this panorama).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImageDiagnostic {
    /// Panorama id.
    pub image: String,
    /// Exposure time, seconds.
    pub time: f64,
    /// The panorama it was paired with (Jende et al. 2017 §3.3), if any.
    pub neighbour: Option<String>,
    /// The MM↔MM transformation used and why (KAZE or the orientation-based fallback).
    pub transform: Option<TransformSource>,
    /// The vehicle's motion between this panorama and its neighbour (in time order) measured by the KAZE
    /// similarity, also when it disagreed with the DG poses (Jende et al. 2017 §3.3, Cazzaniga et al. 2007 §4.1);
    /// None when KAZE + RANSAC found no similarity with enough inliers and unit scale.
    #[serde(default)]
    pub motion: Option<ImageMotion>,
    /// True when the cross-panorama check (Jende et al. 2017 §3.9) found `motion` contradicted by the aerial offsets:
    /// every comparison of matched panoramas across it disagreed by one shared residual. Not to be used as
    /// a relative observation.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub motion_contradicted: bool,
    /// Corner counts through steps 3–4.
    pub corners: CornerCounts,
    /// One entry per aerial image overlapping the recording location (Jende et al. 2017 §3.7–§3.8).
    pub aerial_images: Vec<AerialImageDiagnostic>,
    /// Points with aerial-derived coordinates.
    pub aerial_points: usize,
    /// Ties left out because they failed the adjustment's checks (non-unit ray, covariance not SPD).
    #[serde(default)]
    pub dropped_ties: usize,
    /// The aerial frames each of this panorama's aerial points was triangulated from (Jende et al. 2017 §3.9), one
    /// entry per tie with aerial coordinates; absent in results written before it existed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub aerial_frames: Vec<TieFrames>,
    /// The DG error measured here: where the aerial points put the panorama's MM points (Jende et al. 2017 §3.9);
    /// absent when it has no aerial points (and in results written before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aerial_offset: Option<AerialOffset>,
    /// What the cross-panorama check (Jende et al. 2017 §3.9) concluded about `aerial_offset`; absent when the
    /// check did not run on this panorama (not matched, or the check is off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cross_check: Option<CrossCheck>,
    /// Why no aerial points came from this panorama (None = matched).
    pub discarded: Option<DiscardReason>,
    /// Road markings extracted from the panorama's ortho patch, in DG map coordinates (placed with the
    /// corrected trajectory after the adjustment); empty when the extraction is off or found none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub strokes: Vec<plumbline_lines::Stroke>,
}

/// A panorama's aerial offset: the median horizontal difference (aerial-derived − MM position) over its
/// aerial points, the MM position being where the panorama's DG ortho-image shows the point. The MM side
/// carries the DG error, so this is minus the DG position error at the panorama (plus the heading error
/// times the points' lever, millimetres).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AerialOffset {
    /// East and north offset, metres.
    pub offset: [f64; 2],
    /// σ of east and north: 1.4826 · MAD / √n, at least the points' own median σ (they share frames).
    pub std: [f64; 2],
    /// Aerial points it is the median of.
    pub points: usize,
}

/// The cross-panorama check's verdict on one matched panorama's aerial offset (Jende et al. 2017 §3.9).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum CrossCheck {
    /// No other matched panorama is reachable through the image-derived motion chain: nothing to compare
    /// with, the offset is unverified (but kept).
    Unverified,
    /// Compared with its partners (the panoramas listed); a flagged panorama is also discarded as
    /// [`DiscardReason::Inconsistent`].
    Compared {
        /// Partners whose offsets agree with this one's through the chain.
        agreeing: Vec<String>,
        /// Partners whose offsets disagree.
        disagreeing: Vec<String>,
    },
}

/// One partner whose aerial offset disagrees with a panorama's (Jende et al. 2017 §3.9).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Disagreement {
    /// The partner panorama.
    pub partner: String,
    /// |(o_partner − o_this) − Σ chain change|, metres.
    pub residual_m: f64,
    /// The bound it exceeded, metres.
    pub tolerance_m: f64,
}

/// The aerial frames one tie point's aerial coordinates were triangulated from (the rays the multi-image
/// triangulation kept, Jende et al. 2017 §3.9), for the adjustment's per-frame-set height bias.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TieFrames {
    /// The tie point's id.
    pub tie: String,
    /// Frame ids, sorted, without duplicates.
    pub frames: Vec<String>,
}

/// Corner counts of one panorama pair.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CornerCounts {
    /// Förstner corners detected.
    pub detected: usize,
    /// Corners whose windows lie on valid cells of both ortho-images.
    pub candidates: usize,
    /// Corners matched by NCC + LSM.
    pub matched: usize,
    /// Matches triangulated and kept.
    pub triangulated: usize,
    /// Rejected: rays nearly parallel or behind a camera.
    pub rejected_geometry: usize,
    /// Rejected: rays pass each other too far apart.
    pub rejected_miss: usize,
    /// Rejected: point too far from the ground plane.
    pub rejected_off_ground: usize,
}

/// Why a panorama produced no aerial points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum DiscardReason {
    /// No other panorama of the tile lies within the pairing distance.
    NoNeighbour {
        /// Distance to the nearest panorama in time order, metres (None = it is alone).
        nearest_m: Option<f64>,
    },
    /// A step failed on this panorama's input.
    Failed {
        /// The step.
        step: String,
        /// What failed.
        message: String,
    },
    /// Too few corners were triangulated to attempt the aerial registration.
    TooFewMmPoints {
        /// Points triangulated.
        points: usize,
        /// Points required.
        needed: usize,
    },
    /// The aerial registration discarded the patch (Jende et al. 2017 §3.7–§3.9).
    Aerial(AerialDiscard),
    /// The aerial registration succeeded but its offset disagrees with the partners' offsets carried
    /// through the image-derived motion chain (the cross-panorama check of Jende et al. 2017 §3.9).
    Inconsistent {
        /// The partners it disagrees with and by how much.
        disagreements: Vec<Disagreement>,
        /// How many partners agree with it.
        agreeing: usize,
    },
}

impl DiscardReason {
    /// A short key for counting reasons (e.g. `aerial.too_few_plausible`).
    pub fn key(&self) -> String {
        match self {
            Self::NoNeighbour { .. } => "no_neighbour".into(),
            Self::Failed { step, .. } => format!("failed.{step}"),
            Self::TooFewMmPoints { .. } => "too_few_mm_points".into(),
            Self::Inconsistent { .. } => "inconsistent".into(),
            Self::Aerial(a) => {
                let kind = serde_json::to_value(a).ok().and_then(|v| v["kind"].as_str().map(str::to_owned));
                format!("aerial.{}", kind.unwrap_or_else(|| "other".into()))
            }
        }
    }
}

impl fmt::Display for DiscardReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoNeighbour { nearest_m: Some(d) } => write!(f, "no neighbour within range (nearest {d:.1} m)"),
            Self::NoNeighbour { nearest_m: None } => write!(f, "no other panorama in the tile"),
            Self::Failed { step, message } => write!(f, "{step} failed: {message}"),
            Self::TooFewMmPoints { points, needed } => write!(f, "{points} MM points triangulated, {needed} needed"),
            Self::Aerial(a) => write!(f, "{a}"),
            Self::Inconsistent { disagreements, agreeing } => {
                write!(f, "aerial offset inconsistent with")?;
                for (k, d) in disagreements.iter().enumerate() {
                    let sep = if k == 0 { "" } else { "," };
                    write!(f, "{sep} {} (residual {:.2} m > {:.2} m)", d.partner, d.residual_m, d.tolerance_m)?;
                }
                write!(f, "; {agreeing} partner(s) agree")
            }
        }
    }
}

/// Counts over a tile, in the terms of Jende et al. (2017), Table 1.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TileSummary {
    /// Panoramas in the tile.
    pub images: usize,
    /// Panoramas with aerial points.
    pub images_matched: usize,
    /// Tie points.
    pub ties: usize,
    /// Tie points with aerial coordinates (correspondences).
    pub ties_with_aerial: usize,
    /// Panoramas discarded, by reason key.
    pub discarded: BTreeMap<String, usize>,
}

impl TileSummary {
    /// Count the diagnostics and ties.
    pub fn of(images: &[ImageDiagnostic], ties: &[TiePoint]) -> Self {
        let mut discarded = BTreeMap::new();
        for reason in images.iter().filter_map(|d| d.discarded.as_ref()) {
            *discarded.entry(reason.key()).or_insert(0) += 1;
        }
        Self {
            images: images.len(),
            images_matched: images.iter().filter(|d| d.discarded.is_none()).count(),
            ties: ties.len(),
            ties_with_aerial: ties.iter().filter(|t| t.aerial.is_some()).count(),
            discarded,
        }
    }
}
