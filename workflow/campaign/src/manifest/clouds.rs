//! The manifest's `point_clouds`: LAS/LAZ clouds of the drives, each a location alone
//! (`point_clouds = ["lidar/strip_000.laz"]`) or a table saying how to read it (`[[point_clouds]]`).

use std::fmt;

use schemars::JsonSchema;
use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};

use super::imagery::CameraMount;
use crate::epsg::Epsg;
use crate::location::Location;
use crate::problem::{Checker, FieldPath};

/// A point cloud of the drive and how to read it (in a manifest: its location alone, or this table).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PointCloud {
    /// The LAS or LAZ file.
    pub url: Location,
    /// The cloud's CRS when its header names none or a wrong one; otherwise the header's (which must be the
    /// campaign's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub epsg: Option<Epsg>,
    /// The time scale of the points' GPS times.
    #[serde(default)]
    pub time: CloudTime,
    /// The file's format, when declared: `validate` checks it against the header.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub format: Option<CloudFormat>,
    /// Where the scanner sits on the vehicle (its centre is where the range errors point from); the
    /// navigation reference point when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mount: Option<CameraMount>,
}

/// How a cloud's GPS times relate to the trajectory's time scale (GPS seconds of the week).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CloudTime {
    /// As the header's global-encoding bit 0 says: adjusted standard GPS time when set, week seconds otherwise.
    #[default]
    Header,
    /// GPS seconds of the week, like the trajectory.
    WeekSeconds,
    /// Adjusted standard GPS time (GPS seconds since 1980-01-06 minus 10⁹), whatever the header says.
    AdjustedStandard,
    /// The points carry no usable time: each stem takes the time the drive passed nearest to it (weaker: a
    /// stem scanned from another pass carries that pass's DG error).
    None,
}

/// A point cloud's file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CloudFormat {
    /// Uncompressed LAS 1.0–1.4.
    Las,
    /// LASzip-compressed LAS (LAZ).
    Laz,
    /// Cloud-optimised point cloud (COPC 1.0: LAZ 1.4 stored by octree node, not in GPS-time order): each tile
    /// reads the nodes near it and sorts their points by time.
    Copc,
}

impl CloudFormat {
    /// Its name in a manifest.
    pub fn name(self) -> &'static str {
        match self {
            CloudFormat::Las => "las",
            CloudFormat::Laz => "laz",
            CloudFormat::Copc => "copc",
        }
    }
}

/// The table form of a [`PointCloud`].
#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct PointCloudTable {
    /// The LAS or LAZ file.
    url: Location,
    /// The cloud's CRS when its header names none or a wrong one; otherwise the header's (which must be the
    /// campaign's).
    #[serde(default)]
    epsg: Option<Epsg>,
    /// The time scale of the points' GPS times.
    #[serde(default)]
    time: CloudTime,
    /// The file's format (`las`, `laz` or `copc`), when declared: `validate` checks it against the header.
    #[serde(default)]
    format: Option<CloudFormat>,
    /// Where the scanner sits on the vehicle (its centre is where the range errors point from); the
    /// navigation reference point when absent.
    #[serde(default)]
    mount: Option<CameraMount>,
}

/// What a manifest may write for a point cloud (the schema of [`PointCloud`]).
#[derive(JsonSchema)]
#[serde(untagged)]
#[allow(dead_code)]
enum PointCloudEntry {
    /// The file alone, read as its header says.
    Url(Location),
    /// The file and how to read it.
    Table(PointCloudTable),
}

impl JsonSchema for PointCloud {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "PointCloud".into()
    }

    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        PointCloudEntry::json_schema(generator)
    }
}

impl<'de> Deserialize<'de> for PointCloud {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Entry;
        impl<'de> Visitor<'de> for Entry {
            type Value = PointCloud;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a location or a table with `url` (and `epsg`, `time`, `format`, `mount`)")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<PointCloud, E> {
                let url = Location::deserialize(de::value::StrDeserializer::<E>::new(v))?;
                Ok(PointCloud { url, epsg: None, time: CloudTime::Header, format: None, mount: None })
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<PointCloud, A::Error> {
                let t = PointCloudTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(PointCloud { url: t.url, epsg: t.epsg, time: t.time, format: t.format, mount: t.mount })
            }
        }
        deserializer.deserialize_any(Entry)
    }
}

impl PointCloud {
    pub(crate) fn check(&self, at: &FieldPath, c: &mut Checker) {
        let url = at.field("url");
        c.location(&url, &self.url);
        if !matches!(self.url.extension().as_deref(), Some("las" | "laz")) {
            c.report(&url, format!("{} is not a .las or .laz file", self.url), "a LAS or LAZ point cloud");
        }
        if let Some(mount) = &self.mount {
            mount.check(&at.field("mount"), c);
        }
    }
}
