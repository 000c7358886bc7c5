//! The input of the detector: mapping-frame points of one frame (a depth image, or a time slice of a point
//! cloud) seen from one sensor position, each with its one-sigma error along its ray.

use nalgebra::Vector3;

/// One measured point in the mapping frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePoint {
    /// Easting, northing, height, metres.
    pub position: Vector3<f64>,
    /// The one-sigma displacement of a range error: the point moves along ±this vector (map frame, metres).
    /// For a depth pixel, σ_depth times the camera-frame ray scaled to unit depth, rotated into the map.
    pub error: Vector3<f64>,
    /// Image row of a depth pixel (`None` for point clouds).
    pub row: Option<u32>,
}

/// The points of one frame and how they were taken.
#[derive(Clone, Debug, PartialEq)]
pub struct FramePoints {
    /// Sensor centre in the mapping frame (the camera centre; for a point-cloud slice, the scanner position
    /// in the middle of the slice).
    pub origin: Vector3<f64>,
    /// Angle between neighbouring measurements, radians (a depth camera's 1 / fx).
    pub angular_step: f64,
    /// Beyond this horizontal range from `origin` the range distribution is cut by the sensor's range limit
    /// (points there are used for detection, not for coordinate updates), metres.
    pub reliable_range_m: f64,
    /// The points.
    pub points: Vec<FramePoint>,
}
