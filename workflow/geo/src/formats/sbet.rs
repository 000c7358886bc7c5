//! Applanix SBET (smoothed best estimate of trajectory): binary, geographic, 17 doubles per epoch.
//!
//! No header: records of 17 little-endian `f64` (136 bytes), in this order:
//!
//! | # | field | unit |
//! |---|---|---|
//! | 0 | time | s (GPS seconds of week) |
//! | 1, 2 | latitude, longitude | rad |
//! | 3 | altitude (ellipsoidal height) | m |
//! | 4–6 | x, y, z velocity in the wander frame: north, east, down turned by the wander angle about down | m/s |
//! | 7, 8 | roll, pitch | rad |
//! | 9 | platform heading (from the wander frame's x axis) | rad |
//! | 10 | wander angle | rad |
//! | 11–13 | x, y, z body specific force | m/s² |
//! | 14–16 | x, y, z body angular rate | rad/s |
//!
//! True heading = platform heading − wander angle; roll and pitch are relative to the local level and do
//! not depend on the wander angle. SBETs written here have wander angle 0 (the wander frame is then NED),
//! and zero specific force and angular rate. Standard deviations live in the companion
//! [`smrmsg`](super::smrmsg) file.

use super::binary::{check_records, read_records, write_records};
use super::smrmsg::{SmrmsgRecord, StdTrack};
use super::{FormatError, Horizontal, RawRecord, RawTrajectory};
use crate::attitude::Attitude;

/// Bytes of one SBET record.
pub const SBET_RECORD_LEN: usize = 136;
const FIELDS: usize = 17;
const FORMAT: &str = "SBET";

/// WGS 84 semi-major axis, m.
const WGS84_A: f64 = 6_378_137.0;
/// WGS 84 flattening.
const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// One SBET epoch, fields in file order.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SbetRecord {
    /// Time, seconds.
    pub time: f64,
    /// Latitude, radians.
    pub latitude: f64,
    /// Longitude, radians.
    pub longitude: f64,
    /// Ellipsoidal height, metres.
    pub altitude: f64,
    /// Velocity along the wander frame's x axis (north when the wander angle is 0), m/s.
    pub velocity_x: f64,
    /// Velocity along the wander frame's y axis (east when the wander angle is 0), m/s.
    pub velocity_y: f64,
    /// Velocity down, m/s.
    pub velocity_z: f64,
    /// Roll, radians.
    pub roll: f64,
    /// Pitch, radians.
    pub pitch: f64,
    /// Heading from the wander frame's x axis, radians.
    pub platform_heading: f64,
    /// Wander angle, radians.
    pub wander_angle: f64,
    /// Body x specific force, m/s².
    pub specific_force_x: f64,
    /// Body y specific force, m/s².
    pub specific_force_y: f64,
    /// Body z specific force, m/s².
    pub specific_force_z: f64,
    /// Body x angular rate, rad/s.
    pub angular_rate_x: f64,
    /// Body y angular rate, rad/s.
    pub angular_rate_y: f64,
    /// Body z angular rate, rad/s.
    pub angular_rate_z: f64,
}

impl SbetRecord {
    /// The fields in file order.
    pub fn to_array(&self) -> [f64; FIELDS] {
        [
            self.time,
            self.latitude,
            self.longitude,
            self.altitude,
            self.velocity_x,
            self.velocity_y,
            self.velocity_z,
            self.roll,
            self.pitch,
            self.platform_heading,
            self.wander_angle,
            self.specific_force_x,
            self.specific_force_y,
            self.specific_force_z,
            self.angular_rate_x,
            self.angular_rate_y,
            self.angular_rate_z,
        ]
    }

    /// A record from the fields in file order.
    pub fn from_array(a: [f64; FIELDS]) -> Self {
        let [
            time,
            latitude,
            longitude,
            altitude,
            velocity_x,
            velocity_y,
            velocity_z,
            roll,
            pitch,
            platform_heading,
            wander_angle,
            specific_force_x,
            specific_force_y,
            specific_force_z,
            angular_rate_x,
            angular_rate_y,
            angular_rate_z,
        ] = a;
        Self {
            time,
            latitude,
            longitude,
            altitude,
            velocity_x,
            velocity_y,
            velocity_z,
            roll,
            pitch,
            platform_heading,
            wander_angle,
            specific_force_x,
            specific_force_y,
            specific_force_z,
            angular_rate_x,
            angular_rate_y,
            angular_rate_z,
        }
    }

    /// Heading from true north: platform heading − wander angle.
    pub fn true_heading(&self) -> f64 {
        self.platform_heading - self.wander_angle
    }
}

