//! The `aerial` section of a manifest: a block of frame images with their orientations, and/or an
//! orthophoto with its terrain model, against which the street-level images are registered.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::location::Location;
use crate::problem::{Checker, FieldPath};

/// Ground sampling distance of aerial images assumed when none is given, metres; Jende et al. 2017 §3.2.
pub const DEFAULT_AERIAL_GSD_M: f64 = 0.12;

/// Sane ground sampling distances of aerial images, metres.
pub(crate) const AERIAL_GSD_RANGE_M: (f64, f64) = (0.01, 1.0);

/// The aerial imagery of the campaign area: frames, an orthophoto, or both.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Aerial {
    /// Nadir frame images with interior and exterior orientation.
    pub frames: Option<FrameBlock>,
    /// A georeferenced orthophoto and the terrain model it was rectified with.
    pub orthophoto: Option<Orthophoto>,
}

/// A block of aerial frame images taken with one camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FrameBlock {
    /// Index CSV with one row per image: image id, file, exterior orientation X, Y, Z (campaign
    /// CRS, metres) and omega, phi, kappa (degrees).
    pub index: Location,
    /// Prefix the index's file names are relative to.
    pub images: Location,
    /// The camera's interior orientation.
    pub interior: InteriorOrientation,
    /// Ground sampling distance of the images, metres.
    #[serde(default = "default_gsd_m")]
    pub gsd_m: f64,
}

/// Interior orientation of a metric aerial camera (image coordinates in millimetres).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InteriorOrientation {
    /// Focal length, millimetres.
    pub focal_length_mm: f64,
    /// Principal point [x, y] relative to the sensor centre, millimetres.
    #[serde(default)]
    pub principal_point_mm: [f64; 2],
    /// Pixel size on the sensor, millimetres.
    pub pixel_size_mm: f64,
    /// Radial distortion K1 for image radii in millimetres, mm⁻².
    #[serde(default)]
    pub k1: f64,
    /// Radial distortion K2 for image radii in millimetres, mm⁻⁴.
    #[serde(default)]
    pub k2: f64,
    /// Sensor width, pixels.
    pub width_px: u32,
    /// Sensor height, pixels.
    pub height_px: u32,
}

/// An orthophoto (GeoTIFF/COG) with the terrain model used to rectify it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Orthophoto {
    /// The orthophoto, a GeoTIFF (preferably cloud-optimised).
    pub image: Location,
    /// The terrain model (DTM) as a GeoTIFF of heights in metres.
    pub terrain: Location,
}

fn default_gsd_m() -> f64 {
    DEFAULT_AERIAL_GSD_M
}

impl Aerial {
    pub(crate) fn check(&self, at: &FieldPath, c: &mut Checker) {
        if self.frames.is_none() && self.orthophoto.is_none() {
            c.report(at, "neither frames nor orthophoto is given", "[aerial.frames], [aerial.orthophoto] or both");
        }
        if let Some(frames) = &self.frames {
            frames.check(&at.field("frames"), c);
        }
        if let Some(ortho) = &self.orthophoto {
            c.location(&at.field("orthophoto").field("image"), &ortho.image);
            c.location(&at.field("orthophoto").field("terrain"), &ortho.terrain);
        }
    }
}

impl FrameBlock {
    fn check(&self, at: &FieldPath, c: &mut Checker) {
        c.location(&at.field("index"), &self.index);
        c.location(&at.field("images"), &self.images);
        self.interior.check(&at.field("interior"), c);
        let (min, max) = AERIAL_GSD_RANGE_M;
        c.in_range(&at.field("gsd_m"), self.gsd_m, min, max, " m");
    }
}

impl InteriorOrientation {
    fn check(&self, at: &FieldPath, c: &mut Checker) {
        c.positive(&at.field("focal_length_mm"), self.focal_length_mm, 1_000.0, " mm");
        c.in_range(&at.field("pixel_size_mm"), self.pixel_size_mm, 0.000_5, 0.1, " mm");
        c.count(&at.field("width_px"), self.width_px, 1, 100_000);
        c.count(&at.field("height_px"), self.height_px, 1, 100_000);
        c.in_range(&at.field("k1"), self.k1, -1.0, 1.0, " mm^-2");
        c.in_range(&at.field("k2"), self.k2, -1.0, 1.0, " mm^-4");
        let half = |px: u32| 0.5 * f64::from(px) * self.pixel_size_mm;
        let limits = [half(self.width_px), half(self.height_px)];
        for (i, (value, limit)) in self.principal_point_mm.into_iter().zip(limits).enumerate() {
            c.in_range(&at.field("principal_point_mm").index(i), value, -limit, limit, " mm");
        }
    }
}
