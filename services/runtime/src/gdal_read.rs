//! Read georeferenced rasters (orthophotos, terrain models) through GDAL, a window at a time.
//!
//! A [`RasterSource`] opens a GeoTIFF (or anything GDAL reads) once — from a local path directly, or from
//! bytes fetched from an object store through GDAL's in-memory file system — and serves windows given as
//! mapping-coordinate boxes, so a city orthophoto is never decoded whole. Handles are not `Send`: open one
//! source per thread.
//!
//! Rasters come from agencies, so GDAL is confined: a file opens only with the drivers of
//! [`RASTER_DRIVERS`] (no VRT, no network or archive formats that name other files), never lists its
//! directory for side-car files, and an XML file is never handed to GDAL as it is. A VRT mosaic is parsed
//! and rewritten by [`crate::vrt`] to the tiles beside it that a window needs, each checked to be a raster
//! file before GDAL opens it.

use std::collections::HashMap;
use std::io::Read as _;
use std::path::{Path, PathBuf};

use gdal::errors::GdalError;
use gdal::raster::{GdalDataType, GdalType};
use gdal::{Dataset, DatasetOptions, GdalOpenFlags};

use crate::gdal_messages::route_gdal_messages;
use crate::gdal_write::{Raster, RasterData};
pub use crate::raster_common::{GdalReadError, MapBox};
use crate::store::GdalRemote;
use crate::vrt::{VrtMosaic, is_xml};

/// The GDAL drivers an agency's raster may open with: formats whose files hold their own pixels.
pub const RASTER_DRIVERS: [&str; 4] = ["GTiff", "JPEG", "PNG", "JP2OpenJPEG"];

/// Open `path` with only `drivers`, read-only, after setting the process-wide options that keep GDAL from
/// probing a file's directory.
fn open_confined(path: &Path, drivers: &[&str]) -> Result<Dataset, GdalError> {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // Side-car files (.ovr, .aux.xml, .msk) are not looked for: a directory listing per open is slow on
        // object stores and would read files nobody named.
        if let Err(e) = gdal::config::set_config_option("GDAL_DISABLE_READDIR_ON_OPEN", "EMPTY_DIR") {
            tracing::warn!(error = %e, "GDAL option GDAL_DISABLE_READDIR_ON_OPEN not set");
        }
    });
    let options = DatasetOptions {
        open_flags: GdalOpenFlags::GDAL_OF_RASTER | GdalOpenFlags::GDAL_OF_READONLY,
        allowed_drivers: Some(drivers),
        ..DatasetOptions::default()
    };
    Dataset::open_ex(path, options)
}

/// The first bytes of a local file (fewer when it is shorter).
fn head_of(path: &Path) -> std::io::Result<Vec<u8>> {
    let mut head = Vec::with_capacity(MAGIC_BYTES as usize);
    std::fs::File::open(path)?.take(MAGIC_BYTES).read_to_end(&mut head)?;
    Ok(head)
}

/// Whether a file's first bytes are a raster file holding its own pixels: TIFF, BigTIFF, JPEG 2000, JPEG or PNG.
pub fn is_raster_file(head: &[u8]) -> bool {
    is_tiled_raster(head) || head.starts_with(&[0xFF, 0xD8, 0xFF]) || head.starts_with(b"\x89PNG\r\n\x1a\n")
}

/// The refusal of an XML file where a raster was expected.
fn xml_refused(name: &str) -> GdalReadError {
    let problem =
        "is XML (a VRT?), not a raster file; a VRT mosaic is read through its tiles (`RasterSource::open_path`, \
                   `open_mosaic_bytes`), other VRTs not at all"
            .to_owned();
    GdalReadError::Unusable { name: name.to_owned(), problem }
}

