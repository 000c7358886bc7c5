//! Street-level imagery of a manifest: the equirectangular `panoramas`, the `[[depth]]` cameras and
//! their mounts on the vehicle, and the LAS/LAZ `point_clouds`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::location::Location;
use crate::problem::{Checker, FieldPath};

/// Longest plausible lever-arm component on a vehicle, metres.
const MAX_LEVER_ARM_M: f64 = 10.0;

/// Where a camera sits on the vehicle, in the vehicle body frame (x forward, y right, z down).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraMount {
    /// Lever arm [x, y, z] from the navigation reference point to the camera centre, metres.
    pub lever_arm_m: [f64; 3],
    /// Boresight angles [roll, pitch, yaw] from the body frame to the camera frame, degrees.
    pub boresight_deg: [f64; 3],
}

/// Equirectangular panoramas taken along the trajectory.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Panoramas {
    /// Index CSV with one row per image: image id, time (trajectory time scale), file.
    pub index: Location,
    /// Prefix the index's file names are relative to.
    pub images: Location,
    /// Image width in pixels, when all images share it (read from the files otherwise).
    pub width_px: Option<u32>,
    /// Image height in pixels, when all images share it (read from the files otherwise).
    pub height_px: Option<u32>,
    /// The panoramic camera's mount.
    pub mount: CameraMount,
    /// Mask image hiding the vehicle (non-zero = vehicle), same size as the panoramas.
    pub vehicle_mask: Option<Location>,
    /// Height of the camera centre above the road surface, metres: the ground plane the panoramas are
    /// ortho-projected onto (Jende et al. 2017 §3.2). Required for aerial registration unless a terrain model
    /// is given.
    pub camera_height_m: Option<f64>,
    /// For panoramas stitched from a ring of cameras: the ring (each camera's own centre makes near ground
    /// shift between the slices; the ortho-projection undoes it).
    pub rig: Option<StitchedRig>,
    /// A rolling shutter: seconds from the readout of a panorama's top row to its bottom row's, the
    /// panorama's time being its middle row's (cameras whose sensor rows run along the panorama's rows).
    /// The ortho-projection then sees each ground point from where the vehicle was when its row was read.
    /// Absent or 0: all rows read at once.
    pub readout_s: Option<f64>,
}

/// A panoramic rig of cameras in a ring around the horizon, stitched at infinity into the equirectangular
/// image: camera k images the k-th of `cameras` equal slices of the columns (the first from column 0) from
/// its own centre, `radius_m` out along its optical axis (the middle of its slice, on the horizon row).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StitchedRig {
    /// Cameras in the ring, 2–32.
    pub cameras: u32,
    /// Distance of each camera's centre from the panorama's centre, metres (0–1).
    pub radius_m: f64,
}

/// A depth (range) camera taking 16-bit PNG depth images along the trajectory.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DepthCamera {
    /// Index CSV with one row per image: image id, time (trajectory time scale), file.
    pub index: Location,
    /// Prefix the index's file names are relative to.
    pub images: Location,
    /// The pinhole model and value range of the depth images.
    pub intrinsics: DepthIntrinsics,
    /// The depth camera's mount.
    pub mount: CameraMount,
    /// Standard deviation of a depth as a share of the depth (0.08 = 8 %); Meyer et al. 2023 §3.1.2.
    #[serde(default = "default_range_error_share")]
    pub range_error_share: f64,
}

/// Pinhole intrinsics of a depth camera and how to read its 16-bit values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DepthIntrinsics {
    /// Focal length along image x, pixels.
    pub fx: f64,
    /// Focal length along image y, pixels.
    pub fy: f64,
    /// Principal point x, pixels from the left edge.
    pub cx: f64,
    /// Principal point y, pixels from the top edge.
    pub cy: f64,
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Metres per unit of the 16-bit depth values.
    #[serde(default = "default_depth_scale_m")]
    pub depth_scale_m: f64,
    /// Depths below this are discarded, metres.
    #[serde(default = "default_min_range_m")]
    pub min_range_m: f64,
    /// Depths beyond this are discarded, metres.
    #[serde(default = "default_max_range_m")]
    pub max_range_m: f64,
}