/// Parse an SBET file; a length that is not a multiple of 136 bytes is an error naming the offset, and so are
/// an empty file and a record whose time, position or attitude is not finite or whose latitude lies beyond
/// ±90° (named by record and field).
pub fn parse_sbet(bytes: &[u8], source: &str) -> Result<Vec<SbetRecord>, FormatError> {
    let records = read_records::<FIELDS>(bytes, source, FORMAT)?;
    let finite: fn(f64) -> bool = f64::is_finite;
    let not_finite = "is not finite";
    check_records(
        &records,
        source,
        FORMAT,
        &[
            (0, "time", finite, not_finite),
            (1, "latitude", |v| v.abs() <= std::f64::consts::FRAC_PI_2, "rad is not a latitude (NaN or beyond ±π/2)"),
            (2, "longitude", |v| v.abs() <= 2.0 * std::f64::consts::PI, "rad is not a longitude (NaN or beyond ±2π)"),
            (3, "altitude", finite, not_finite),
            (7, "roll", finite, not_finite),
            (8, "pitch", finite, not_finite),
            (9, "platform_heading", finite, not_finite),
            (10, "wander_angle", finite, not_finite),
        ],
    )?;
    Ok(records.into_iter().map(SbetRecord::from_array).collect())
}

/// Encode SBET records.
pub fn write_sbet(records: &[SbetRecord]) -> Vec<u8> {
    write_records(records.iter().map(SbetRecord::to_array))
}

/// A geographic trajectory from SBET records: degrees, true heading, velocities and IMU data dropped.
/// With smrmsg records, σ are interpolated linearly in time onto every SBET epoch (clamped to the first
/// and last smrmsg epoch) and the attitude σ converted from arc-minutes to radians; an empty smrmsg
/// slice gives no σ, like `None`.
pub fn sbet_to_raw(records: &[SbetRecord], std: Option<&[SmrmsgRecord]>) -> RawTrajectory {
    let track = std.and_then(StdTrack::new);
    let convert = |r: &SbetRecord| RawRecord {
        time: r.time,
        x: r.longitude.to_degrees(),
        y: r.latitude.to_degrees(),
        z: r.altitude,
        attitude: Attitude::new(r.roll, r.pitch, r.true_heading()),
        std: track.as_ref().map(|t| t.at(r.time)),
    };
    RawTrajectory { horizontal: Horizontal::Geographic, records: records.iter().map(convert).collect() }
}

/// SBET records from a geographic trajectory (σ go to [`raw_to_smrmsg`](super::raw_to_smrmsg)).
///
/// Wander angle 0, so the platform heading is the true heading and the velocity is north, east, down.
/// Velocities are central differences of the positions (one-sided at the ends, 0 for a single record or
/// a non-increasing time step), with metres from degrees in the local tangent plane at the mid-point
/// (WGS 84 radii of curvature). Specific force and angular rate are 0.
pub fn raw_to_sbet(trajectory: &RawTrajectory) -> Result<Vec<SbetRecord>, FormatError> {
    if trajectory.horizontal != Horizontal::Geographic {
        return Err(FormatError::NotGeographic { format: FORMAT });
    }
    let r = &trajectory.records;
    let convert = |i: usize| {
        let (lo, hi) = (i.saturating_sub(1), (i + 1).min(r.len() - 1));
        let [north, east, down] = velocity_ned(&r[lo], &r[hi]);
        let a = &r[i];
        SbetRecord {
            time: a.time,
            latitude: a.y.to_radians(),
            longitude: a.x.to_radians(),
            altitude: a.z,
            velocity_x: north,
            velocity_y: east,
            velocity_z: down,
            roll: a.attitude.roll,
            pitch: a.attitude.pitch,
            platform_heading: a.attitude.heading,
            ..SbetRecord::default()
        }
    };
    Ok((0..r.len()).map(convert).collect())
}

/// North, east, down velocity from geographic record `a` to `b` in the local tangent plane.
fn velocity_ned(a: &RawRecord, b: &RawRecord) -> [f64; 3] {
    let dt = b.time - a.time;
    if dt.is_nan() || dt <= 0.0 {
        return [0.0; 3];
    }
    let latitude = ((a.y + b.y) / 2.0).to_radians();
    let height = (a.z + b.z) / 2.0;
    let (meridian, prime_vertical) = radii_of_curvature(latitude);
    let d_lat = (b.y - a.y).to_radians();
    let d_lon = wrap_degrees(b.x - a.x).to_radians();
    let north = d_lat * (meridian + height);
    let east = d_lon * (prime_vertical + height) * latitude.cos();
    [north / dt, east / dt, -(b.z - a.z) / dt]
}

/// Meridian (north–south) and prime-vertical (east–west) radii of curvature of WGS 84 at `latitude` (rad).
// Groves, Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems (2nd ed.), §2.4.2.
fn radii_of_curvature(latitude: f64) -> (f64, f64) {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let w = 1.0 - e2 * latitude.sin().powi(2);
    (WGS84_A * (1.0 - e2) / w.powf(1.5), WGS84_A / w.sqrt())
}

/// A longitude difference in degrees, wrapped into [−180, 180).
fn wrap_degrees(d: f64) -> f64 {
    (d + 180.0).rem_euclid(360.0) - 180.0
}

#[cfg(test)]
mod tests;
