//! Cadastres of pole-like objects read from GeoPackages through GDAL (issue 6, item 1; paper 002 §3.3.2).
//!
//! [`read_cadastre`] reads the point layers a manifest's `[[cadastres]]` entry names, reprojects them
//! into the campaign CRS, assigns class, accuracy and diameter, and filters by a tile's box. Messy
//! files do not stop it: every layer or feature it cannot use as read gives a counted
//! [`CadastreDiagnostic`] naming file, layer, FID and field, and the good features are still used.
//! [`inspect_cadastre`] reports what a file holds, for `plumbline cadastre inspect`.
//!
//! Sources: a local path, or bytes (an object fetched with [`crate::read_url`]), which are opened from
//! GDAL's in-memory file system (`/vsimem/`) and removed afterwards. Object-store URLs are not opened
//! directly: the caller fetches them.
//!
//! Threads: GDAL handles are not `Send`; every call opens its own dataset.

mod attributes;
mod geometry;
mod inspect;
mod read;
mod srs;

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use gdal::errors::GdalError;
use gdal::{Dataset, DatasetOptions, GdalOpenFlags};
use plumbline_campaign::Epsg;
pub use plumbline_campaign::{CadastreDiagnostic, CadastreFeature, CadastreFeatureId, Consequence, DiagnosticKind};
use serde::Serialize;

pub use attributes::MAX_DIAMETER_M;
pub use inspect::{CadastreInspection, ClassValues, FieldInfo, LayerCrs, LayerInspection, inspect_cadastre};
pub use read::read_cadastre;

/// Where a cadastre GeoPackage comes from.
#[derive(Debug, Clone, Copy)]
pub enum CadastreSource<'a> {
    /// A local file.
    Path(&'a Path),
    /// The file's bytes, e.g. fetched from an object store; `name` is used in diagnostics.
    Bytes {
        /// How diagnostics name the file (its URL).
        name: &'a str,
        /// The GeoPackage's content.
        bytes: &'a [u8],
    },
}

impl CadastreSource<'_> {
    /// How diagnostics name the file.
    pub fn name(&self) -> String {
        match self {
            Self::Path(path) => path.display().to_string(),
            Self::Bytes { name, .. } => (*name).to_owned(),
        }
    }
}

/// Everything read from one cadastre.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CadastreRead {
    /// The usable objects, in the campaign CRS, inside the box when one was given.
    pub features: Vec<CadastreFeature>,
    /// Every problem found, in reading order.
    pub diagnostics: Vec<CadastreDiagnostic>,
    /// What happened per layer, in the manifest's order.
    pub layers: Vec<LayerCounts>,
}

/// Counts of one layer's features.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct LayerCounts {
    /// The layer's name.
    pub layer: String,
    /// Whether the layer was read at all (it exists and its SRS is usable).
    pub read: bool,
    /// Features looked at (after GDAL's spatial filter when a box was given).
    pub examined: usize,
    /// Objects produced (a multipoint gives several).
    pub used: usize,
    /// Features skipped because of a diagnostic.
    pub skipped: usize,
    /// Objects outside the box after exact reprojection.
    pub outside_bbox: usize,
}

/// Why a cadastre could not be read at all (problems within a file are diagnostics, not errors).
#[derive(Debug, thiserror::Error)]
pub enum CadastreError {
    /// The file is missing or not a GeoPackage.
    #[error("cannot open {file} as a GeoPackage: {source}")]
    Open {
        /// The file.
        file: String,
        /// GDAL's reason.
        #[source]
        source: GdalError,
    },
    /// The campaign's CRS is unknown to PROJ.
    #[error("campaign CRS {epsg} is unknown: {source}")]
    CampaignCrs {
        /// The campaign's code.
        epsg: Epsg,
        /// GDAL's reason.
        #[source]
        source: GdalError,
    },
    /// The tile box is not `[min_x, min_y, max_x, max_y]` with finite, ordered values.
    #[error("tile box {bbox:?} is not [min_x, min_y, max_x, max_y] with finite min ≤ max")]
    BadBox {
        /// The box given.
        bbox: [f64; 4],
    },
}

/// An open GeoPackage; for bytes, the in-memory file is removed when this is dropped.
#[derive(Debug)]
pub(crate) struct OpenCadastre {
    // Field order matters: the dataset closes before the in-memory file is unlinked.
    pub(crate) dataset: Dataset,
    _memory: Option<MemoryFile>,
}

#[derive(Debug)]
struct MemoryFile(String);

impl Drop for MemoryFile {
    fn drop(&mut self) {
        // Nothing useful can be done if GDAL cannot remove its own in-memory file.
        let _ = gdal::vsi::unlink_mem_file(&self.0);
    }
}

impl OpenCadastre {
    /// Opens `source` read-only with the GeoPackage driver only.
    pub(crate) fn open(source: CadastreSource<'_>) -> Result<Self, CadastreError> {
        crate::crs::route_gdal_messages();
        let file = source.name();
        let open_error = |source| CadastreError::Open { file: file.clone(), source };
        let (path, memory) = match source {
            CadastreSource::Path(path) => (path.to_path_buf(), None),
            CadastreSource::Bytes { bytes, .. } => {
                static NEXT: AtomicU64 = AtomicU64::new(0);
                let n = NEXT.fetch_add(1, Ordering::Relaxed);
                let name = format!("/vsimem/plumbline-cadastre-{}-{n}.gpkg", std::process::id());
                gdal::vsi::create_mem_file(&name, bytes.to_vec()).map_err(open_error)?;
                (name.clone().into(), Some(MemoryFile(name)))
            }
        };
        let options = DatasetOptions {
            open_flags: GdalOpenFlags::GDAL_OF_VECTOR | GdalOpenFlags::GDAL_OF_READONLY,
            allowed_drivers: Some(&["GPKG"]),
            ..Default::default()
        };
        let dataset = Dataset::open_ex(&path, options).map_err(open_error)?;
        Ok(Self { dataset, _memory: memory })
    }
}
