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

use crate::gdal_messages::route_gdal_messages;
use crate::gdal_write::{Raster, RasterData};
use crate::store::GdalRemote;

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

/// An open raster of any kind, georeferenced or not (aerial frames are placed by their own orientation, not
/// by a geotransform): its size, bands and pixel windows. Opened from a local path, from bytes, or from a
/// remote GDAL path (`/vsicurl/…` of a signed URL, see `Files::remote_raster`) whose windows GDAL reads with
/// HTTP range requests, so that only the tiles a window touches are transferred.
#[derive(Debug)]
pub struct PixelSource {
    name: String,
    dataset: Dataset,
    /// In-memory files to remove on drop, when opened from bytes.
    vsimem: Vec<PathBuf>,
    /// Thread-local GDAL options to clear on drop, when opened over the network.
    thread_options: Vec<String>,
}

impl PixelSource {
    /// Open a raster file on the local file system.
    pub fn open_path(path: &Path) -> Result<Self, GdalReadError> {
        route_gdal_messages();
        let name = path.display().to_string();
        if std::fs::metadata(path).is_ok_and(|m| m.len() == 0) {
            return Err(GdalReadError::Unusable { name, problem: "is empty (0 bytes)".into() });
        }
        let dataset = Dataset::open(path).map_err(failed(&name, "open the raster"))?;
        Self::checked(name, dataset, Vec::new())
    }

    /// Open a raster from its bytes; `name` is used in errors.
    pub fn open_bytes(name: &str, bytes: Vec<u8>) -> Result<Self, GdalReadError> {
        Self::open_in_memory(name, "raster.tif", bytes, Vec::new())
    }

    /// Open a raster GDAL reads itself over the network with range requests (`remote.path`, e.g. `/vsis3/…`,
    /// with `remote.options` carrying endpoint and credentials); `name` (the URL the campaign gave) is used in
    /// errors. The options are set for this thread while the source is open (a source never leaves its
    /// thread) and cleared when it is dropped. GDAL fetches the header and then, per window, the byte ranges
    /// of the tiles the window touches.
    pub fn open_remote(name: &str, remote: &GdalRemote) -> Result<Self, GdalReadError> {
        route_gdal_messages();
        let mut options = remote.options.clone();
        // Never list the "directory" of an object to look for side-car files.
        options.push(("GDAL_DISABLE_READDIR_ON_OPEN".to_owned(), "EMPTY_DIR".to_owned()));
        options.push(("GDAL_HTTP_MAX_RETRY".to_owned(), "3".to_owned()));
        options.push(("GDAL_HTTP_RETRY_DELAY".to_owned(), "1".to_owned()));
        for (key, value) in &options {
            gdal::config::set_thread_local_config_option(key, value)
                .map_err(failed(name, format!("set the GDAL option {key}")))?;
        }
        let keys: Vec<String> = options.into_iter().map(|(k, _)| k).collect();
        let opened = Dataset::open(Path::new(&remote.path)).map_err(failed(name, "open the raster over the network"));
        match opened {
            Ok(dataset) => {
                let mut source = Self::checked(name.to_owned(), dataset, Vec::new())?;
                source.thread_options = keys;
                Ok(source)
            }
            Err(e) => {
                clear_thread_options(&keys);
                Err(e)
            }
        }
    }

    /// Hold `bytes` as `{dir}/{file}` and the `others` beside it in GDAL's in-memory file system, and open it.
    fn open_in_memory(
        name: &str,
        file: &str,
        bytes: Vec<u8>,
        others: Vec<(String, Vec<u8>)>,
    ) -> Result<Self, GdalReadError> {
        route_gdal_messages();
        let dir = crate::gdal_write::vsimem_path("dir");
        let mut held = Vec::new();
        let mut hold = |relative: &str, bytes: Vec<u8>| {
            // GDAL takes ownership of the buffer; an empty `Vec` has no allocation for it to free.
            if bytes.is_empty() {
                let problem = format!("{relative} is empty (0 bytes)");
                return Err(GdalReadError::Unusable { name: name.to_owned(), problem });
            }
            let path = PathBuf::from(format!("{dir}/{relative}"));
            let result = gdal::vsi::create_mem_file(&path, bytes);
            held.push(path);
            result.map_err(failed(name, format!("hold {relative} in memory")))
        };
        let result =
            others.into_iter().try_for_each(|(relative, b)| hold(&relative, b)).and_then(|()| hold(file, bytes));
        let opened = result.and_then(|()| {
            Dataset::open(held.last().map_or(Path::new(""), PathBuf::as_path)).map_err(failed(name, "open the raster"))
        });
        match opened {
            Ok(dataset) => Self::checked(name.to_owned(), dataset, held),
            Err(e) => {
                for path in &held {
                    let _ = gdal::vsi::unlink_mem_file(path);
                }
                Err(e)
            }
        }
    }

