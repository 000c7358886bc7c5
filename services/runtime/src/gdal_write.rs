//! Encode geodata to bytes through GDAL: GeoPackages of point layers and GeoTIFF rasters. Everything is
//! built in GDAL's in-memory file system (`/vsimem/`, one unique name per call) and returned as bytes, so
//! callers store it with [`crate::write_url`] anywhere. Coordinates are in traditional GIS axis order
//! (longitude, latitude for geographic CRSs), as everywhere in this crate.

use std::sync::atomic::{AtomicU64, Ordering};

use gdal::errors::GdalError;
use gdal::raster::{Buffer, GdalType};
use gdal::spatial_ref::{AxisMappingStrategy, SpatialRef};
use gdal::vector::{Feature, FieldDefn, Geometry, LayerAccess, LayerOptions, OGRFieldType, OGRwkbGeometryType};
use gdal::{Dataset, DriverManager};

use crate::gdal_messages::route_gdal_messages;
use crate::vrt::{Rect, SourceProperties, VrtBand, VrtMosaic, VrtSource};

/// Why encoding failed: the GDAL step, or the item and field that were bad.
#[derive(Debug, thiserror::Error)]
pub enum GdalWriteError {
    /// A GDAL call failed.
    #[error("GDAL could not {step}: {source}")]
    Gdal {
        /// What was being done.
        step: String,
        /// GDAL's error.
        #[source]
        source: GdalError,
    },
    /// The input is inconsistent.
    #[error("{item}: {field} {problem}")]
    Invalid {
        /// The layer, feature or raster.
        item: String,
        /// The field.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
}

/// Type of an attribute column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldType {
    /// 64-bit integer.
    Integer,
    /// Double.
    Real,
    /// Text.
    Text,
}

/// One attribute value.
#[derive(Clone, Debug, PartialEq)]
pub enum FieldValue {
    /// An integer.
    Integer(i64),
    /// A real.
    Real(f64),
    /// A text.
    Text(String),
}

/// A point feature: (x, y) in the layer CRS and one value per field.
#[derive(Clone, Debug, PartialEq)]
pub struct PointFeature {
    /// Easting or longitude.
    pub x: f64,
    /// Northing or latitude.
    pub y: f64,
    /// Values in the order of [`PointLayer::fields`].
    pub values: Vec<FieldValue>,
}

/// A point layer.
#[derive(Clone, Debug, PartialEq)]
pub struct PointLayer {
    /// Layer name.
    pub name: String,
    /// Attribute columns: name and type.
    pub fields: Vec<(String, FieldType)>,
    /// The features.
    pub features: Vec<PointFeature>,
}

/// A line feature: its vertices (x, y) in the layer CRS and one value per field.
#[derive(Clone, Debug, PartialEq)]
pub struct LineFeature {
    /// Vertices, at least two.
    pub points: Vec<[f64; 2]>,
    /// Values in the order of [`LineLayer::fields`].
    pub values: Vec<FieldValue>,
}

/// A line-string layer.
#[derive(Clone, Debug, PartialEq)]
pub struct LineLayer {
    /// Layer name.
    pub name: String,
    /// Attribute columns: name and type.
    pub fields: Vec<(String, FieldType)>,
    /// The features.
    pub features: Vec<LineFeature>,
}

/// What a feature of either layer kind gives the writer.
trait Shaped {
    const TYPE: OGRwkbGeometryType::Type;
    fn values(&self) -> &[FieldValue];
    /// The coordinates' problem, if one is not finite or the shape is degenerate.
    fn problem(&self) -> Option<String>;
    fn geometry(&self) -> Result<Geometry, GdalError>;
}

impl Shaped for PointFeature {
    const TYPE: OGRwkbGeometryType::Type = OGRwkbGeometryType::wkbPoint;
    fn values(&self) -> &[FieldValue] {
        &self.values
    }
    fn problem(&self) -> Option<String> {
        (!(self.x.is_finite() && self.y.is_finite())).then(|| format!("({}, {}) is not finite", self.x, self.y))
    }
    fn geometry(&self) -> Result<Geometry, GdalError> {
        let mut point = Geometry::empty(Self::TYPE)?;
        point.add_point_2d((self.x, self.y));
        Ok(point)
    }
}

