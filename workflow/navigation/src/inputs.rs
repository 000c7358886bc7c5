//! The filter's inputs: IMU increments and GNSS fixes.

use plumbline_geo::{Body, Map, Point3, Vec3};

/// One IMU record: angle and velocity increments over the interval `[time − dt, time]`, body frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// End of the interval, s.
    pub time: f64,
    /// Length of the interval, s.
    pub dt: f64,
    /// Angle increment Δθ, rad.
    pub delta_theta: Vec3<Body>,
    /// Velocity increment Δv (specific force × dt), m/s.
    pub delta_v: Vec3<Body>,
}

/// One GNSS position fix of the antenna.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFix {
    /// Time, s (same scale as the IMU).
    pub time: f64,
    /// Antenna position in the mapping frame, m.
    pub position: Point3<Map>,
    /// Standard deviations east, north, up, m.
    pub std: [f64; 3],
}
