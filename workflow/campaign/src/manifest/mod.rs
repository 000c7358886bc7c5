//! The versioned campaign manifest: what a campaign is, which inputs it names, in which frame it
//! maps, where results go, and how it is processed. Version 1 is the only version so far.

mod aerial;
mod cadastre;
mod clouds;
mod imagery;
mod parameters;
mod trajectory;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

pub use aerial::{Aerial, DEFAULT_AERIAL_GSD_M, FrameBlock, InteriorOrientation, Orthophoto};
pub use cadastre::{Cadastre, ClassAccuracy, PoleClass};
pub use clouds::{CloudFormat, CloudTime, PointCloud};
pub use imagery::{CameraMount, DepthCamera, DepthIntrinsics, Panoramas, StitchedRig};
pub use parameters::{Adjustment, Parameters, PoleParameters, Registration, RobustLoss};
pub use trajectory::{AttitudeConvention, CsvTrajectory, SbetTrajectory, TrajectorySource};

use crate::epsg::Epsg;
use crate::id::CampaignId;
use crate::location::Location;
use crate::problem::{Checker, FieldPath};

/// Largest tile side accepted, metres.
const MAX_TILE_SIZE_M: f64 = 10_000.0;

/// A plumbline campaign manifest. The file states its version first: `version = "1"`.
///
/// Read files with [`Manifest::from_toml_str`] or [`Manifest::from_json_str`]: their errors name
/// the field path and position, which the derived `Deserialize` (kept for embedding a manifest in
/// messages) cannot, as serde buffers internally tagged content.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
#[schemars(description = "A plumbline campaign manifest. The file states its version first: version = \"1\".")]
pub enum Manifest {
    /// Campaign manifest, version 1.
    #[serde(rename = "1")]
    V1(ManifestV1),
}

/// Campaign manifest, version 1. Locations are absolute URLs (`s3://`, `file:///`, `memory:///`)
/// or paths relative to the manifest's own location.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ManifestV1 {
    /// What the campaign is and who ran it.
    pub campaign: CampaignInfo,
    /// The mapping frame: EPSG code of a projected CRS, e.g. 25832 (ETRS89 / UTM zone 32N). Tiles,
    /// observations and reports are in this frame.
    pub crs: Epsg,
    /// Prefix under which the results are written: corrected trajectories, observations, report.
    pub output: Location,
    /// The drives' trajectories from direct georeferencing; at least one.
    #[schemars(length(min = 1))]
    pub trajectory: Vec<TrajectorySource>,
    /// Equirectangular panoramas, for registration with the aerial images.
    pub panoramas: Option<Panoramas>,
    /// Depth cameras, for pole detection.
    #[serde(default)]
    pub depth: Vec<DepthCamera>,
    /// LAS/LAZ point clouds of the drives, for pole detection: each a location, or a table with `url`, `epsg`,
    /// `time` and `mount`.
    #[serde(default)]
    pub point_clouds: Vec<PointCloud>,
    /// Aerial images of the area: frames with orientations and/or an orthophoto.
    pub aerial: Option<Aerial>,
    /// Cadastres of pole-like objects used as 2D control.
    #[serde(default)]
    pub cadastres: Vec<Cadastre>,
    /// How the trajectory is split into tiles processed independently.
    #[serde(default)]
    pub tiling: Tiling,
    /// Algorithm parameters.
    #[serde(default)]
    pub parameters: Parameters,
}

/// What the campaign is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CampaignInfo {
    /// Identifier used in storage keys and messages: a-z, 0-9, '-' and '_', at most 64 characters.
    pub id: CampaignId,
    /// Human-readable name shown in reports.
    pub name: String,
    /// The mapping agency that ordered or ran the campaign.
    pub agency: Option<String>,
}

/// The square tiles the trajectory is processed in.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Tiling {
    /// Side length of a tile, metres.
    #[serde(default = "default_tile_size_m")]
    pub tile_size_m: f64,
    /// Buffer around each tile whose data the tile also reads, metres; less than `tile_size_m`.
    #[serde(default = "default_overlap_m")]
    pub overlap_m: f64,
}

fn default_tile_size_m() -> f64 {
    250.0
}
fn default_overlap_m() -> f64 {
    30.0
}

impl Default for Tiling {
    fn default() -> Self {
        Self { tile_size_m: default_tile_size_m(), overlap_m: default_overlap_m() }
    }
}

impl Tiling {
    pub(crate) fn check(&self, at: &FieldPath, c: &mut Checker) {
        c.positive(&at.field("tile_size_m"), self.tile_size_m, MAX_TILE_SIZE_M, " m");
        c.in_range(&at.field("overlap_m"), self.overlap_m, 0.0, MAX_TILE_SIZE_M, " m");
        if self.overlap_m >= self.tile_size_m {
            let found = format!("{} m is not less than tile_size_m ({} m)", self.overlap_m, self.tile_size_m);
            c.report(&at.field("overlap_m"), found, "an overlap smaller than the tile size");
        }
    }
}

impl Manifest {
    /// The version as written in the file.
    pub fn version(&self) -> &'static str {
        match self {
            Self::V1(_) => "1",
        }
    }

    /// The manifest in the newest version's types (older versions are upgraded here).
    pub fn into_latest(self) -> ManifestV1 {
        match self {
            Self::V1(v1) => v1,
        }
    }

    /// The manifest's campaign identifier.
    pub fn campaign_id(&self) -> &CampaignId {
        match self {
            Self::V1(v1) => &v1.campaign.id,
        }
    }
}

impl From<ManifestV1> for Manifest {
    fn from(v1: ManifestV1) -> Self {
        Self::V1(v1)
    }
}

impl ManifestV1 {
    /// The ground sampling distance MM↔aerial registration works at, metres: the explicit
    /// parameter, else the aerial frames' GSD, else [`DEFAULT_AERIAL_GSD_M`].
    pub fn aerial_gsd_m(&self) -> f64 {
        let frames = self.aerial.as_ref().and_then(|a| a.frames.as_ref()).map(|f| f.gsd_m);
        self.parameters.registration.aerial_gsd_m.or(frames).unwrap_or(DEFAULT_AERIAL_GSD_M)
    }
}
