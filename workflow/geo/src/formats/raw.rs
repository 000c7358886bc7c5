//! The format-neutral trajectory as read from a file ([`RawTrajectory`]), and its conversion to and from
//! mapping-frame records through a caller-supplied projection.

use serde::{Deserialize, Serialize};

use crate::attitude::{Attitude, NovatelAttitude};
use crate::frames::Point3;
use crate::trajectory::{PoseStd, TrajectoryRecord};

/// How a file gives horizontal position, and from which north its heading counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Horizontal {
    /// x = easting, y = northing, z = height (metres, the campaign's projected CRS); heading from grid north.
    Projected,
    /// x = longitude, y = latitude (degrees), z = ellipsoidal height (metres); heading from true north.
    Geographic,
}

/// The attitude convention of a file's roll, pitch and heading (see [`crate::attitude`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum AttitudeConvention {
    /// Applanix roll, pitch, heading: plumbline's canonical [`Attitude`], taken as is.
    #[default]
    Applanix,
    /// NovAtel SPAN roll, pitch, azimuth, converted through [`NovatelAttitude::to_canonical`].
    Novatel,
}

impl AttitudeConvention {
    /// The canonical attitude of angles (radians) given in this convention.
    pub fn to_canonical(self, roll: f64, pitch: f64, heading: f64) -> Attitude {
        match self {
            Self::Applanix => Attitude::new(roll, pitch, heading),
            Self::Novatel => NovatelAttitude { roll, pitch, azimuth: heading }.to_canonical(),
        }
    }
}

/// One epoch as a file gives it; the meaning of `x`, `y`, `z` and of north depends on [`Horizontal`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawRecord {
    /// Time, seconds.
    pub time: f64,
    /// Easting (m) or longitude (degrees).
    pub x: f64,
    /// Northing (m) or latitude (degrees).
    pub y: f64,
    /// Height (m); ellipsoidal when geographic.
    pub z: f64,
    /// Canonical attitude; heading from grid north (projected) or true north (geographic).
    pub attitude: Attitude,
    /// Standard deviations: east, north, height in metres, angles in radians.
    pub std: Option<PoseStd>,
}

/// A trajectory in its file's coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct RawTrajectory {
    /// Projected or geographic.
    pub horizontal: Horizontal,
    /// The epochs, in file order.
    pub records: Vec<RawRecord>,
}

/// A geographic point projected into the campaign's CRS, as a projection closure returns it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapPoint {
    /// Easting, metres.
    pub e: f64,
    /// Northing, metres.
    pub n: f64,
    /// Height, metres.
    pub h: f64,
    /// Meridian convergence γ at the point, radians: the clockwise angle from true north to grid north,
    /// so grid heading = true heading − γ (for Transverse Mercator, γ > 0 east of the central meridian
    /// in the northern hemisphere).
    pub convergence_rad: f64,
}

/// A projection closure failed for one record.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("record {index} (time {time}): {error}")]
pub struct ProjectionError<E> {
    /// 0-based record index.
    pub index: usize,
    /// The record's time.
    pub time: f64,
    /// What the closure returned.
    pub error: E,
}

impl RawTrajectory {
    /// Records in the mapping frame. Projected: fields move as they are, `project` is not called.
    /// Geographic: `project(longitude_deg, latitude_deg, height)` gives the map point and the meridian
    /// convergence γ, and the grid heading is the true heading − γ (not wrapped into [0, 2π)).
    /// Standard deviations are kept as they are: the east/north σ are not rotated by γ (a few degrees,
    /// negligible for σ).
    pub fn into_map<E>(
        self,
        mut project: impl FnMut(f64, f64, f64) -> Result<MapPoint, E>,
    ) -> Result<Vec<TrajectoryRecord>, ProjectionError<E>> {
        let geographic = self.horizontal == Horizontal::Geographic;
        let convert = |(index, r): (usize, RawRecord)| {
            if !geographic {
                return Ok(r.to_map(r.x, r.y, r.z, 0.0));
            }
            let p = project(r.x, r.y, r.z).map_err(|error| ProjectionError { index, time: r.time, error })?;
            Ok(r.to_map(p.e, p.n, p.h, p.convergence_rad))
        };
        self.records.into_iter().enumerate().map(convert).collect()
    }

    /// A geographic trajectory from mapping-frame records: `unproject(e, n, h)` returns
    /// `(longitude_deg, latitude_deg, ellipsoidal_height, convergence_rad)` and the true heading is the grid
    /// heading + γ (the inverse of [`RawTrajectory::into_map`]; γ as in [`MapPoint::convergence_rad`]).
    pub fn from_map<E>(
        records: &[TrajectoryRecord],
        mut unproject: impl FnMut(f64, f64, f64) -> Result<(f64, f64, f64, f64), E>,
    ) -> Result<Self, ProjectionError<E>> {
        let convert = |(index, r): (usize, &TrajectoryRecord)| {
            let p = r.position;
            let (lon, lat, h, convergence) =
                unproject(p.x(), p.y(), p.z()).map_err(|error| ProjectionError { index, time: r.time, error })?;
            let attitude = Attitude { heading: r.attitude.heading + convergence, ..r.attitude };
            Ok(RawRecord { time: r.time, x: lon, y: lat, z: h, attitude, std: r.std })
        };
        let records = records.iter().enumerate().map(convert).collect::<Result<_, _>>()?;
        Ok(Self { horizontal: Horizontal::Geographic, records })
    }

