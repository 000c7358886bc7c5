//! The `[[trajectory]]` sources of a manifest: each drive's direct-georeferencing trajectory file,
//! with its optional raw GNSS/IMU for re-fusion and a reference trajectory for evaluation.

use schemars::JsonSchema;
use serde::{Deserialize, Deserializer, Serialize};

use crate::epsg::{Epsg, EpsgKind};
use crate::location::Location;
use crate::problem::{Checker, FieldPath};

/// One drive's trajectory, by file format.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(tag = "format", rename_all = "lowercase")]
pub enum TrajectorySource {
    /// Text trajectory: time, E/N/H or lat/lon/h, roll/pitch/heading and their standard deviations.
    Csv(CsvTrajectory),
    /// Applanix SBET (smoothed best estimate of trajectory), always WGS 84 geographic.
    Sbet(SbetTrajectory),
}

/// A trajectory in a CSV file.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CsvTrajectory {
    /// The CSV file: time, E/N/H (or lat/lon/h), roll/pitch/heading, standard deviations.
    pub url: Location,
    /// EPSG code of the file's coordinates when they are not in the campaign's `crs`; may be
    /// geographic (e.g. 4258 for ETRS89 lat/lon).
    pub epsg: Option<Epsg>,
    /// Convention of the roll/pitch/heading columns.
    #[serde(default)]
    pub attitude: AttitudeConvention,
    /// Raw GNSS positions (CSV) of the drive, for re-fusion with `imu`.
    pub gnss: Option<Location>,
    /// Raw IMU records of the drive, for re-fusion with `gnss`.
    pub imu: Option<Location>,
    /// Ground-truth trajectory of the drive (same CSV layout), used only to evaluate the result.
    pub reference: Option<Location>,
}

/// A trajectory in an Applanix SBET file (WGS 84 geographic, Applanix attitude).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SbetTrajectory {
    /// The SBET file.
    pub url: Location,
    /// The matching smrmsg file with the SBET's standard deviations.
    pub smrmsg: Option<Location>,
    /// Raw GNSS positions (CSV) of the drive, for re-fusion with `imu`.
    pub gnss: Option<Location>,
    /// Raw IMU records of the drive, for re-fusion with `gnss`.
    pub imu: Option<Location>,
    /// Ground-truth trajectory of the drive (CSV), used only to evaluate the result.
    pub reference: Option<Location>,
}

/// The convention of a trajectory's roll, pitch and heading columns.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum AttitudeConvention {
    /// Applanix (SBET, POSPac): body x forward, y right, z down; local level NED;
    /// R = Rz(heading) · Ry(pitch) · Rx(roll), heading clockwise from north.
    #[default]
    Applanix,
    /// NovAtel SPAN (INSPVA): body x right, y forward, z up; local level ENU;
    /// R = Rz(−azimuth) · Rx(pitch) · Ry(roll), azimuth clockwise from north.
    Novatel,
}

/// Every key a `[[trajectory]]` table may hold, whatever its format.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TrajectoryFields {
    format: TrajectoryFormat,
    url: Location,
    epsg: Option<Epsg>,
    attitude: Option<AttitudeConvention>,
    smrmsg: Option<Location>,
    gnss: Option<Location>,
    imu: Option<Location>,
    reference: Option<Location>,
}

#[derive(Deserialize)]
#[serde(rename_all = "lowercase")]
enum TrajectoryFormat {
    Csv,
    Sbet,
}

// Read through `TrajectoryFields` rather than serde's internally tagged enum, which buffers the
// table and so loses the field paths and positions of errors inside it.
impl<'de> Deserialize<'de> for TrajectorySource {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        TrajectoryFields::deserialize(deserializer)?.into_source().map_err(serde::de::Error::custom)
    }
}

