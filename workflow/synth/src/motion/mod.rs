//! Drives through the synthetic city and the navigation data a mobile-mapping vehicle would record on them.
//!
//! 1. [`Drive::simulate`]: the true motion along a [`Route`](crate::route::Route) at 100–200 Hz — speed
//!    profile with limits, curve speed, bounded acceleration and braking, stops at junctions with standstills
//!    up to ~40 s (Meyer et al. 2023 §4.2.3, Fig. 7), attitude from the path. Parameters: [`DriveConfig`].
//! 2. [`dg`]: the direct-georeferencing (GNSS/INS) error process driven by the urban canyon: drift,
//!    multipath jumps, outages, optimistic standard deviations in canyons
//!    (Cazzaniga et al. 2007 §1.2, Meyer et al. 2023 §4.2).
//! 3. [`gnss`] and [`imu`]: the raw sensor data the DG solution would come from — GNSS fixes at 1–10 Hz with
//!    the same canyon process, IMU increments at the trajectory rate for a navigation-grade (LN-100 class,
//!    Grejner-Brzezinska and Toth 2000 §2.1) or consumer (BMI160 class, Meyer et al. 2023 §3.1.1) grade. For drives
//!    made in legs (`city`), [`dg::DgStream`], [`gnss::GnssStream`] and [`imu::ImuStream`] carry every process across
//!    the joins.
//! 4. [`files`]: the bytes of the GNSS, IMU and error-series CSV files; [`overview_png`]: a map of the drive
//!    coloured by the DG error.
//!
//! Everything is deterministic from a seed: each model draws from its own random stream.

mod config;
pub mod dg;
mod drive;
pub mod files;
pub mod gnss;
pub mod imu;
mod overview;
mod path;
mod profile;
mod rng;
pub mod routes;
#[cfg(test)]
mod stream_tests;

pub use config::DriveConfig;
pub use drive::{Drive, Kinematics, STANDSTILL_SPEED};
pub use overview::overview_png;
pub use path::{Path, PathPoint};
pub use profile::Stop;

use plumbline_geo::TrajectoryError;

/// Why a drive or its navigation data could not be simulated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MotionError {
    /// A route needs two waypoints.
    #[error("route has {waypoints} waypoint(s); a drive needs at least 2")]
    RouteTooShort { waypoints: usize },
    /// A waypoint field is unusable.
    #[error("route waypoint {index}: field `{field}` is {value}; expected {expected}")]
    Waypoint { index: usize, field: &'static str, value: f64, expected: &'static str },
    /// A configuration parameter is out of range.
    #[error("{config}: parameter `{field}` is {value}; expected {expected}")]
    Config { config: &'static str, field: &'static str, value: f64, expected: &'static str },
    /// Two series that must have one entry per epoch do not (or the drive has no epoch).
    #[error("{what}: {got} entries for a drive of {expected} epochs")]
    Mismatch { what: &'static str, expected: usize, got: usize },
    /// The generated trajectory failed validation (a bug in the simulator).
    #[error("simulated trajectory is invalid: {0}")]
    Trajectory(#[from] TrajectoryError),
}
