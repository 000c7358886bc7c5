//! Steps 1–4 of Jende et al. 2017 §3: ortho-projection, MM↔MM transformation, corner matching and triangulation.
//!
//! Inputs are decoded panoramas with their DG poses ([`Panorama`]) and the camera rig they share
//! ([`PanoramaRig`]); every step is a pure function of them and of [`MmConfig`].

pub mod corners;
pub mod motion;
pub mod ortho;
pub mod transform;
pub mod triangulate;

#[cfg(test)]
pub(crate) mod testing;

use std::sync::Arc;

use plumbline_geo::MapFromBody;
use plumbline_geo::camera::Equirectangular;
use plumbline_geo::dg::CameraMount;
use plumbline_imaging::corners::Foerstner;
use plumbline_imaging::kaze::KazeConfig;
pub use plumbline_imaging::ortho::SubCameras;
use plumbline_imaging::{GrayImage, ImagePart, ImagingError, Mask};

use crate::aerial::Terrain;

pub use corners::{CornerMatch, CornerMatches, match_corners};
pub use motion::image_motion;
pub use ortho::{OrthoPatch, ortho_patch, patch_part};
pub use transform::{
    FallbackReason, FeatureFit, PairTransform, TransformSource, features, orientation_transform, pair_transform,
};
pub use triangulate::{MmPoint, RayIntersection, TriangulationStats, intersect_rays, triangulate};

/// One equirectangular panorama as the pipeline receives it: decoded, with its DG pose.
#[derive(Clone, Debug)]
pub struct Panorama {
    /// Image id (unique within the campaign).
    pub id: String,
    /// Exposure time on the trajectory's time scale, seconds.
    pub time: f64,
    /// The gray panorama: the pixels of [`Panorama::part`] of the camera image ([`PanoramaRig::camera`]).
    pub image: GrayImage,
    /// Which pixels of the camera image `image` holds: the whole image, or what the ortho patch samples
    /// ([`ortho::patch_part`]), which is all a worker decodes.
    pub part: ImagePart,
    /// The vehicle pose at `time` from direct georeferencing (carries the DG error).
    pub pose: MapFromBody,
    /// 1σ horizontal uncertainty of the DG position, metres.
    pub position_sigma: f64,
    /// The vehicle's velocity at `time` (mapping frame: east, north, up; m/s) from the trajectory: what a
    /// rolling-shutter rig ([`PanoramaRig::readout_s`]) moved while reading the rows (`None`: unknown, the
    /// rows are taken as read at once).
    pub velocity: Option<[f64; 3]>,
}

/// What all panoramas of a campaign share: the camera model, its mounting and the vehicle mask.
#[derive(Clone, Debug)]
pub struct PanoramaRig {
    /// The equirectangular camera model (image size).
    pub camera: Equirectangular,
    /// Lever arm and boresight of the panoramic camera.
    pub mount: CameraMount,
    /// Pixels showing the vehicle itself (set = vehicle), same size as the panoramas.
    pub vehicle_mask: Option<Mask>,
    /// Height of the camera centre above the road, metres: places the ground plane of §3.2.
    pub camera_height: f64,
    /// A panorama stitched from a ring of cameras, each with its own centre: the ortho-projection sees each
    /// ground point from the camera that imaged it (`None`: one centre).
    pub sub_cameras: Option<SubCameras>,
    /// A terrain model (DTM) under the panoramas: the ortho-projection follows its relief around the ground
    /// under the camera instead of a level plane ([`OrthoPatch::height_at`]; `None`: the plane).
    pub terrain: Option<Arc<Terrain>>,
    /// Seconds from the readout of the panorama's top row to its bottom row's (a rolling shutter; the
    /// panorama's time is its middle row's). 0: a global shutter. The ortho-projection sees each ground
    /// point from where the rig was when its row was read ([`plumbline_imaging::ortho::RollingShutter`]).
    pub readout_s: f64,
}