impl Shaped for LineFeature {
    const TYPE: OGRwkbGeometryType::Type = OGRwkbGeometryType::wkbLineString;
    fn values(&self) -> &[FieldValue] {
        &self.values
    }
    fn problem(&self) -> Option<String> {
        if self.points.len() < 2 {
            return Some(format!("has {} vertices (a line needs two)", self.points.len()));
        }
        let bad = self.points.iter().position(|p| !(p[0].is_finite() && p[1].is_finite()))?;
        Some(format!("vertex {bad} {:?} is not finite", self.points[bad]))
    }
    fn geometry(&self) -> Result<Geometry, GdalError> {
        let mut line = Geometry::empty(Self::TYPE)?;
        for p in &self.points {
            line.add_point_2d((p[0], p[1]));
        }
        Ok(line)
    }
}

/// Pixels of a raster, band-sequential, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub enum RasterData {
    /// 8-bit bands (e.g. RGB).
    U8(Vec<Vec<u8>>),
    /// 16-bit bands (e.g. the RGB + NIR of a large-format aerial camera).
    U16(Vec<Vec<u16>>),
    /// 32-bit float bands (e.g. heights).
    F32(Vec<Vec<f32>>),
}

/// A georeferenced raster.
#[derive(Clone, Debug, PartialEq)]
pub struct Raster {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// GDAL geotransform: [x0, pixel width, row rotation, y0, column rotation, −pixel height] of the top-left corner.
    pub geotransform: [f64; 6],
    /// EPSG code of the CRS.
    pub epsg: u32,
    /// The bands.
    pub data: RasterData,
    /// No-data value, if any.
    pub nodata: Option<f64>,
}

/// Map a GDAL error to one naming the step that failed.
fn failed(step: impl Into<String>) -> impl FnOnce(GdalError) -> GdalWriteError {
    let step = step.into();
    move |source| GdalWriteError::Gdal { step, source }
}

/// A fresh `/vsimem/` path.
pub(crate) fn vsimem_path(extension: &str) -> String {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    format!("/vsimem/plumbline-{}-{n}.{extension}", std::process::id())
}

pub(crate) fn srs(epsg: u32) -> Result<SpatialRef, GdalWriteError> {
    let mut srs = SpatialRef::from_epsg(epsg).map_err(failed(format!("build the CRS EPSG:{epsg}")))?;
    srs.set_axis_mapping_strategy(AxisMappingStrategy::TraditionalGisOrder);
    Ok(srs)
}

/// Read a closed `/vsimem/` file's bytes and remove it.
fn take(path: &str) -> Result<Vec<u8>, GdalWriteError> {
    gdal::vsi::get_vsi_mem_file_bytes_owned(path).map_err(failed(format!("read back {path}")))
}

/// A GeoPackage with the given point layers, all in CRS `epsg`.
pub fn geopackage(layers: &[PointLayer], epsg: u32) -> Result<Vec<u8>, GdalWriteError> {
    geopackage_in(layers, Some(epsg))
}

/// A GeoPackage with the given point layers in CRS `epsg`, or with no CRS recorded (GeoPackage's
/// "undefined Cartesian SRS") when `None`.
pub fn geopackage_in(layers: &[PointLayer], epsg: Option<u32>) -> Result<Vec<u8>, GdalWriteError> {
    geopackage_with_lines(layers, &[], epsg)
}

