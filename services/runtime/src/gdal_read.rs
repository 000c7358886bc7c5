//! Read georeferenced rasters (orthophotos, terrain models) through GDAL, a window at a time.
//!
//! A [`RasterSource`] opens a GeoTIFF (or anything GDAL reads) once — from a local path directly, or from
//! bytes fetched from an object store through GDAL's in-memory file system — and serves windows given as
//! mapping-coordinate boxes, so a city orthophoto is never decoded whole. Handles are not `Send`: open one
//! source per thread.

use std::path::{Path, PathBuf};

use gdal::Dataset;
use gdal::errors::GdalError;
use gdal::raster::{GdalDataType, GdalType};

use crate::crs::route_gdal_messages;
use crate::gdal_write::{Raster, RasterData};

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

/// An open raster: its size, georeferencing and bands, ready to serve windows.
#[derive(Debug)]
pub struct RasterSource {
    name: String,
    dataset: Dataset,
    /// In-memory file to remove on drop, when opened from bytes.
    vsimem: Option<PathBuf>,
    width: usize,
    height: usize,
    geotransform: [f64; 6],
    epsg: Option<u32>,
}

impl RasterSource {
    /// Open a raster file on the local file system.
    pub fn open_path(path: &Path) -> Result<Self, GdalReadError> {
        route_gdal_messages();
        let name = path.display().to_string();
        let dataset = Dataset::open(path).map_err(failed(&name, "open the raster"))?;
        Self::from_dataset(name, dataset, None)
    }

    /// Open a raster from its bytes (e.g. fetched from an object store); `name` is used in errors.
    pub fn open_bytes(name: &str, bytes: Vec<u8>) -> Result<Self, GdalReadError> {
        route_gdal_messages();
        let path = PathBuf::from(crate::gdal_write::vsimem_path("tif"));
        gdal::vsi::create_mem_file(&path, bytes).map_err(failed(name, "hold the bytes in memory"))?;
        match Dataset::open(&path) {
            Ok(dataset) => Self::from_dataset(name.to_owned(), dataset, Some(path)),
            Err(e) => {
                let _ = gdal::vsi::unlink_mem_file(&path);
                Err(failed(name, "open the raster")(e))
            }
        }
    }

    fn from_dataset(name: String, dataset: Dataset, vsimem: Option<PathBuf>) -> Result<Self, GdalReadError> {
        let unusable = |problem: String| GdalReadError::Unusable { name: name.clone(), problem };
        let (width, height) = dataset.raster_size();
        if dataset.raster_count() == 0 || width == 0 || height == 0 {
            return Err(unusable(format!("{width}×{height} px with {} bands holds no pixels", dataset.raster_count())));
        }
        let geotransform =
            dataset.geo_transform().map_err(|_| unusable("has no geotransform (not georeferenced)".into()))?;
        if geotransform[2] != 0.0 || geotransform[4] != 0.0 || geotransform[1] <= 0.0 || geotransform[5] >= 0.0 {
            return Err(unusable(format!("geotransform {geotransform:?} is rotated or not north-up")));
        }
        let epsg = dataset.spatial_ref().ok().and_then(|s| s.auth_code().ok()).and_then(|c| u32::try_from(c).ok());
        Ok(Self { name, dataset, vsimem, width, height, geotransform, epsg })
    }

    /// Width and height in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// GDAL geotransform of the whole raster.
    pub fn geotransform(&self) -> [f64; 6] {
        self.geotransform
    }

    /// EPSG code of the raster's CRS, when it has one GDAL can name.
    pub fn epsg(&self) -> Option<u32> {
        self.epsg
    }

    /// The pixel window (column, row, width, height) covering `area`, clipped to the raster; `None` when
    /// the area lies outside it.
    pub fn pixel_window(&self, area: &MapBox) -> Option<(usize, usize, usize, usize)> {
        let g = &self.geotransform;
        let c0 = ((area.min_e - g[0]) / g[1]).floor().max(0.0);
        let c1 = ((area.max_e - g[0]) / g[1]).ceil().min(self.width as f64);
        let r0 = ((area.max_n - g[3]) / g[5]).floor().max(0.0);
        let r1 = ((area.min_n - g[3]) / g[5]).ceil().min(self.height as f64);
        if !(c0.is_finite() && c1.is_finite() && r0.is_finite() && r1.is_finite()) || c1 <= c0 || r1 <= r0 {
            return None;
        }
        Some((c0 as usize, r0 as usize, (c1 - c0) as usize, (r1 - r0) as usize))
    }

    /// Read the window covering `area` (all bands, in the raster's own pixel type: 8-bit or float), with
    /// the geotransform of the window; `None` when the area lies outside the raster.
    pub fn window(&self, area: &MapBox) -> Result<Option<Raster>, GdalReadError> {
        let Some((col, row, w, h)) = self.pixel_window(area) else {
            return Ok(None);
        };
        let band1 = self.dataset.rasterband(1).map_err(failed(&self.name, "open band 1"))?;
        let nodata = band1.no_data_value();
        let data = match band1.band_type() {
            GdalDataType::UInt8 => RasterData::U8(self.bands::<u8>(col, row, w, h)?),
            _ => RasterData::F32(self.bands::<f32>(col, row, w, h)?),
        };
        let g = self.geotransform;
        let geotransform = [g[0] + col as f64 * g[1], g[1], 0.0, g[3] + row as f64 * g[5], 0.0, g[5]];
        Ok(Some(Raster { width: w, height: h, geotransform, epsg: self.epsg.unwrap_or(0), data, nodata }))
    }