fn default_range_error_share() -> f64 {
    0.08
}
fn default_depth_scale_m() -> f64 {
    0.001
}
fn default_min_range_m() -> f64 {
    0.4
}
fn default_max_range_m() -> f64 {
    10.0
}

impl CameraMount {
    pub(crate) fn check(&self, at: &FieldPath, c: &mut Checker) {
        for (i, value) in self.lever_arm_m.into_iter().enumerate() {
            c.in_range(&at.field("lever_arm_m").index(i), value, -MAX_LEVER_ARM_M, MAX_LEVER_ARM_M, " m");
        }
        for (i, value) in self.boresight_deg.into_iter().enumerate() {
            c.in_range(&at.field("boresight_deg").index(i), value, -360.0, 360.0, " deg");
        }
    }
}

impl Panoramas {
    pub(crate) fn check(&self, at: &FieldPath, c: &mut Checker) {
        c.location(&at.field("index"), &self.index);
        c.location(&at.field("images"), &self.images);
        if let Some(mask) = &self.vehicle_mask {
            c.location(&at.field("vehicle_mask"), mask);
        }
        if let Some(width) = self.width_px {
            c.count(&at.field("width_px"), width, 2, 65_536);
        }
        if let Some(height) = self.height_px {
            c.count(&at.field("height_px"), height, 1, 32_768);
        }
        if let (Some(width), Some(height)) = (self.width_px, self.height_px)
            && u64::from(width) != 2 * u64::from(height)
        {
            let found = format!("{width} × {height} px is not 2:1");
            c.report(&at.field("width_px"), found, "an equirectangular size: width_px = 2 × height_px");
        }
        self.mount.check(&at.field("mount"), c);
        if let Some(height) = self.camera_height_m {
            c.in_range(&at.field("camera_height_m"), height, 0.5, 10.0, " m");
        }
        if let Some(readout) = self.readout_s {
            c.in_range(&at.field("readout_s"), readout, 0.0, 0.5, " s");
        }
        if let Some(rig) = &self.rig {
            c.count(&at.field("rig").field("cameras"), rig.cameras, 2, 32);
            c.in_range(&at.field("rig").field("radius_m"), rig.radius_m, 0.0, 1.0, " m");
        }
    }
}

impl DepthCamera {
    pub(crate) fn check(&self, at: &FieldPath, c: &mut Checker) {
        c.location(&at.field("index"), &self.index);
        c.location(&at.field("images"), &self.images);
        self.intrinsics.check(&at.field("intrinsics"), c);
        self.mount.check(&at.field("mount"), c);
        c.positive(&at.field("range_error_share"), self.range_error_share, 1.0, "");
    }
}

impl DepthIntrinsics {
    fn check(&self, at: &FieldPath, c: &mut Checker) {
        c.count(&at.field("width_px"), self.width_px, 1, 16_384);
        c.count(&at.field("height_px"), self.height_px, 1, 16_384);
        c.positive(&at.field("fx"), self.fx, 100_000.0, " px");
        c.positive(&at.field("fy"), self.fy, 100_000.0, " px");
        c.in_range(&at.field("cx"), self.cx, 0.0, f64::from(self.width_px), " px");
        c.in_range(&at.field("cy"), self.cy, 0.0, f64::from(self.height_px), " px");
        c.positive(&at.field("depth_scale_m"), self.depth_scale_m, 1.0, " m");
        c.positive(&at.field("min_range_m"), self.min_range_m, 1_000.0, " m");
        c.positive(&at.field("max_range_m"), self.max_range_m, 1_000.0, " m");
        if self.min_range_m >= self.max_range_m {
            let found = format!("{} m is not below max_range_m ({} m)", self.min_range_m, self.max_range_m);
            c.report(&at.field("min_range_m"), found, "min_range_m < max_range_m");
        }
    }
}