/// A GeoPackage with the given point layers, then the line layers, in CRS `epsg` (or none recorded).
pub fn geopackage_with_lines(
    points: &[PointLayer],
    lines: &[LineLayer],
    epsg: Option<u32>,
) -> Result<Vec<u8>, GdalWriteError> {
    route_gdal_messages();
    for l in points {
        check_layer(&l.name, &l.fields, &l.features)?;
    }
    for l in lines {
        check_layer(&l.name, &l.fields, &l.features)?;
    }
    let srs = epsg.map(srs).transpose()?;
    let path = vsimem_path("gpkg");
    let driver = DriverManager::get_driver_by_name("GPKG").map_err(failed("find the GPKG driver"))?;
    let mut ds = driver.create_vector_only(&path).map_err(failed("create a GeoPackage"))?;
    let result =
        points.iter().try_for_each(|l| write_layer(&mut ds, &l.name, &l.fields, &l.features, srs.as_ref())).and_then(
            |()| lines.iter().try_for_each(|l| write_layer(&mut ds, &l.name, &l.fields, &l.features, srs.as_ref())),
        );
    let closed = ds.close().map_err(failed("close the GeoPackage"));
    let bytes = take(&path);
    result?;
    closed?;
    bytes
}

fn check_layer<F: Shaped>(name: &str, fields: &[(String, FieldType)], features: &[F]) -> Result<(), GdalWriteError> {
    for (i, f) in features.iter().enumerate() {
        let item = || format!("layer {name} feature {i}");
        if f.values().len() != fields.len() {
            let problem = format!("has {} values for {} fields", f.values().len(), fields.len());
            return Err(GdalWriteError::Invalid { item: item(), field: "values", problem });
        }
        if let Some(problem) = f.problem() {
            return Err(GdalWriteError::Invalid { item: item(), field: "geometry", problem });
        }
    }
    Ok(())
}

fn write_layer<F: Shaped>(
    ds: &mut Dataset,
    name: &str,
    fields: &[(String, FieldType)],
    features: &[F],
    srs: Option<&SpatialRef>,
) -> Result<(), GdalWriteError> {
    let options = LayerOptions { name, srs, ty: F::TYPE, options: None };
    let mut txn = ds.start_transaction().map_err(failed("start a transaction"))?;
    let lyr = txn.create_layer(options).map_err(failed(format!("create layer {name}")))?;
    add_fields(&lyr, name, fields)?;
    for (i, f) in features.iter().enumerate() {
        let written = f.geometry().and_then(|g| write_values(&lyr, g, f.values()));
        written.map_err(failed(format!("write feature {i} of layer {name}")))?;
    }
    txn.commit().map_err(failed(format!("commit layer {name}")))?;
    Ok(())
}

/// Define the attribute columns of a new layer.
pub(crate) fn add_fields<L: LayerAccess>(
    lyr: &L,
    name: &str,
    fields: &[(String, FieldType)],
) -> Result<(), GdalWriteError> {
    for (field, ty) in fields {
        let ogr = match ty {
            FieldType::Integer => OGRFieldType::OFTInteger64,
            FieldType::Real => OGRFieldType::OFTReal,
            FieldType::Text => OGRFieldType::OFTString,
        };
        let defn = FieldDefn::new(field, ogr).map_err(failed(format!("define field {name}.{field}")))?;
        defn.add_to_layer(lyr).map_err(failed(format!("add field {name}.{field}")))?;
    }
    Ok(())
}

/// Write one feature: its geometry and its values in the layer's field order.
pub(crate) fn write_values<L: LayerAccess>(
    lyr: &L,
    geometry: Geometry,
    values: &[FieldValue],
) -> Result<(), GdalError> {
    let mut feature = Feature::new(lyr.defn())?;
    feature.set_geometry(geometry)?;
    for (k, value) in values.iter().enumerate() {
        match value {
            FieldValue::Integer(v) => feature.set_field_integer64(k, *v)?,
            FieldValue::Real(v) => feature.set_field_double(k, *v)?,
            FieldValue::Text(v) => feature.set_field_string(k, v)?,
        }
    }
    feature.create(lyr)
}