    fn checked(name: String, dataset: Dataset, vsimem: Vec<PathBuf>) -> Result<Self, GdalReadError> {
        let (width, height) = dataset.raster_size();
        let source = Self { name, dataset, vsimem, thread_options: Vec::new() };
        if source.dataset.raster_count() == 0 || width == 0 || height == 0 {
            let bands = source.dataset.raster_count();
            let problem = format!("{width}×{height} px with {bands} bands holds no pixels");
            return Err(GdalReadError::Unusable { name: source.name.clone(), problem });
        }
        Ok(source)
    }

    /// The name used in errors.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Width and height in pixels.
    pub fn size(&self) -> (usize, usize) {
        self.dataset.raster_size()
    }

    /// Number of bands.
    pub fn band_count(&self) -> usize {
        self.dataset.raster_count()
    }

    /// The pixel type of band 1 as GDAL names it (`Byte`, `UInt16`, `Float32`, …).
    pub fn pixel_type(&self) -> Result<String, GdalReadError> {
        let band = self.dataset.rasterband(1).map_err(failed(&self.name, "open band 1"))?;
        Ok(band.band_type().name())
    }

    /// True when band 1 holds 8-bit pixels.
    pub fn is_eight_bit(&self) -> Result<bool, GdalReadError> {
        let band = self.dataset.rasterband(1).map_err(failed(&self.name, "open band 1"))?;
        Ok(band.band_type() == GdalDataType::UInt8)
    }

    /// The pixels of bands `1..=bands.min(band_count)` in the window at column `col`, row `row` of `w` × `h`
    /// pixels (which must lie inside the raster), as `f32` whatever their type; one row-major `Vec` per band.
    pub fn read_f32(
        &self,
        (col, row, w, h): (usize, usize, usize, usize),
        bands: usize,
    ) -> Result<Vec<Vec<f32>>, GdalReadError> {
        self.bands::<f32>(col, row, w, h, bands)
    }