    /// A projected trajectory holding mapping-frame records as they are.
    pub fn from_map_projected(records: &[TrajectoryRecord]) -> Self {
        let convert = |r: &TrajectoryRecord| RawRecord {
            time: r.time,
            x: r.position.x(),
            y: r.position.y(),
            z: r.position.z(),
            attitude: r.attitude,
            std: r.std,
        };
        Self { horizontal: Horizontal::Projected, records: records.iter().map(convert).collect() }
    }
}

impl RawRecord {
    /// The mapping-frame record at map position (e, n, h), heading turned from true to grid north by γ.
    fn to_map(self, e: f64, n: f64, h: f64, convergence: f64) -> TrajectoryRecord {
        let attitude = Attitude { heading: self.attitude.heading - convergence, ..self.attitude };
        TrajectoryRecord { time: self.time, position: Point3::new(e, n, h), attitude, std: self.std }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(time: f64, x: f64, y: f64, heading_deg: f64) -> RawRecord {
        RawRecord { time, x, y, z: 50.0, attitude: Attitude::from_degrees(1.0, -2.0, heading_deg), std: None }
    }

    fn geographic() -> RawTrajectory {
        let records =
            vec![record(0.0, 13.4, 52.5, 10.0), record(1.0, 13.41, 52.51, 359.5), record(2.0, 13.42, 52.52, 0.0)];
        RawTrajectory { horizontal: Horizontal::Geographic, records }
    }

    /// A stand-in projection: scaled degrees and a fixed convergence of 1°.
    fn project(lon: f64, lat: f64, h: f64) -> Result<MapPoint, String> {
        Ok(MapPoint { e: lon * 1000.0, n: lat * 1000.0, h: h + 1.0, convergence_rad: 1f64.to_radians() })
    }

    fn unproject(e: f64, n: f64, h: f64) -> Result<(f64, f64, f64, f64), String> {
        Ok((e / 1000.0, n / 1000.0, h - 1.0, 1f64.to_radians()))
    }

    #[test]
    fn projected_fields_move_without_calling_the_projection() {
        let raw = RawTrajectory { horizontal: Horizontal::Projected, records: vec![record(0.0, 500.0, 600.0, 30.0)] };
        let out = raw.clone().into_map(|_, _, _| Err("called")).unwrap();
        assert_eq!(out[0].position, Point3::new(500.0, 600.0, 50.0));
        assert_eq!(out[0].attitude, raw.records[0].attitude);
        assert_eq!(RawTrajectory::from_map_projected(&out), raw);
    }

    #[test]
    fn convergence_is_subtracted_into_grid_and_added_back_into_true_heading() {
        let raw = geographic();
        let map = raw.clone().into_map(project).unwrap();
        for (m, r) in map.iter().zip(&raw.records) {
            let expected = r.attitude.heading - 1f64.to_radians();
            assert!((m.attitude.heading - expected).abs() < 1e-15, "{m:?}");
            assert_eq!((m.attitude.roll, m.attitude.pitch), (r.attitude.roll, r.attitude.pitch));
            assert_eq!(m.position, Point3::new(r.x * 1000.0, r.y * 1000.0, 51.0));
        }
        let back = RawTrajectory::from_map(&map, unproject).unwrap();
        assert_eq!(back.horizontal, Horizontal::Geographic);
        for (b, r) in back.records.iter().zip(&raw.records) {
            assert!((b.attitude.heading - r.attitude.heading).abs() < 1e-14);
            assert!((b.x - r.x).abs() < 1e-12 && (b.y - r.y).abs() < 1e-12 && (b.z - r.z).abs() < 1e-12);
        }
    }

    #[test]
    fn projection_errors_name_the_record() {
        let fail_on_third = |lon: f64, lat: f64, h: f64| {
            if lon > 13.415 { Err("outside the CRS") } else { project(lon, lat, h).map_err(|_| "") }
        };
        let err = geographic().into_map(fail_on_third).unwrap_err();
        assert_eq!(err.index, 2);
        assert_eq!(err.to_string(), "record 2 (time 2): outside the CRS");
    }

    #[test]
    fn novatel_angles_go_through_novatel_attitude() {
        // A negative azimuth tells the paths apart: the NovAtel conversion returns heading in [0, 2π).
        let (roll, pitch, heading) = (8f64.to_radians(), 6f64.to_radians(), -30f64.to_radians());
        let applanix = AttitudeConvention::Applanix.to_canonical(roll, pitch, heading);
        assert_eq!(applanix, Attitude::new(roll, pitch, heading));
        let novatel = AttitudeConvention::Novatel.to_canonical(roll, pitch, heading);
        assert_eq!(novatel, NovatelAttitude { roll, pitch, azimuth: heading }.to_canonical());
        assert!((0.0..std::f64::consts::TAU).contains(&novatel.heading), "{novatel:?}");
    }
}
