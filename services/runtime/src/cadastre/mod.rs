//! Cadastres of pole-like objects read from GeoPackages through GDAL (Meyer et al. 2023 §3.3.2).
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
mod walk;

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use gdal::errors::GdalError;
use gdal::{Dataset, DatasetOptions, GdalOpenFlags};
use plumbline_campaign::Epsg;
pub use plumbline_campaign::{CadastreDiagnostic, CadastreFeature, CadastreFeatureId, Consequence, DiagnosticKind};
use serde::Serialize;

use crate::gdal_messages::capture_failures;

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
    /// The local file cannot be read (missing, no permission).
    #[error("cannot read {file}: {source}")]
    Unreadable {
        /// The file.
        file: String,
        /// The operating system's reason.
        #[source]
        source: std::io::Error,
    },
    /// The file can be read but holds no GeoPackage vector data: empty, another format, raster tiles only,
    /// or an SQLite database without the GeoPackage tables.
    #[error("{file} is not a GeoPackage with vector layers: {problem}")]
    NotVector {
        /// The file.
        file: String,
        /// What it is instead.
        problem: String,
    },
    /// The tile box is not `[min_x, min_y, max_x, max_y]` with finite, ordered values.
    #[error("tile box {bbox:?} is not [min_x, min_y, max_x, max_y] with finite min ≤ max")]
    BadBox {
        /// The box given.
        bbox: [f64; 4],
    },
}

impl CadastreError {
    /// Whether the file itself is at fault (missing, unreadable, not a GeoPackage), as opposed to the
    /// campaign's CRS or the caller's box.
    pub fn is_file_problem(&self) -> bool {
        matches!(self, Self::Open { .. } | Self::Unreadable { .. } | Self::NotVector { .. })
    }
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
    /// Opens `source` read-only with the GeoPackage driver only. The first bytes are looked at before GDAL
    /// sees the file, so an empty file (a failed upload), a text file or another format is named for what it
    /// is, and GDAL never receives an empty in-memory buffer.
    pub(crate) fn open(source: CadastreSource<'_>) -> Result<Self, CadastreError> {
        crate::gdal_messages::route_gdal_messages();
        let file = source.name();
        let open_error = |source| CadastreError::Open { file: file.clone(), source };
        let not_vector = |problem: String| CadastreError::NotVector { file: file.clone(), problem };
        let (path, memory) = match source {
            CadastreSource::Path(path) => {
                let head =
                    read_head(path).map_err(|source| CadastreError::Unreadable { file: file.clone(), source })?;
                sniff(&head.0, head.1).map_err(not_vector)?;
                (path.to_path_buf(), None)
            }
            CadastreSource::Bytes { bytes, .. } => {
                sniff(bytes, bytes.len() as u64).map_err(not_vector)?;
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
        let (opened, messages) = capture_failures(|| Dataset::open_ex(&path, options));
        let dataset = match opened {
            Ok(dataset) => dataset,
            Err(e) => {
                let raster = DatasetOptions {
                    open_flags: GdalOpenFlags::GDAL_OF_RASTER | GdalOpenFlags::GDAL_OF_READONLY,
                    allowed_drivers: Some(&["GPKG"]),
                    ..Default::default()
                };
                if capture_failures(|| Dataset::open_ex(&path, raster)).0.is_ok() {
                    return Err(not_vector("it holds raster tiles only".into()));
                }
                return Err(match messages.last() {
                    Some(m) => not_vector(format!("GDAL: {m}")),
                    None => not_vector(format!(
                        "GDAL's GeoPackage driver does not open it for vector data (no vector layer, or damaged \
                         GeoPackage tables): {e}"
                    )),
                });
            }
        };
        if dataset.layer_count() == 0 {
            return Err(not_vector("it holds no vector layer".into()));
        }
        Ok(Self { dataset, _memory: memory })
    }
}

/// SQLite's 16-byte file header, which every GeoPackage starts with.
const SQLITE_HEADER: &[u8; 16] = b"SQLite format 3\0";

/// Up to the first 100 bytes of a local file and its length.
fn read_head(path: &Path) -> std::io::Result<(Vec<u8>, u64)> {
    use std::io::Read as _;
    let file = std::fs::File::open(path)?;
    let len = file.metadata()?.len();
    let mut head = Vec::with_capacity(100);
    file.take(100).read_to_end(&mut head)?;
    Ok((head, len))
}

/// Why the bytes that start a file (of `len` bytes) cannot be a GeoPackage, before GDAL is asked.
pub(crate) fn sniff(head: &[u8], len: u64) -> Result<(), String> {
    if len == 0 {
        return Err("the file is empty (0 bytes; a failed upload or copy?)".into());
    }
    if !head.starts_with(SQLITE_HEADER) {
        let shown: String =
            head.iter().take(16).map(|&b| if b.is_ascii_graphic() || b == b' ' { b as char } else { '.' }).collect();
        return Err(format!("no SQLite header (the file's {len} bytes start with `{shown}`)"));
    }
    if len < 1024 {
        return Err(format!("{len} bytes is shorter than one SQLite page (truncated?)"));
    }
    Ok(())
}