    fn bands<T: GdalType + Copy>(
        &self,
        col: usize,
        row: usize,
        w: usize,
        h: usize,
        bands: usize,
    ) -> Result<Vec<Vec<T>>, GdalReadError> {
        let (width, height) = self.size();
        if col.saturating_add(w) > width || row.saturating_add(h) > height || w == 0 || h == 0 {
            let problem = format!("window at column {col}, row {row}, {w}×{h} px lies outside its {width}×{height} px");
            return Err(GdalReadError::Unusable { name: self.name.clone(), problem });
        }
        (1..=self.dataset.raster_count().min(bands))
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

impl Drop for PixelSource {
    fn drop(&mut self) {
        for path in self.vsimem.drain(..) {
            // The dataset still holds the file open; GDAL frees the memory once both are gone.
            let _ = gdal::vsi::unlink_mem_file(&path);
        }
        clear_thread_options(&self.thread_options);
    }
}

/// Clear thread-local GDAL options set for a network read.
fn clear_thread_options(keys: &[String]) {
    for key in keys {
        let _ = gdal::config::clear_thread_local_config_option(key);
    }
}

/// Where a [`PixelSource`] is opened from: in place (a local file, or an object GDAL reads with range
/// requests) or from bytes already fetched (`Files::pixel_input` decides).
#[derive(Clone, Debug)]
pub enum PixelInput {
    /// A local file.
    Path(PathBuf),
    /// An object-store file GDAL reads itself.
    Remote(GdalRemote),
    /// The whole file's bytes.
    Bytes(Vec<u8>),
}

impl PixelInput {
    /// Open it; `name` (the URL) is used in errors.
    pub fn open(self, name: &str) -> Result<PixelSource, GdalReadError> {
        match self {
            Self::Path(path) => PixelSource::open_path(&path),
            Self::Remote(remote) => PixelSource::open_remote(name, &remote),
            Self::Bytes(bytes) => PixelSource::open_bytes(name, bytes),
        }
    }
}

/// Bytes to read from a file's start to tell a tiled raster ([`is_tiled_raster`]) from a JPEG or PNG.
pub const MAGIC_BYTES: u64 = 12;

/// Whether a file's first bytes are a TIFF, BigTIFF or JPEG 2000 file: rasters GDAL reads a window at a time
/// (a JPEG or PNG has to be decoded from its start).
pub fn is_tiled_raster(head: &[u8]) -> bool {
    const JP2: [u8; 12] = [0, 0, 0, 0x0C, b'j', b'P', b' ', b' ', 0x0D, 0x0A, 0x87, 0x0A];
    matches!(head, [b'I', b'I', 42 | 43, 0, ..] | [b'M', b'M', 0, 42 | 43, ..]) || head.starts_with(&JP2)
}

/// An open georeferenced raster: its size, georeferencing and bands, ready to serve windows given in mapping
/// coordinates.
#[derive(Debug)]
pub struct RasterSource {
    pixels: PixelSource,
    width: usize,
    height: usize,
    geotransform: [f64; 6],
    epsg: Option<u32>,
}

impl RasterSource {
    /// Open a raster file on the local file system.
    pub fn open_path(path: &Path) -> Result<Self, GdalReadError> {
        Self::georeferenced(PixelSource::open_path(path)?)
    }

    /// Open a raster from its bytes (e.g. fetched from an object store); `name` is used in errors. A VRT mosaic
    /// is refused: its tiles are named relative to it and cannot be reached from memory (use
    /// [`mosaic_tiles`] and [`RasterSource::open_mosaic_bytes`]).
    pub fn open_bytes(name: &str, bytes: Vec<u8>) -> Result<Self, GdalReadError> {
        if is_vrt(&bytes) {
            let problem = "is a VRT mosaic: its tiles are named relative to it and are not in memory; fetch the \
                           tiles the window needs (`mosaic_tiles`) and open it with `open_mosaic_bytes`"
                .to_owned();
            return Err(GdalReadError::Unusable { name: name.to_owned(), problem });
        }
        Self::georeferenced(PixelSource::open_bytes(name, bytes)?)
    }

    /// Open a VRT mosaic from its bytes and those of its tiles (paths relative to the VRT, as
    /// [`mosaic_tiles`] lists them); windows over tiles not given fail naming the tile.
    pub fn open_mosaic_bytes(name: &str, vrt: Vec<u8>, tiles: Vec<(String, Vec<u8>)>) -> Result<Self, GdalReadError> {
        Self::georeferenced(PixelSource::open_in_memory(name, "mosaic.vrt", vrt, tiles)?)
    }

    fn georeferenced(pixels: PixelSource) -> Result<Self, GdalReadError> {
        let unusable = |problem: String| GdalReadError::Unusable { name: pixels.name.clone(), problem };
        let (width, height) = pixels.size();
        let geotransform =
            pixels.dataset.geo_transform().map_err(|_| unusable("has no geotransform (not georeferenced)".into()))?;
        if geotransform[2] != 0.0 || geotransform[4] != 0.0 || geotransform[1] <= 0.0 || geotransform[5] >= 0.0 {
            return Err(unusable(format!("geotransform {geotransform:?} is rotated or not north-up")));
        }
        let epsg =
            pixels.dataset.spatial_ref().ok().and_then(|s| s.auth_code().ok()).and_then(|c| u32::try_from(c).ok());
        Ok(Self { pixels, width, height, geotransform, epsg })
    }

    /// Width and height in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// GDAL geotransform of the whole raster.
    pub fn geotransform(&self) -> [f64; 6] {
        self.geotransform
    }

    /// Number of bands.
    pub fn band_count(&self) -> usize {
        self.pixels.band_count()
    }

    /// The pixel type of band 1 as GDAL names it (`Byte`, `UInt16`, `Float32`, …).
    pub fn pixel_type(&self) -> Result<String, GdalReadError> {
        self.pixels.pixel_type()
    }

    /// The raster's extent in its own CRS.
    pub fn extent(&self) -> MapBox {
        let g = &self.geotransform;
        let (e1, n0) = (g[0] + self.width as f64 * g[1], g[3] + self.height as f64 * g[5]);
        MapBox { min_e: g[0], min_n: n0, max_e: e1, max_n: g[3] }
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
        let p = &self.pixels;
        let band1 = p.dataset.rasterband(1).map_err(failed(&p.name, "open band 1"))?;
        let nodata = band1.no_data_value();
        let all = p.band_count();
        let data = match band1.band_type() {
            GdalDataType::UInt8 => RasterData::U8(p.bands::<u8>(col, row, w, h, all)?),
            _ => RasterData::F32(p.bands::<f32>(col, row, w, h, all)?),
        };
        let g = self.geotransform;
        let geotransform = [g[0] + col as f64 * g[1], g[1], 0.0, g[3] + row as f64 * g[5], 0.0, g[5]];
        Ok(Some(Raster { width: w, height: h, geotransform, epsg: self.epsg.unwrap_or(0), data, nodata }))
    }
}

/// Whether the bytes are a GDAL VRT (XML starting with `<VRTDataset`).
pub fn is_vrt(bytes: &[u8]) -> bool {
    let text = bytes.get(..512.min(bytes.len())).unwrap_or_default();
    String::from_utf8_lossy(text).trim_start().starts_with("<VRTDataset")
}

/// The tiles of a VRT mosaic (paths relative to the VRT, each once) that hold pixels of `area`, read from each
/// source's `SourceFilename` and `DstRect` (what `gdalbuildvrt` and `gdal_write::vrt` write); empty when the
/// area misses the mosaic or the bytes are no VRT.
pub fn mosaic_tiles(name: &str, vrt: &[u8], area: &MapBox) -> Result<Vec<String>, GdalReadError> {
    if !is_vrt(vrt) {
        return Ok(Vec::new());
    }
    let text = String::from_utf8_lossy(vrt);
    let unusable = |problem: String| GdalReadError::Unusable { name: name.to_owned(), problem };
    let head = text.split("<VRTRasterBand").next().unwrap_or_default();
    let size = |key: &str| attribute(head, key).ok_or_else(|| unusable(format!("has no {key}")));
    let (width, height) = (size("rasterXSize")?, size("rasterYSize")?);
    let gt: Vec<f64> = element(head, "GeoTransform")
        .map(|g| g.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .unwrap_or_default();
    let [x0, dx, _, y0, _, dy] = gt[..] else { return Err(unusable("has no geotransform".into())) };
    // The area in mosaic pixels (as `pixel_window`).
    let (c0, c1) = ((area.min_e - x0) / dx, (area.max_e - x0) / dx);
    let (r0, r1) = ((area.max_n - y0) / dy, (area.min_n - y0) / dy);
    let mut tiles: Vec<String> = Vec::new();
    for source in text.split("<SourceFilename").skip(1) {
        let path = source.split_once('>').and_then(|(_, rest)| rest.split_once("</SourceFilename>")).map(|p| p.0);
        let rect = source.split_once("<DstRect").map(|(_, r)| r.split_once("/>").map_or(r, |r| r.0));
        let (Some(path), Some(rect)) = (path, rect) else { continue };
        let v = |key: &str| attribute(rect, key);
        let (Some(x), Some(y), Some(w), Some(h)) = (v("xOff"), v("yOff"), v("xSize"), v("ySize")) else { continue };
        let overlaps = c0 < x + w && c1 > x && r0 < y + h && r1 > y && x < width && y < height;
        let path = unescape(path);
        if overlaps && !tiles.contains(&path) {
            tiles.push(path);
        }
    }
    Ok(tiles)
}

/// The number in `key="…"` within `text`.
fn attribute(text: &str, key: &str) -> Option<f64> {
    let start = text.find(&format!("{key}=\""))? + key.len() + 2;
    text[start..].split('"').next()?.trim().parse().ok()
}

/// The text of the first `<tag>…</tag>` within `text`.
fn element<'t>(text: &'t str, tag: &str) -> Option<&'t str> {
    let start = text.find(&format!("<{tag}>"))? + tag.len() + 2;
    text[start..].split(&format!("</{tag}>")).next()
}

fn unescape(text: &str) -> String {
    text.replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"").replace("&amp;", "&")
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
    fn empty_rasters_are_refused_before_gdal_sees_them() {
        // An empty `Vec` handed to GDAL's in-memory file system was freed by GDAL: a segfault.
        let e = RasterSource::open_bytes("s3://b/empty.tif", Vec::new()).unwrap_err();
        assert_eq!(e.to_string(), "s3://b/empty.tif: raster.tif is empty (0 bytes)");
        let e = RasterSource::open_mosaic_bytes("m.vrt", b"<VRTDataset/>".to_vec(), vec![("t.tif".into(), vec![])])
            .unwrap_err();
        assert!(e.to_string().contains("t.tif is empty (0 bytes)"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.tif");
        std::fs::write(&path, b"").unwrap();
        let e = RasterSource::open_path(&path).unwrap_err();
        assert!(e.to_string().ends_with("empty.tif: is empty (0 bytes)"), "{e}");
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

    /// Two 8 × 6 ramp tiles side by side (the eastern one offset by 1000) and their VRT in a temporary directory.
    fn two_tile_mosaic(nodata: Option<f64>) -> (tempfile::TempDir, PathBuf) {
        use crate::gdal_write::{Mosaic, MosaicTile, MosaicType, vrt};
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("tiles")).unwrap();
        let mut east = ramp(8, 6);
        east.geotransform[0] += 4.0;
        let RasterData::F32(bands) = &mut east.data else { unreachable!() };
        bands[0].iter_mut().for_each(|v| *v += 1000.0);
        std::fs::write(dir.path().join("tiles/0_0.tif"), geotiff(&ramp(8, 6)).unwrap()).unwrap();
        std::fs::write(dir.path().join("tiles/1_0.tif"), geotiff(&east).unwrap()).unwrap();
        let tiles = vec![
            MosaicTile { path: "tiles/0_0.tif".into(), col: 0, row: 2 },
            MosaicTile { path: "tiles/1_0.tif".into(), col: 8, row: 2 },
        ];
        let mut geotransform = ramp(8, 6).geotransform;
        geotransform[3] += 1.0; // two empty rows above the tiles
        let mosaic = Mosaic {
            width: 16,
            height: 8,
            geotransform,
            epsg: 25832,
            bands: 1,
            data_type: MosaicType::F32,
            tile_size: (8, 6),
            nodata,
            tiles,
        };
        let path = dir.path().join("mosaic.vrt");
        std::fs::write(&path, vrt(&mosaic).unwrap()).unwrap();
        (dir, path)
    }

    #[test]
    fn a_vrt_mosaic_reads_across_its_tile_border_with_the_tiles_georeferencing() {
        let (_dir, path) = two_tile_mosaic(Some(-9999.0));
        let source = RasterSource::open_path(&path).unwrap();
        assert_eq!((source.size(), source.epsg()), ((16, 8), Some(25832)));
        // E 500003–500005 spans the last two columns of the west tile and the first two of the east tile;
        // N 5000101–5000099 the empty row 1 and the tiles' row 0.
        let area = MapBox { min_e: 500_003.0, min_n: 5_000_099.0, max_e: 500_005.0, max_n: 5_000_101.0 };
        let w = source.window(&area).unwrap().unwrap();
        assert_eq!((w.width, w.height, w.nodata), (4, 4, Some(-9999.0)));
        assert_eq!(w.geotransform, [500_003.0, 0.5, 0.0, 5_000_101.0, 0.0, -0.5]);
        let RasterData::F32(bands) = &w.data else { panic!("float raster expected") };
        assert_eq!(&bands[0][0..4], &[-9999.0; 4], "no tile there: no data");
        assert_eq!(&bands[0][8..12], &[6.0, 7.0, 1000.0, 1001.0], "row 0 of both tiles");
        assert_eq!(&bands[0][12..16], &[14.0, 15.0, 1008.0, 1009.0], "row 1 of both tiles");
    }

    #[test]
    fn mosaics_with_tiles_outside_or_escaping_paths_are_refused() {
        use crate::gdal_write::{Mosaic, MosaicTile, MosaicType, vrt};
        let tile = |path: &str, col| MosaicTile { path: path.into(), col, row: 0 };
        let mosaic = |tiles| Mosaic {
            width: 16,
            height: 6,
            geotransform: [0.0, 1.0, 0.0, 6.0, 0.0, -1.0],
            epsg: 25832,
            bands: 3,
            data_type: MosaicType::U8,
            tile_size: (8, 6),
            nodata: None,
            tiles,
        };
        let e = vrt(&mosaic(vec![tile("a.tif", 0), tile("b.tif", 9)])).unwrap_err();
        assert!(e.to_string().contains("b.tif at column 9, row 0 reaches outside"), "{e}");
        let e = vrt(&mosaic(vec![tile("../a.tif", 0)])).unwrap_err();
        assert!(e.to_string().contains("not a path below"), "{e}");
        let ok = String::from_utf8(vrt(&mosaic(vec![tile("a&b.tif", 8)])).unwrap()).unwrap();
        assert!(ok.contains("a&amp;b.tif") && ok.matches("<SimpleSource>").count() == 3, "{ok}");
    }

    #[test]
    fn a_vrt_from_an_object_store_reads_with_the_tiles_its_window_needs() {
        let (dir, path) = two_tile_mosaic(Some(-9999.0));
        let vrt = std::fs::read(&path).unwrap();
        let e = RasterSource::open_bytes("s3://b/mosaic.vrt", vrt.clone()).unwrap_err();
        assert!(e.to_string().starts_with("s3://b/mosaic.vrt: is a VRT mosaic"), "{e}");
        // The west tile only (columns 0–7 are E 500000–500004), both, and none.
        let west = MapBox { min_e: 500_000.5, min_n: 5_000_098.0, max_e: 500_003.5, max_n: 5_000_099.0 };
        let across = MapBox { min_e: 500_003.0, min_n: 5_000_099.0, max_e: 500_005.0, max_n: 5_000_101.0 };
        let outside = MapBox { min_e: 400_000.0, min_n: 5_000_099.0, max_e: 400_005.0, max_n: 5_000_101.0 };
        assert_eq!(mosaic_tiles("m", &vrt, &west).unwrap(), vec!["tiles/0_0.tif".to_owned()]);
        assert_eq!(
            mosaic_tiles("m", &vrt, &across).unwrap(),
            vec!["tiles/0_0.tif".to_owned(), "tiles/1_0.tif".to_owned()]
        );
        assert!(mosaic_tiles("m", &vrt, &outside).unwrap().is_empty());
        assert!(mosaic_tiles("m", b"II*\0", &west).unwrap().is_empty(), "a GeoTIFF needs no tiles");
        let fetch = |t: &str| (t.to_owned(), std::fs::read(dir.path().join(t)).unwrap());
        let tiles = mosaic_tiles("m", &vrt, &across).unwrap().iter().map(|t| fetch(t)).collect();
        let source = RasterSource::open_mosaic_bytes("s3://b/mosaic.vrt", vrt.clone(), tiles).unwrap();
        let w = source.window(&across).unwrap().unwrap();
        let RasterData::F32(bands) = &w.data else { panic!("float raster expected") };
        assert_eq!(&bands[0][8..12], &[6.0, 7.0, 1000.0, 1001.0]);
        // Only the west tile held: a window over the east one fails naming the step.
        let source = RasterSource::open_mosaic_bytes("s3://b/mosaic.vrt", vrt, vec![fetch("tiles/0_0.tif")]).unwrap();
        assert!(source.window(&west).unwrap().is_some());
        let e = source.window(&across).unwrap_err();
        assert!(e.to_string().starts_with("s3://b/mosaic.vrt: GDAL could not read band 1"), "{e}");
    }
}
