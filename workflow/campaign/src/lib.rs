//! The campaign manifest of plumbline: its versioned types, reading them from TOML or JSON,
//! validating them with every problem named by field path, and their JSON Schema.
//!
//! Synchronous and I/O-free: callers pass text in and get values and errors back. Locations in a
//! manifest are resolved against the manifest's own URL with [`resolve`] by the service layer.
//!
//! ```text
//! Manifest::from_toml_str / from_json_str → Manifest (versioned) → validate() → ValidManifest (every
//!     problem named by field path)
//! tables::read_index / read_exterior → Table (good rows kept, bad rows listed with line and field)
//! plan::plan_campaign(panoramas, depth, trajectory, tiling) → CampaignPlan (tiles, owned and context images)
//! Campaign: all of it loaded (the scheduler loads it); Campaign::url / file_url resolve its locations
//! ```
//!
//! ```
//! let text = r#"
//! version = "1"
//! crs = 25832
//! output = "results/"
//! [campaign]
//! id = "hh-2024"
//! name = "Hamburg 2024"
//! [[trajectory]]
//! format = "sbet"
//! url = "sbet.out"
//! "#;
//! let manifest = plumbline_campaign::Manifest::from_toml_str(text)?;
//! let valid = manifest.validate()?;
//! assert_eq!(valid.tiling.tile_size_m, 250.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod cadastre_features;
mod epsg;
mod id;
mod inputs;
mod loaded;
mod location;
pub mod manifest;
mod parse;
pub mod plan;
mod problem;
pub mod progress;
mod schema;
pub mod skipped;
pub mod tables;
mod validate;

pub use cadastre_features::{
    CadastreDiagnostic, CadastreFeature, CadastreFeatureId, Consequence, DiagnosticKind, count_diagnostics,
};
pub use epsg::{EPSG_CRS_RANGE, Epsg, EpsgKind};
pub use id::{CampaignId, CampaignIdError, MAX_CAMPAIGN_ID_LEN};
pub use loaded::{Campaign, LoadedTrajectory, LocationError, TrajectoryFormat};
pub use location::{Location, ResolveError, SCHEMES, resolve, resolve_below};
pub use manifest::{Manifest, ManifestV1};
pub use parse::{Format, ParseError, Position, SUPPORTED_VERSIONS};
pub use problem::{FieldPath, Problem, Problems};
pub use progress::Stage;
pub use schema::{MANIFEST_SCHEMA_FILE, canonical_json, manifest_schema, manifest_schema_json};
pub use skipped::{SkipReason, SkippedInput};
pub use validate::ValidManifest;