    fn bands<T: GdalType + Copy>(
        &self,
        col: usize,
        row: usize,
        w: usize,
        h: usize,
    ) -> Result<Vec<Vec<T>>, GdalReadError> {
        (1..=self.dataset.raster_count())
            .map(|b| {
                let band = self.dataset.rasterband(b).map_err(failed(&self.name, format!("open band {b}")))?;
                let buffer = band
                    .read_as::<T>((col as isize, row as isize), (w, h), (w, h), None)
                    .map_err(failed(&self.name, format!("read band {b} at column {col}, row {row}, {w}×{h} px")))?;
                Ok(buffer.into_shape_and_vec().1)
            })
            .collect()
    }
}

impl Drop for RasterSource {
    fn drop(&mut self) {
        if let Some(path) = self.vsimem.take() {
            // The dataset still holds the file open; GDAL frees the memory once both are gone.
            let _ = gdal::vsi::unlink_mem_file(&path);
        }
    }
}

fn failed(name: &str, step: impl Into<String>) -> impl FnOnce(GdalError) -> GdalReadError {
    let (name, step) = (name.to_owned(), step.into());
    move |source| GdalReadError::Gdal { name, step, source }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gdal_write::geotiff;

    fn ramp(width: usize, height: usize) -> Raster {
        let data: Vec<f32> = (0..width * height).map(|i| i as f32).collect();
        let geotransform = [500_000.0, 0.5, 0.0, 5_000_100.0, 0.0, -0.5];
        Raster { width, height, geotransform, epsg: 25832, data: RasterData::F32(vec![data]), nodata: None }
    }

    #[test]
    fn a_window_holds_the_pixels_and_georeferencing_of_its_area() {
        let bytes = geotiff(&ramp(40, 30)).unwrap();
        let source = RasterSource::open_bytes("mem.tif", bytes).unwrap();
        assert_eq!((source.size(), source.epsg()), ((40, 30), Some(25832)));
        // Columns 4..10 (E 500002–500005), rows 2..6 (N 5000099–5000097).
        let area = MapBox { min_e: 500_002.0, min_n: 5_000_097.0, max_e: 500_005.0, max_n: 5_000_099.0 };
        let w = source.window(&area).unwrap().unwrap();
        assert_eq!((w.width, w.height), (6, 4));
        assert_eq!(w.geotransform, [500_002.0, 0.5, 0.0, 5_000_099.0, 0.0, -0.5]);
        let RasterData::F32(bands) = &w.data else { panic!("float raster expected") };
        assert_eq!(bands[0][0], (2 * 40 + 4) as f32);
        assert_eq!(bands[0][6 * 4 - 1], (5 * 40 + 9) as f32);
    }

    #[test]
    fn opens_a_local_file_by_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("terrain.tif");
        std::fs::write(&path, geotiff(&ramp(8, 6)).unwrap()).unwrap();
        let source = RasterSource::open_path(&path).unwrap();
        assert_eq!(source.geotransform(), ramp(8, 6).geotransform);
        let e = RasterSource::open_path(&dir.path().join("missing.tif")).unwrap_err();
        assert!(e.to_string().contains("missing.tif"), "{e}");
    }

    #[test]
    fn windows_are_clipped_to_the_raster_and_outside_areas_give_none() {
        let source = RasterSource::open_bytes("mem.tif", geotiff(&ramp(40, 30)).unwrap()).unwrap();
        let overlapping = MapBox { min_e: 499_990.0, min_n: 5_000_090.0, max_e: 500_001.0, max_n: 5_000_200.0 };
        assert_eq!(source.pixel_window(&overlapping), Some((0, 0, 2, 20)));
        let outside = MapBox { min_e: 600_000.0, min_n: 5_000_090.0, max_e: 600_001.0, max_n: 5_000_091.0 };
        assert!(source.window(&outside).unwrap().is_none());
    }

    #[test]
    fn eight_bit_bands_stay_eight_bit() {
        let raster = Raster {
            width: 4,
            height: 2,
            geotransform: [0.0, 1.0, 0.0, 2.0, 0.0, -1.0],
            epsg: 25832,
            data: RasterData::U8(vec![vec![1; 8], vec![2; 8], vec![3; 8]]),
            nodata: None,
        };
        let source = RasterSource::open_bytes("rgb.tif", geotiff(&raster).unwrap()).unwrap();
        let all = MapBox { min_e: 0.0, min_n: 0.0, max_e: 4.0, max_n: 2.0 };
        let w = source.window(&all).unwrap().unwrap();
        assert_eq!(w.data, raster.data);
    }

    #[test]
    fn garbage_and_ungeoreferenced_rasters_are_named_errors() {
        let e = RasterSource::open_bytes("broken.tif", b"not a tiff".to_vec()).unwrap_err();
        assert!(e.to_string().starts_with("broken.tif: GDAL could not open the raster"), "{e}");
        let png = {
            let mut out = std::io::Cursor::new(Vec::new());
            image::GrayImage::new(3, 3).write_to(&mut out, image::ImageFormat::Png).unwrap();
            out.into_inner()
        };
        let e = RasterSource::open_bytes("plain.png", png).unwrap_err();
        assert!(e.to_string().contains("not georeferenced"), "{e}");
    }
}