/// A GeoTIFF (deflate-compressed, tiled) of the raster.
pub fn geotiff(raster: &Raster) -> Result<Vec<u8>, GdalWriteError> {
    route_gdal_messages();
    match &raster.data {
        RasterData::U8(bands) => geotiff_typed(raster, bands),
        RasterData::U16(bands) => geotiff_typed(raster, bands),
        RasterData::F32(bands) => geotiff_typed(raster, bands),
    }
}

fn geotiff_typed<T: GdalType + Copy>(raster: &Raster, bands: &[Vec<T>]) -> Result<Vec<u8>, GdalWriteError> {
    check_bands(&format!("{}×{} raster", raster.width, raster.height), raster.width * raster.height, bands)?;
    let srs = srs(raster.epsg)?;
    let path = vsimem_path("tif");
    let driver = DriverManager::get_driver_by_name("GTiff").map_err(failed("find the GTiff driver"))?;
    let options = gdal::raster::RasterCreationOptions::from_iter(["COMPRESS=DEFLATE", "TILED=YES"]);
    let mut ds = driver
        .create_with_band_type_with_options::<T, _>(&path, raster.width, raster.height, bands.len(), &options)
        .map_err(failed("create a GeoTIFF"))?;
    let result = fill(&mut ds, raster, bands, &srs);
    let closed = ds.close().map_err(failed("close the GeoTIFF"));
    let bytes = take(&path);
    result?;
    closed?;
    bytes
}

/// A cloud-optimised GeoTIFF of the raster (GDAL's COG driver): deflate, 512 × 512 tiles, averaged
/// overviews down to one tile, the overviews and tiles ordered for range reads. What agencies serve their
/// orthophotos as; readers open it like any GeoTIFF.
pub fn cloud_optimized_geotiff(raster: &Raster) -> Result<Vec<u8>, GdalWriteError> {
    route_gdal_messages();
    match &raster.data {
        RasterData::U8(bands) => cog_typed(raster, bands),
        RasterData::U16(bands) => cog_typed(raster, bands),
        RasterData::F32(bands) => cog_typed(raster, bands),
    }
}

fn cog_typed<T: GdalType + Copy>(raster: &Raster, bands: &[Vec<T>]) -> Result<Vec<u8>, GdalWriteError> {
    check_bands(&format!("{}×{} raster", raster.width, raster.height), raster.width * raster.height, bands)?;
    let srs = srs(raster.epsg)?;
    let memory = DriverManager::get_driver_by_name("MEM").map_err(failed("find the MEM driver"))?;
    let mut source = memory
        .create_with_band_type::<T, _>("", raster.width, raster.height, bands.len())
        .map_err(failed("create an in-memory raster"))?;
    fill(&mut source, raster, bands, &srs)?;
    let path = vsimem_path("tif");
    let cog = DriverManager::get_driver_by_name("COG").map_err(failed("find the COG driver"))?;
    let options = gdal::raster::RasterCreationOptions::from_iter([
        "COMPRESS=DEFLATE",
        "BLOCKSIZE=512",
        "OVERVIEWS=AUTO",
        "RESAMPLING=AVERAGE",
        "BIGTIFF=IF_SAFER",
        "NUM_THREADS=ALL_CPUS",
    ]);
    let copy = source.create_copy(&cog, &path, &options).map_err(failed("write a cloud-optimised GeoTIFF"));
    let closed = copy.and_then(|ds| ds.close().map_err(failed("close the cloud-optimised GeoTIFF")));
    let bytes = take(&path);
    closed?;
    bytes
}

/// An image TIFF without georeferencing (aerial frames, which their orientation places): tiled 512 × 512,
/// deflate with horizontal differencing, BigTIFF when it may pass 4 GB. `data` holds `width · height` pixels
/// per band.
pub fn image_tiff(width: usize, height: usize, data: &RasterData) -> Result<Vec<u8>, GdalWriteError> {
    route_gdal_messages();
    match data {
        RasterData::U8(bands) => image_tiff_typed(width, height, bands),
        RasterData::U16(bands) => image_tiff_typed(width, height, bands),
        RasterData::F32(bands) => image_tiff_typed(width, height, bands),
    }
}

