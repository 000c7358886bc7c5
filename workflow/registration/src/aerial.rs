//! Steps 5–8 of Jende et al. 2017 §3: MM patch ↔ aerial images, from the initial transformation to the multi-image
//! triangulation, and the same registration against a georeferenced orthophoto.
//!
//! [`register_patch`] takes one MM patch (the north-up 3 cm ortho-image of a panorama and its corners with
//! DG-derived mapping coordinates) and the aerial reference, and returns the corners' aerial-derived mapping
//! coordinates with covariances plus a diagnostic per overlapping aerial image.
//!
//! Stages, each in its own module: `prepare` (§3.6 resampling, rotation, blur; §3.7 Wallis), `view`
//! (projection into the block, local orientation and windows), `initial` (§3.7 KAZE + RANSAC and the
//! plausibility check; `guided`: descriptor matching within the DG bound; `pooled`: one offset from the KAZE
//! matches of all windows of a patch at once) with `correlate` (a whole-patch NCC fallback when KAZE finds no
//! transformation), `correspond` (§3.8 NCC + LSM, RANSAC, cross-image consistency), `joint` (§3.8 RANSAC
//! over all images of a patch), `triangulate` (§3.9), `points` (§3.9 over a patch, or the orthophoto +
//! terrain lookup), `trace` (what §3.8 did, for diagnosis), `image` (steps 5–7 for one aerial image; a
//! DG-bounded corner search when no initial transformation passes) and `register` (the driver: overlapping
//! images, one prepared MM patch per aerial orientation, images in parallel). Beside them: `config` (the
//! settings, with the paper's values where it gives them), `diagnostics` (why an image or a patch was not
//! used, typed, part of the tile result) and `consensus` (the translation consensus and how many inliers make
//! it significant, shared by `initial`, `pooled` and `joint`; it imports no stage).
//!
//! Architecture invariant: I/O-free and deterministic (seeded RANSAC, no clocks); one broken aerial image
//! or patch is reported in the outcome, never a panic or an error that sinks the tile.

mod config;
mod consensus;
mod correlate;
mod correspond;
mod diagnostics;
mod guided;
mod image;
mod initial;
mod joint;
mod points;
mod pooled;
mod prepare;
mod register;
mod trace;
mod triangulate;
mod view;

#[cfg(test)]
mod tests;

pub use config::{AerialConfig, FrameReach, Plausibility, edge_roundness};
pub use diagnostics::{AerialDiscard, AerialImageDiagnostic, ImageRejection};
pub use initial::{PlausibilityCheck, check_plausibility};
pub use register::register_patch;
pub use trace::{Attempt, ImageTrace};
pub use triangulate::{Ray, Triangulated, TriangulationError, triangulate};

use plumbline_geo::MapFromCamera;
use plumbline_geo::camera::Pinhole;
use plumbline_imaging::ortho::GroundGrid;
use plumbline_imaging::{GrayImage, Mask};

/// One aerial frame image with its exterior orientation (from aerial triangulation) and interior.
#[derive(Clone, Debug)]
pub struct AerialFrame {
    /// Image id, reported in diagnostics and observations.
    pub id: String,
    /// The gray pixels: the whole frame, or the window of it that a tile needs (see `origin`). They must lie
    /// within the camera's `width` × `height`.
    pub image: GrayImage,
    /// Full-frame column and row of `image`'s pixel (0, 0): zero for a whole frame.
    pub origin: [usize; 2],
    /// Interior orientation.
    pub camera: Pinhole,
    /// Exterior orientation: camera (computer-vision axes) to map.
    pub pose: MapFromCamera,
}

/// A terrain model on its own grid: heights in metres, row-major, with GDAL's six-number geotransform.
#[derive(Clone, Debug)]
pub struct Terrain {
    /// Heights, metres (`width · height` values, row-major; non-finite = no data).
    pub heights: Vec<f32>,
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// GDAL geotransform: E = g0 + u·g1 + v·g2, N = g3 + u·g4 + v·g5 (u, v continuous pixels).
    pub geotransform: [f64; 6],
}

/// A georeferenced orthophoto (+ optional terrain model) used instead of frames (a window of it around
/// the recording location, as the services read it from a GeoTIFF/COG).
#[derive(Clone, Debug)]
pub struct Orthophoto {
    /// Id reported in diagnostics and observations.
    pub id: String,
    /// The gray image (or a window of the full orthophoto).
    pub image: GrayImage,
    /// GDAL geotransform of `image`: E = g0 + u·g1 + v·g2, N = g3 + u·g4 + v·g5.
    pub geotransform: [f64; 6],
    /// Terrain heights; without it the patch's own (DG-derived) height is used with a large σ.
    pub terrain: Option<Terrain>,
}

/// What MM patches are registered against.
#[derive(Clone, Debug)]
pub enum AerialReference {
    /// Frame images of an aerial block with their orientations.
    Frames(Vec<AerialFrame>),
    /// A true orthophoto with a terrain model.
    Orthophoto(Orthophoto),
}

/// The MM side of one panorama: its north-up ortho-image at 3 cm (Jende et al. 2017 §3.2) and the corners found in
/// it, each with the mapping coordinates triangulated from two panoramas with DG poses (§3.5).
#[derive(Clone, Copy, Debug)]
pub struct MmPatch<'a> {
    /// The ortho-image.
    pub image: &'a GrayImage,
    /// Cells that received a sample (not off-image, not the vehicle).
    pub valid: &'a Mask,
    /// Where the ortho-image lies (DG georeferencing).
    pub grid: &'a GroundGrid,
    /// The corners to register.
    pub points: &'a [PatchPoint],
    /// 1σ horizontal uncertainty of the DG position (m), for the plausibility check's bound.
    pub position_sigma: f64,
}

/// One corner of the MM patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchPoint {
    /// Caller's id of the point, returned in [`AerialPointResult::index`].
    pub index: usize,
    /// Continuous pixel in the MM ortho-image.
    pub pixel: [f64; 2],
    /// E, N, H from the MM triangulation with DG poses (§3.5).
    pub map: [f64; 3],
    /// The ground's rise at the point from under the camera (the terrain model's, `mm::OrthoPatch`; 0 on a
    /// level plane): the aerial steps meet a ray at the patch's ground height plus this.
    pub rise: f64,
}

/// The result of registering one MM patch.
#[derive(Clone, Debug)]
pub struct AerialOutcome {
    /// Points matched in ≥ 2 aerial images (1 orthophoto) and triangulated (§3.9); empty when discarded.
    pub points: Vec<AerialPointResult>,
    /// One entry per overlapping aerial image.
    pub images: Vec<AerialImageDiagnostic>,
    /// Why the whole patch was discarded (None = matched).
    pub discarded: Option<AerialDiscard>,
    /// What §3.8 did with every corner, per entry of `images` (for diagnosis against ground truth).
    pub trace: Vec<ImageTrace>,
}

/// One MM point with its aerial-derived mapping coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct AerialPointResult {
    /// [`PatchPoint::index`].
    pub index: usize,
    /// E, N, H from the multi-image triangulation (or orthophoto + terrain).
    pub position: [f64; 3],
    /// Covariance of `position`, m².
    pub covariance: [[f64; 3]; 3],
    /// The aerial image points it was triangulated from.
    pub observations: Vec<AerialObservation>,
}

/// The point's position in one aerial image.
#[derive(Clone, Debug, PartialEq)]
pub struct AerialObservation {
    /// Frame (or orthophoto) id.
    pub frame: String,
    /// Continuous pixel in the full aerial image.
    pub pixel: [f64; 2],
}