/// Parameters of steps 1–4 (Jende et al. 2017 §3.2–§3.5); `Default` gives the paper's values where it states them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MmConfig {
    /// Ground sampling distance of the MM ortho-images, metres (Jende et al. 2017 §3.2: 3 cm).
    pub gsd: f64,
    /// Half the side of the square ortho-image around the camera, metres.
    pub half_extent: f64,
    /// KAZE settings: two octaves, upright, threshold tuned for ortho-images (Jende et al. 2017 §3.3).
    pub kaze: KazeConfig,
    /// Keypoints closer than this to an invalid ortho cell are dropped, pixels (their blobs see the mask edge).
    pub kaze_margin: usize,
    /// Radius around the DG-predicted position in which KAZE matches are sought, metres.
    pub guide_radius: f64,
    /// Nearest/second-nearest descriptor distance ratio.
    pub kaze_ratio: f32,
    /// RANSAC inlier threshold on the transfer error, ortho pixels.
    pub ransac_threshold: f64,
    /// Fewest RANSAC inliers for a feature-based transformation.
    pub min_kaze_inliers: usize,
    /// Largest disagreement, metres, between the feature-based and the orientation-based position of the
    /// first image's centre in the second image (Jende et al. 2017 §3.3's verification).
    pub max_disagreement: f64,
    /// Largest deviation of the similarity's scale from 1 (both ortho-images have the same GSD).
    pub max_scale_deviation: f64,
    /// σ added in quadrature to the image-derived motion's formal σ (Cazzaniga et al. 2007 §4.1): displacement (m),
    /// heading change (rad). It covers the errors features of one marking share, which the inlier residuals
    /// do not show. Default 1 cm (a third of the 3 cm ortho pixel) and 1 mrad (1 cm over 10 m): the
    /// registration bench measured errors of 7–8 mm / 0.6–0.9 mrad median and 28–43 mm / 2.8–4.0 mrad at
    /// 95 % (tiny, three GNSS profiles, seeds 1 and 2), 93–96 % of pairs within 3σ.
    pub motion_std_floor: [f64; 2],
    /// Förstner operator for the corners (Jende et al. 2017 §3.4).
    pub foerstner: Foerstner,
    /// Corners farther than this from the camera (horizontally, metres) are not matched: the panorama's
    /// ground resolution falls with range, and the patch beyond serves the aerial registration only.
    pub max_corner_distance: f64,
    /// Strongest corners kept per image.
    pub max_corners: usize,
    /// Half-size of the NCC/LSM template, pixels.
    pub template_half: usize,
    /// NCC search radius around the transferred corner with a feature-based transformation, pixels.
    pub search_radius: usize,
    /// NCC search radius with the orientation-based fallback, pixels (covers the relative DG error).
    pub fallback_search_radius: usize,
    /// Smallest accepted NCC coefficient.
    pub min_ncc: f64,
    /// Largest accepted LSM standard deviation of the matched position, pixels.
    pub max_lsm_std: f64,
    /// Largest distance between the LSM and the NCC position, pixels.
    pub max_lsm_shift: f64,
    /// Smallest intersection angle of the two rays, radians.
    pub min_ray_angle: f64,
    /// Largest distance of the triangulated point from either ray, metres.
    pub max_miss: f64,
    /// Largest height of a triangulated point above or below the ground plane, metres (kerbs, camber).
    pub max_height_offset: f64,
    /// Road-marking extraction from the ortho patch of every owned panorama (`None`: off); its strokes go
    /// into the panorama's diagnostic, in DG map coordinates, for the line product after the adjustment.
    pub lines: Option<plumbline_lines::ExtractConfig>,
    /// Strokes are kept within this horizontal distance of the camera, metres (cut there, the cut end
    /// open): the panorama's ground resolution falls with range.
    pub lines_max_distance: f64,
}

impl Default for MmConfig {
    fn default() -> Self {
        Self {
            gsd: 0.03,
            half_extent: 14.0,
            kaze: KazeConfig { octaves: 2, sublevels: 4, threshold: 0.0003, upright: true, ..KazeConfig::default() },
            kaze_margin: 12,
            guide_radius: 1.0,
            kaze_ratio: 0.9,
            ransac_threshold: 2.0,
            min_kaze_inliers: 12,
            max_disagreement: 0.3,
            max_scale_deviation: 0.03,
            motion_std_floor: [0.01, 1e-3],
            foerstner: Foerstner { min_weight_factor: 0.5, nms_radius: 5, ..Foerstner::default() },
            max_corner_distance: 20.0,
            max_corners: 400,
            template_half: 8,
            search_radius: 5,
            fallback_search_radius: 12,
            min_ncc: 0.8,
            max_lsm_std: 0.3,
            max_lsm_shift: 1.5,
            min_ray_angle: 2f64.to_radians(),
            max_miss: 0.08,
            max_height_offset: 0.5,
            lines: Some(plumbline_lines::ExtractConfig::default()),
            lines_max_distance: 10.0,
        }
    }
}

/// Errors of steps 1–4, naming the panorama and what failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MmError {
    /// The configuration or the rig is unusable.
    #[error("registration parameter `{field}` = {value}: {reason}")]
    Config { field: &'static str, value: f64, reason: &'static str },
    /// An image primitive failed on a panorama.
    #[error("panorama {image}: {step}: {source}")]
    Imaging {
        /// Panorama id.
        image: String,
        /// The step (e.g. "ortho-projection").
        step: &'static str,
        /// The primitive's error.
        source: ImagingError,
    },
}
