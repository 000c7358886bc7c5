//! What reading rasters (`gdal_read`) and parsing VRT mosaics (`vrt`) share, below both (it imports
//! neither): why a raster could not be read ([`GdalReadError`]) and a box in mapping coordinates
//! ([`MapBox`]). Both are public as `gdal_read::GdalReadError` and `gdal_read::MapBox`.

use gdal::errors::GdalError;

/// Why a raster could not be read, naming the raster and the step.
#[derive(Debug, thiserror::Error)]
pub enum GdalReadError {
    /// A GDAL call failed.
    #[error("{name}: GDAL could not {step}: {source}")]
    Gdal {
        /// The raster (its URL or path).
        name: String,
        /// What was being done.
        step: String,
        /// GDAL's error.
        #[source]
        source: GdalError,
    },
    /// The raster is readable but not usable as asked.
    #[error("{name}: {problem}")]
    Unusable {
        /// The raster (its URL or path).
        name: String,
        /// What is wrong.
        problem: String,
    },
}

/// A box in mapping coordinates (the raster's CRS), metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapBox {
    /// Smallest easting.
    pub min_e: f64,
    /// Smallest northing.
    pub min_n: f64,
    /// Largest easting.
    pub max_e: f64,
    /// Largest northing.
    pub max_n: f64,
}