/// Tile edge of the image TIFFs, pixels.
const TILE: usize = 512;

fn image_tiff_typed<T: GdalType + Copy>(
    width: usize,
    height: usize,
    bands: &[Vec<T>],
) -> Result<Vec<u8>, GdalWriteError> {
    check_bands(&format!("{width}×{height} image"), width * height, bands)?;
    let path = vsimem_path("tif");
    let driver = DriverManager::get_driver_by_name("GTiff").map_err(failed("find the GTiff driver"))?;
    let options = gdal::raster::RasterCreationOptions::from_iter([
        "TILED=YES",
        "BLOCKXSIZE=512", // TILE
        "BLOCKYSIZE=512",
        "COMPRESS=DEFLATE",
        "PREDICTOR=2",
        "BIGTIFF=IF_SAFER",
        "NUM_THREADS=ALL_CPUS",
    ]);
    let ds = driver
        .create_with_band_type_with_options::<T, _>(&path, width, height, bands.len(), &options)
        .map_err(failed("create a TIFF"))?;
    // One row of tiles at a time, every band: a pixel-interleaved tile is compressed once, when complete,
    // instead of being written with one band and read back for each of the others.
    let result = (0..height).step_by(TILE).try_for_each(|top| {
        let rows = TILE.min(height - top);
        bands.iter().enumerate().try_for_each(|(b, data)| {
            let mut band = ds.rasterband(b + 1).map_err(failed(format!("open band {}", b + 1)))?;
            let strip = data[top * width..(top + rows) * width].to_vec();
            let mut buffer = Buffer::new((width, rows), strip);
            band.write((0, top as isize), (width, rows), &mut buffer).map_err(failed(format!("write band {}", b + 1)))
        })
    });
    let closed = ds.close().map_err(failed("close the TIFF"));
    let bytes = take(&path);
    result?;
    closed?;
    bytes
}

/// At least one band, each of `pixels` values; the error names `item`.
fn check_bands<T>(item: &str, pixels: usize, bands: &[Vec<T>]) -> Result<(), GdalWriteError> {
    let invalid = |problem: String| GdalWriteError::Invalid { item: item.to_owned(), field: "data", problem };
    if bands.is_empty() {
        return Err(invalid("has no band".into()));
    }
    match bands.iter().enumerate().find(|(_, b)| b.len() != pixels) {
        Some((b, band)) => Err(invalid(format!("band {} holds {} pixels", b + 1, band.len()))),
        None => Ok(()),
    }
}

fn fill<T: GdalType + Copy>(
    ds: &mut Dataset,
    raster: &Raster,
    bands: &[Vec<T>],
    srs: &SpatialRef,
) -> Result<(), GdalWriteError> {
    ds.set_geo_transform(&raster.geotransform).map_err(failed("set the geotransform"))?;
    ds.set_spatial_ref(srs).map_err(failed("set the CRS"))?;
    for (b, data) in bands.iter().enumerate() {
        let mut band = ds.rasterband(b + 1).map_err(failed(format!("open band {}", b + 1)))?;
        if let Some(nodata) = raster.nodata {
            band.set_no_data_value(Some(nodata)).map_err(failed("set the no-data value"))?;
        }
        let mut buffer = Buffer::new((raster.width, raster.height), data.clone());
        band.write((0, 0), (raster.width, raster.height), &mut buffer)
            .map_err(failed(format!("write band {}", b + 1)))?;
    }
    Ok(())
}

/// Pixel type of a mosaic's bands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MosaicType {
    /// 8-bit (GDAL `Byte`).
    U8,
    /// 32-bit float (GDAL `Float32`).
    F32,
}

/// One tile of a mosaic: its file, relative to the VRT, and the mosaic pixel of its top-left corner.
#[derive(Clone, Debug, PartialEq)]
pub struct MosaicTile {
    /// Path relative to the VRT file (forward slashes).
    pub path: String,
    /// Column of the tile's top-left pixel in the mosaic.
    pub col: usize,
    /// Row of the tile's top-left pixel in the mosaic.
    pub row: usize,
}

