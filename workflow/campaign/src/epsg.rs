//! `Epsg`: an EPSG code naming a coordinate reference system, with the plausibility checks this
//! crate can do without PROJ (the service layer asks GDAL whether the code exists and is projected).

use std::fmt;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Codes of the EPSG dataset's coordinate reference systems lie in this range.
pub const EPSG_CRS_RANGE: std::ops::RangeInclusive<u32> = 1024..=32767;

/// Geographic (latitude/longitude) CRSs that campaigns name most often; never a mapping frame.
const GEOGRAPHIC: &[(u32, &str)] = &[
    (4326, "WGS 84"),
    (4979, "WGS 84 3D"),
    (4258, "ETRS89"),
    (4937, "ETRS89 3D"),
    (4269, "NAD83"),
    (4267, "NAD27"),
    (4150, "CH1903+"),
    (4149, "CH1903"),
    (4314, "DHDN"),
    (4277, "OSGB36"),
    (4283, "GDA94"),
    (7844, "GDA2020"),
    (4612, "JGD2000"),
    (6668, "JGD2011"),
];

/// Geocentric (earth-centred cartesian) CRSs, also never a mapping frame.
const GEOCENTRIC: &[(u32, &str)] = &[(4978, "WGS 84 geocentric"), (4936, "ETRS89 geocentric")];

/// An EPSG code, e.g. 25832 (ETRS89 / UTM zone 32N) or 2056 (CH1903+ / LV95).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(transparent)]
#[schemars(transparent)]
pub struct Epsg(#[schemars(range(min = 1024, max = 32767))] pub u32);

/// What the basic checks can tell about a code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EpsgKind {
    /// Outside [`EPSG_CRS_RANGE`]: not an EPSG CRS code.
    OutOfRange,
    /// A known geographic CRS, named.
    Geographic(&'static str),
    /// A known geocentric CRS, named.
    Geocentric(&'static str),
    /// In range and not known to be geographic or geocentric; the service layer confirms it.
    PlausiblyProjected,
}

impl Epsg {
    /// WGS 84 geographic, the frame of every SBET file.
    pub const WGS84: Epsg = Epsg(4326);

    /// Classifies the code by range and by the short lists of well-known non-projected CRSs.
    pub fn kind(self) -> EpsgKind {
        let named = |list: &[(u32, &'static str)]| list.iter().find(|(code, _)| *code == self.0).map(|(_, n)| *n);
        if !EPSG_CRS_RANGE.contains(&self.0) {
            EpsgKind::OutOfRange
        } else if let Some(name) = named(GEOGRAPHIC) {
            EpsgKind::Geographic(name)
        } else if let Some(name) = named(GEOCENTRIC) {
            EpsgKind::Geocentric(name)
        } else {
            EpsgKind::PlausiblyProjected
        }
    }
}

impl fmt::Display for Epsg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "EPSG:{}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(code: u32, expect: EpsgKind) {
        assert_eq!(Epsg(code).kind(), expect, "EPSG:{code}");
    }

    #[test]
    fn classifies_codes() {
        check(25832, EpsgKind::PlausiblyProjected);
        check(2056, EpsgKind::PlausiblyProjected);
        check(3857, EpsgKind::PlausiblyProjected);
        check(4326, EpsgKind::Geographic("WGS 84"));
        check(4258, EpsgKind::Geographic("ETRS89"));
        check(4979, EpsgKind::Geographic("WGS 84 3D"));
        check(4978, EpsgKind::Geocentric("WGS 84 geocentric"));
        check(0, EpsgKind::OutOfRange);
        check(1023, EpsgKind::OutOfRange);
        check(32768, EpsgKind::OutOfRange);
        check(102100, EpsgKind::OutOfRange);
    }

    #[test]
    fn displays_with_authority() {
        assert_eq!(Epsg(25832).to_string(), "EPSG:25832");
    }
}
