//! A campaign as the services hold it once its inputs are read: the validated manifest, the DG trajectory in
//! the campaign CRS (with what is needed to write it back the way it came), the aerial orientations, the
//! tile plan and what was skipped. Reading it is the scheduler's job; this crate only defines the value and
//! resolves its locations.

use plumbline_geo::Trajectory;
use plumbline_geo::formats::Horizontal;

use crate::location::{Location, ResolveError, resolve, resolve_below};
use crate::manifest::ManifestV1;
use crate::plan::CampaignPlan;
use crate::skipped::SkippedInput;
use crate::tables::ExteriorRow;

/// File formats of trajectories.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrajectoryFormat {
    /// Header-driven CSV (projected or geographic columns).
    Csv,
    /// Applanix SBET (WGS84 geographic, binary), standard deviations in a companion smrmsg file.
    Sbet,
}

impl TrajectoryFormat {
    /// The format a file name implies: `.sbet`/`.out` are SBET, anything else CSV.
    pub fn of(url: &str) -> Self {
        let lower = url.to_ascii_lowercase();
        if lower.ends_with(".sbet") || lower.ends_with(".out") { Self::Sbet } else { Self::Csv }
    }
}

/// A trajectory in the campaign CRS, with what is needed to write it back the way it came.
#[derive(Debug, Clone)]
pub struct LoadedTrajectory {
    /// Validated records in the campaign CRS.
    pub trajectory: Trajectory,
    /// The file's format.
    pub format: TrajectoryFormat,
    /// The file's horizontal coordinates.
    pub horizontal: Horizontal,
    /// EPSG code of the campaign CRS (None: a projected CSV of unstated CRS, kept as it is).
    pub epsg: Option<u32>,
    /// File name, for messages.
    pub name: String,
}

/// A campaign ready to process.
#[derive(Clone, Debug)]
pub struct Campaign {
    /// The manifest's absolute URL: relative locations resolve against it.
    pub base: String,
    /// The manifest.
    pub manifest: ManifestV1,
    /// The output prefix (absolute, ending in `/`).
    pub output: String,
    /// The DG trajectory in the campaign CRS, with how to write it back.
    pub trajectory: LoadedTrajectory,
    /// The reference trajectory in the campaign CRS, when the manifest names one that could be read.
    pub reference: Option<Trajectory>,
    /// Aerial exterior orientations (frame block), in table order.
    pub aerial_frames: Vec<ExteriorRow>,
    /// The tile plan.
    pub plan: CampaignPlan,
    /// What was skipped while loading.
    pub skipped: Vec<SkippedInput>,
}

/// A location of the manifest or of an index row that does not resolve: the location as written and why.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{location}: {error}")]
pub struct LocationError {
    /// The location as the manifest or the row wrote it.
    pub location: String,
    /// Why it does not resolve.
    pub error: ResolveError,
}

impl Campaign {
    /// The absolute path or URL of a manifest location.
    pub fn url(&self, location: &Location) -> Result<String, LocationError> {
        resolve(&self.base, location.as_str())
            .map_err(|error| LocationError { location: location.as_str().to_owned(), error })
    }

    /// The URL of a file named by an index row, under the manifest's `images` prefix: a row naming an absolute
    /// URL or path, or climbing above the prefix with `..`, is refused (another agency's objects, worker-local
    /// files).
    pub fn file_url(&self, prefix: &Location, file: &str) -> Result<String, LocationError> {
        let mut dir = self.url(prefix)?;
        if !dir.ends_with('/') {
            dir.push('/');
        }
        resolve_below(&dir, file).map_err(|error| LocationError { location: file.to_owned(), error })
    }

    /// The campaign CRS.
    pub fn epsg(&self) -> u32 {
        self.manifest.crs.0
    }
}