/// A mosaic of equally sized, equally typed, pixel-aligned GeoTIFF tiles, described as a GDAL VRT.
#[derive(Clone, Debug, PartialEq)]
pub struct Mosaic {
    /// Width of the whole mosaic, pixels.
    pub width: usize,
    /// Height of the whole mosaic, pixels.
    pub height: usize,
    /// GDAL geotransform of the mosaic (north-up).
    pub geotransform: [f64; 6],
    /// EPSG code of the CRS.
    pub epsg: u32,
    /// Bands per tile.
    pub bands: usize,
    /// Pixel type.
    pub data_type: MosaicType,
    /// Size of every tile, pixels (width, height).
    pub tile_size: (usize, usize),
    /// No-data value (also what areas without a tile read as), if any.
    pub nodata: Option<f64>,
    /// The tiles.
    pub tiles: Vec<MosaicTile>,
}

/// The VRT XML of a mosaic (what `gdalbuildvrt` writes for such tiles): sources relative to the VRT, with
/// their size and block size declared so GDAL opens a tile only when a read touches it.
pub fn vrt(mosaic: &Mosaic) -> Result<Vec<u8>, GdalWriteError> {
    route_gdal_messages();
    check_mosaic(mosaic)?;
    let wkt = srs(mosaic.epsg)?.to_wkt().map_err(failed(format!("write EPSG:{} as WKT", mosaic.epsg)))?;
    let (ty, colours): (&str, &[&str]) = match mosaic.data_type {
        MosaicType::U8 => ("Byte", &["Red", "Green", "Blue"]),
        MosaicType::F32 => ("Float32", &["Gray"]),
    };
    let (tw, th) = mosaic.tile_size;
    let whole = |x: usize, y: usize| Rect { x: x as f64, y: y as f64, w: tw as f64, h: th as f64 };
    let properties = SourceProperties {
        width: tw,
        height: th,
        data_type: ty.to_owned(),
        block_width: tw.min(256),
        block_height: th.min(256),
    };
    let bands = (1..=mosaic.bands)
        .map(|b| VrtBand {
            data_type: ty.to_owned(),
            colour: Some(if mosaic.bands == colours.len() { colours[b - 1] } else { "Undefined" }.to_owned()),
            nodata: mosaic.nodata,
            sources: mosaic
                .tiles
                .iter()
                .map(|t| VrtSource {
                    complex: false,
                    path: t.path.clone(),
                    band: b,
                    properties: Some(properties.clone()),
                    src: Some(whole(0, 0)),
                    dst: whole(t.col, t.row),
                    nodata: None,
                })
                .collect(),
        })
        .collect();
    let vrt = VrtMosaic {
        width: mosaic.width,
        height: mosaic.height,
        srs: Some(wkt),
        axis_mapping: Some("1,2".to_owned()),
        geotransform: mosaic.geotransform,
        bands,
    };
    Ok(vrt.to_xml(|path| Some((path.to_owned(), true))))
}

fn check_mosaic(m: &Mosaic) -> Result<(), GdalWriteError> {
    let invalid = |field: &'static str, problem: String| GdalWriteError::Invalid {
        item: format!("{}×{} px mosaic", m.width, m.height),
        field,
        problem,
    };
    if m.bands == 0 || m.tile_size.0 == 0 || m.tile_size.1 == 0 {
        return Err(invalid("bands/tile_size", format!("{} bands of {:?} px hold no pixels", m.bands, m.tile_size)));
    }
    for t in &m.tiles {
        if t.col + m.tile_size.0 > m.width || t.row + m.tile_size.1 > m.height {
            return Err(invalid("tiles", format!("{} at column {}, row {} reaches outside", t.path, t.col, t.row)));
        }
        if crate::vrt::relative_below(&t.path).is_err() {
            return Err(invalid("tiles", format!("`{}` is not a path below the VRT's directory", t.path)));
        }
    }
    Ok(())
}