impl TrajectoryFields {
    /// The source of the table's format, or which key does not belong to that format.
    fn into_source(self) -> Result<TrajectorySource, &'static str> {
        let Self { format, url, epsg, attitude, smrmsg, gnss, imu, reference } = self;
        match format {
            TrajectoryFormat::Csv if smrmsg.is_some() => Err("`smrmsg` is only for format = \"sbet\""),
            TrajectoryFormat::Csv => {
                let attitude = attitude.unwrap_or_default();
                Ok(TrajectorySource::Csv(CsvTrajectory { url, epsg, attitude, gnss, imu, reference }))
            }
            TrajectoryFormat::Sbet if epsg.is_some() => {
                Err("`epsg` is only for format = \"csv\"; SBET is always WGS 84")
            }
            TrajectoryFormat::Sbet if attitude.is_some() => {
                Err("`attitude` is only for format = \"csv\"; SBET attitude is always applanix")
            }
            TrajectoryFormat::Sbet => Ok(TrajectorySource::Sbet(SbetTrajectory { url, smrmsg, gnss, imu, reference })),
        }
    }
}

impl TrajectorySource {
    /// The trajectory file.
    pub fn url(&self) -> &Location {
        match self {
            Self::Csv(csv) => &csv.url,
            Self::Sbet(sbet) => &sbet.url,
        }
    }

    /// The file's CRS when it is not the campaign's: given for CSV, WGS 84 for SBET.
    pub fn epsg(&self) -> Option<Epsg> {
        match self {
            Self::Csv(csv) => csv.epsg,
            Self::Sbet(_) => Some(Epsg::WGS84),
        }
    }

    /// The attitude convention of the file's roll/pitch/heading.
    pub fn attitude(&self) -> AttitudeConvention {
        match self {
            Self::Csv(csv) => csv.attitude,
            Self::Sbet(_) => AttitudeConvention::Applanix,
        }
    }

    /// Raw GNSS and IMU for re-fusion, when both are given.
    pub fn raw_navigation(&self) -> Option<(&Location, &Location)> {
        let (gnss, imu) = self.companions();
        gnss.zip(imu)
    }

    /// The ground-truth trajectory for evaluation.
    pub fn reference(&self) -> Option<&Location> {
        match self {
            Self::Csv(csv) => csv.reference.as_ref(),
            Self::Sbet(sbet) => sbet.reference.as_ref(),
        }
    }

    fn companions(&self) -> (Option<&Location>, Option<&Location>) {
        match self {
            Self::Csv(csv) => (csv.gnss.as_ref(), csv.imu.as_ref()),
            Self::Sbet(sbet) => (sbet.gnss.as_ref(), sbet.imu.as_ref()),
        }
    }

    pub(crate) fn check(&self, at: &FieldPath, c: &mut Checker) {
        c.location(&at.field("url"), self.url());
        if let Self::Csv(CsvTrajectory { epsg: Some(epsg), .. }) = self {
            check_file_epsg(&at.field("epsg"), *epsg, c);
        }
        if let Self::Sbet(SbetTrajectory { smrmsg: Some(smrmsg), .. }) = self {
            c.location(&at.field("smrmsg"), smrmsg);
        }
        let (gnss, imu) = self.companions();
        let named = [("gnss", gnss), ("imu", imu), ("reference", self.reference())];
        for (name, location) in named.into_iter().filter_map(|(n, l)| Some((n, l?))) {
            c.location(&at.field(name), location);
        }
        match (gnss, imu) {
            (Some(_), None) => {
                c.report(&at.field("imu"), "gnss is given without imu", "both gnss and imu for re-fusion, or neither")
            }
            (None, Some(_)) => {
                c.report(&at.field("gnss"), "imu is given without gnss", "both gnss and imu for re-fusion, or neither")
            }
            _ => {}
        }
    }
}

/// A file's own CRS may be geographic or projected, not geocentric.
pub(crate) fn check_file_epsg(at: &FieldPath, epsg: Epsg, c: &mut Checker) {
    match epsg.kind() {
        EpsgKind::OutOfRange => c.report(at, format!("{epsg} is not an EPSG CRS code"), "a code in 1024..=32767"),
        EpsgKind::Geocentric(name) => {
            c.report(at, format!("{epsg} ({name}) is geocentric"), "a geographic or projected CRS")
        }
        EpsgKind::Geographic(_) | EpsgKind::PlausiblyProjected => {}
    }
}