/// A tile of a VRT mosaic: a local file (resolved below the VRT's directory) or bytes fetched from a store.
#[derive(Clone, Debug)]
pub enum MosaicFile {
    /// A local file.
    Path(PathBuf),
    /// The file's bytes.
    Bytes(Vec<u8>),
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
        if head_of(path).is_ok_and(|head| is_xml(&head)) {
            return Err(xml_refused(&name));
        }
        let dataset = open_confined(path, &RASTER_DRIVERS).map_err(failed(&name, "open the raster"))?;
        Self::checked(name, dataset, Vec::new())
    }

    /// Open a raster from its bytes; `name` is used in errors.
    pub fn open_bytes(name: &str, bytes: Vec<u8>) -> Result<Self, GdalReadError> {
        if is_xml(&bytes) {
            return Err(xml_refused(name));
        }
        route_gdal_messages();
        let path = PathBuf::from(crate::gdal_write::vsimem_path("raster"));
        Self::hold(name, &path, bytes, "raster")?;
        match open_confined(&path, &RASTER_DRIVERS) {
            Ok(dataset) => Self::checked(name.to_owned(), dataset, vec![path]),
            Err(e) => {
                let _ = gdal::vsi::unlink_mem_file(&path);
                Err(failed(name, "open the raster")(e))
            }
        }
    }

    /// Put `bytes` in GDAL's in-memory file system at `path`; `what` names them in errors.
    fn hold(name: &str, path: &Path, bytes: Vec<u8>, what: &str) -> Result<(), GdalReadError> {
        // GDAL takes ownership of the buffer; an empty `Vec` has no allocation for it to free.
        if bytes.is_empty() {
            return Err(GdalReadError::Unusable {
                name: name.to_owned(),
                problem: format!("{what} is empty (0 bytes)"),
            });
        }
        gdal::vsi::create_mem_file(path, bytes).map_err(failed(name, format!("hold {what} in memory")))
    }

    /// Open a VRT mosaic with the tiles given (paths relative to the VRT, as [`VrtMosaic::files_over`] lists
    /// them): GDAL sees a VRT written afresh from `mosaic` holding only these tiles, each checked to be a
    /// raster file. Areas of tiles not given read as the band's no-data value (zero without one).
    pub fn open_mosaic(
        name: &str,
        mosaic: &VrtMosaic,
        files: Vec<(String, MosaicFile)>,
    ) -> Result<Self, GdalReadError> {
        route_gdal_messages();
        let dir = crate::gdal_write::vsimem_path("mosaic");
        let mut held = Vec::new();
        let mut located: HashMap<String, (String, bool)> = HashMap::new();
        let mut place = |relative: String, file: MosaicFile, held: &mut Vec<PathBuf>| -> Result<(), GdalReadError> {
            let not_raster = |detail: String| GdalReadError::Unusable {
                name: name.to_owned(),
                problem: format!("mosaic tile {relative} {detail}"),
            };
            match file {
                MosaicFile::Path(path) => {
                    let head = head_of(&path).map_err(|e| not_raster(format!("cannot be read: {e}")))?;
                    if !is_raster_file(&head) {
                        return Err(not_raster("is no TIFF, JPEG 2000, JPEG or PNG file".into()));
                    }
                    located.insert(relative, (path.display().to_string(), false));
                }
                MosaicFile::Bytes(bytes) => {
                    if !bytes.is_empty() && !is_raster_file(&bytes) {
                        return Err(not_raster("is no TIFF, JPEG 2000, JPEG or PNG file".into()));
                    }
                    let path = PathBuf::from(format!("{dir}/{relative}"));
                    Self::hold(name, &path, bytes, &relative)?;
                    held.push(path);
                    located.insert(relative.clone(), (relative, true));
                }
            }
            Ok(())
        };
        let placed = files.into_iter().try_for_each(|(relative, file)| place(relative, file, &mut held));
        let opened = placed.and_then(|()| {
            let xml = mosaic.to_xml(|p| located.get(p).cloned());
            let path = PathBuf::from(format!("{dir}/mosaic.vrt"));
            Self::hold(name, &path, xml, "the mosaic")?;
            held.push(path.clone());
            open_confined(&path, &["VRT"]).map_err(failed(name, "open the mosaic"))
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
        let opened = open_confined(Path::new(&remote.path), &RASTER_DRIVERS)
            .map_err(failed(name, "open the raster over the network"));
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
    /// Open a raster file on the local file system; a VRT mosaic with every tile ([`Self::open_local`]).
    pub fn open_path(path: &Path) -> Result<Self, GdalReadError> {
        Self::open_local(path, Tiles::All)
    }

    /// Open a raster file on the local file system. A VRT (XML) is parsed as a [`VrtMosaic`] and opened with
    /// `tiles` of it, resolved below the VRT's directory.
    pub fn open_local(path: &Path, tiles: Tiles<'_>) -> Result<Self, GdalReadError> {
        let name = path.display().to_string();
        if !head_of(path).is_ok_and(|head| is_xml(&head)) {
            return Self::georeferenced(PixelSource::open_path(path)?);
        }
        let bytes = read_bounded(path).map_err(|problem| GdalReadError::Unusable { name: name.clone(), problem })?;
        let mosaic = VrtMosaic::parse(&name, &bytes)?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let files = tiles.of(&mosaic).into_iter().map(|f| {
            let path = dir.join(&f);
            (f, MosaicFile::Path(path))
        });
        Self::georeferenced(PixelSource::open_mosaic(&name, &mosaic, files.collect())?)
    }

    /// Open a raster from its bytes (e.g. fetched from an object store); `name` is used in errors. XML (a VRT
    /// mosaic) is refused: parse it ([`VrtMosaic::parse`]), fetch the tiles the window needs
    /// ([`VrtMosaic::files_over`]) and open it with [`Self::open_mosaic_bytes`].
    pub fn open_bytes(name: &str, bytes: Vec<u8>) -> Result<Self, GdalReadError> {
        Self::georeferenced(PixelSource::open_bytes(name, bytes)?)
    }

    /// Open a VRT mosaic from its bytes and those of some of its tiles (paths relative to the VRT, as
    /// [`VrtMosaic::files_over`] lists them); areas of tiles not given read as no data.
    pub fn open_mosaic_bytes(name: &str, vrt: &[u8], tiles: Vec<(String, Vec<u8>)>) -> Result<Self, GdalReadError> {
        let mosaic = VrtMosaic::parse(name, vrt)?;
        let files = tiles.into_iter().map(|(f, bytes)| (f, MosaicFile::Bytes(bytes))).collect();
        Self::georeferenced(PixelSource::open_mosaic(name, &mosaic, files)?)
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

/// Which tiles of a local VRT mosaic to open.
#[derive(Clone, Copy, Debug)]
pub enum Tiles<'a> {
    /// Every tile.
    All,
    /// The tiles holding pixels of an area (mapping coordinates).
    Over(&'a MapBox),
    /// None: size, georeferencing and bands only.
    None,
}

impl Tiles<'_> {
    fn of(self, mosaic: &VrtMosaic) -> Vec<String> {
        match self {
            Self::All => {
                let mut seen = std::collections::HashSet::new();
                let sources = mosaic.bands.iter().flat_map(|b| &b.sources);
                sources.filter(|s| seen.insert(s.path.as_str())).map(|s| s.path.clone()).collect()
            }
            Self::Over(area) => mosaic.files_over(area),
            Self::None => Vec::new(),
        }
    }
}

/// A local VRT's bytes, refused above [`crate::vrt::MAX_VRT_BYTES`] before reading.
fn read_bounded(path: &Path) -> Result<Vec<u8>, String> {
    let len = std::fs::metadata(path).map_err(|e| format!("cannot be read: {e}"))?.len();
    if len > crate::vrt::MAX_VRT_BYTES as u64 {
        return Err(format!("is a VRT of {len} bytes; at most {} are read", crate::vrt::MAX_VRT_BYTES));
    }
    std::fs::read(path).map_err(|e| format!("cannot be read: {e}"))
}

fn failed(name: &str, step: impl Into<String>) -> impl FnOnce(GdalError) -> GdalReadError {
    let (name, step) = (name.to_owned(), step.into());
    move |source| GdalReadError::Gdal { name, step, source }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gdal_write::geotiff;
    use crate::vrt::VrtMosaic;

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
        assert_eq!(e.to_string(), "s3://b/empty.tif: raster is empty (0 bytes)");
        let (_dir, path) = two_tile_mosaic(None);
        let vrt = std::fs::read(path).unwrap();
        let e = RasterSource::open_mosaic_bytes("m.vrt", &vrt, vec![("tiles/0_0.tif".into(), vec![])]).unwrap_err();
        assert!(e.to_string().contains("tiles/0_0.tif is empty (0 bytes)"), "{e}");
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
        assert!(e.to_string().starts_with("s3://b/mosaic.vrt: is XML (a VRT?)"), "{e}");
        // The west tile only (columns 0–7 are E 500000–500004), both, and none.
        let west = MapBox { min_e: 500_000.5, min_n: 5_000_098.0, max_e: 500_003.5, max_n: 5_000_099.0 };
        let across = MapBox { min_e: 500_003.0, min_n: 5_000_099.0, max_e: 500_005.0, max_n: 5_000_101.0 };
        let outside = MapBox { min_e: 400_000.0, min_n: 5_000_099.0, max_e: 400_005.0, max_n: 5_000_101.0 };
        let mosaic = VrtMosaic::parse("m", &vrt).unwrap();
        assert_eq!(mosaic.files_over(&west), vec!["tiles/0_0.tif".to_owned()]);
        assert_eq!(mosaic.files_over(&across), vec!["tiles/0_0.tif".to_owned(), "tiles/1_0.tif".to_owned()]);
        assert!(mosaic.files_over(&outside).is_empty());
        let fetch = |t: &str| (t.to_owned(), std::fs::read(dir.path().join(t)).unwrap());
        let tiles = mosaic.files_over(&across).iter().map(|t| fetch(t)).collect();
        let source = RasterSource::open_mosaic_bytes("s3://b/mosaic.vrt", &vrt, tiles).unwrap();
        let w = source.window(&across).unwrap().unwrap();
        let RasterData::F32(bands) = &w.data else { panic!("float raster expected") };
        assert_eq!(&bands[0][8..12], &[6.0, 7.0, 1000.0, 1001.0]);
        // Only the west tile held: the east tile's pixels read as no data.
        let source = RasterSource::open_mosaic_bytes("s3://b/mosaic.vrt", &vrt, vec![fetch("tiles/0_0.tif")]).unwrap();
        let w = source.window(&across).unwrap().unwrap();
        let RasterData::F32(bands) = &w.data else { panic!("float raster expected") };
        assert_eq!(&bands[0][8..12], &[6.0, 7.0, -9999.0, -9999.0]);
    }

    /// A listener on a free loopback port that tells whether anything connected to it.
    fn listener() -> (std::net::TcpListener, u16) {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        listener.set_nonblocking(true).unwrap();
        let port = listener.local_addr().unwrap().port();
        (listener, port)
    }

    #[test]
    fn an_agency_vrt_reads_no_file_outside_its_directory_and_makes_no_request() {
        let (dir, path) = two_tile_mosaic(None);
        let secret = dir.path().parent().unwrap().join(format!("secret-{}.tif", std::process::id()));
        std::fs::write(&secret, geotiff(&ramp(8, 6)).unwrap()).unwrap();
        let vrt = std::fs::read_to_string(&path).unwrap();
        let secret_name = secret.file_name().unwrap().to_str().unwrap();
        // A source written with single quotes, escaping the directory.
        let escaping = vrt.replacen(
            "<SourceFilename relativeToVRT=\"1\">tiles/1_0.tif",
            &format!("<SourceFilename relativeToVRT='1'>tiles/../../{secret_name}"),
            1,
        );
        assert_ne!(escaping, vrt);
        std::fs::write(&path, &escaping).unwrap();
        let e = RasterSource::open_path(&path).unwrap_err().to_string();
        assert!(e.contains("band 1, source 2") && e.contains("`..` segment"), "{e}");
        // An absolute source, and a network one behind a leading comment: refused before GDAL, no request made.
        let (server, port) = listener();
        let remote = format!("<!-- tiles --><VRTDataset{}", vrt.split_once("<VRTDataset").unwrap().1).replacen(
            "<SourceFilename relativeToVRT=\"1\">tiles/1_0.tif",
            &format!("<SourceFilename relativeToVRT=\"0\">/vsicurl/http://127.0.0.1:{port}/t.tif"),
            1,
        );
        std::fs::write(&path, &remote).unwrap();
        let e = RasterSource::open_path(&path).unwrap_err().to_string();
        assert!(e.contains("not relative to the VRT"), "{e}");
        let e = RasterSource::open_mosaic_bytes("s3://b/m.vrt", remote.as_bytes(), vec![]).unwrap_err().to_string();
        assert!(e.contains("not relative to the VRT"), "{e}");
        let e = RasterSource::open_bytes("s3://b/t.tif", remote.clone().into_bytes()).unwrap_err().to_string();
        assert!(e.contains("is XML"), "{e}");
        let frame = dir.path().join("frame.tif");
        std::fs::write(&frame, &remote).unwrap();
        assert!(PixelSource::open_path(&frame).unwrap_err().to_string().contains("is XML"));
        assert!(server.accept().is_err_and(|e| e.kind() == std::io::ErrorKind::WouldBlock), "GDAL connected");
        // A tile that is itself XML is no raster file.
        std::fs::write(&path, &vrt).unwrap();
        std::fs::write(dir.path().join("tiles/1_0.tif"), &remote).unwrap();
        let e = RasterSource::open_path(&path).unwrap_err().to_string();
        assert!(e.contains("mosaic tile tiles/1_0.tif is no TIFF"), "{e}");
        let e = RasterSource::open_mosaic_bytes("m.vrt", vrt.as_bytes(), vec![("tiles/1_0.tif".into(), remote.into())]);
        assert!(e.unwrap_err().to_string().contains("mosaic tile tiles/1_0.tif is no TIFF"));
        std::fs::remove_file(secret).unwrap();
    }

    #[test]
    fn only_raster_drivers_open_agency_files() {
        // An ESRI ASCII grid: a raster GDAL reads with its AAIGrid driver, which is not on the list.
        let grid = b"ncols 2\nnrows 2\nxllcorner 500000\nyllcorner 5000000\ncellsize 1\n1 2\n3 4\n";
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("terrain.tif");
        std::fs::write(&path, grid).unwrap();
        assert_eq!(Dataset::open(&path).unwrap().raster_size(), (2, 2), "GDAL reads it unconfined");
        let e = RasterSource::open_path(&path).unwrap_err().to_string();
        assert!(e.contains("GDAL could not open the raster"), "{e}");
        let e = RasterSource::open_bytes("s3://b/terrain.tif", grid.to_vec()).unwrap_err().to_string();
        assert!(e.contains("GDAL could not open the raster"), "{e}");
    }
}
