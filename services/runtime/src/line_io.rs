//! Line layers through GDAL: read one line-string layer of a GeoPackage (the road lines of
//! `observations.gpkg`) and encode a line layer as GeoJSON (RFC 7946: WGS 84 longitude/latitude, GDAL
//! reprojecting on write). Everything happens in GDAL's in-memory file system.

use gdal::vector::{FieldValue as GdalValue, Geometry, LayerAccess, LayerOptions, OGRwkbGeometryType};
use gdal::{Dataset, DatasetOptions, DriverManager, GdalOpenFlags};

use crate::gdal_messages::route_gdal_messages;
use crate::gdal_write::{FieldType, FieldValue, GdalWriteError, LineFeature, LineLayer, vsimem_path};

/// Why a line layer could not be read: the file, the layer or the feature, and what was wrong.
#[derive(Debug, thiserror::Error)]
pub enum LineReadError {
    /// GDAL could not open the file as a GeoPackage.
    #[error("{file}: not a readable GeoPackage: {message}")]
    Open {
        /// The file as named.
        file: String,
        /// GDAL's message.
        message: String,
    },
    /// The layer is not in the file.
    #[error("{file}: no layer `{layer}` (layers: {present})")]
    NoLayer {
        /// The file.
        file: String,
        /// The layer asked for.
        layer: String,
        /// The layers it has.
        present: String,
    },
    /// A feature is not a line string with finite coordinates.
    #[error("{file}: layer {layer} feature {feature}: {problem}")]
    Feature {
        /// The file.
        file: String,
        /// The layer.
        layer: String,
        /// The feature's id.
        feature: u64,
        /// What is wrong.
        problem: String,
    },
}

/// A line layer read back and the EPSG code of its CRS (`None` when it has none or one without a code).
#[derive(Clone, Debug, PartialEq)]
pub struct ReadLines {
    /// The layer.
    pub layer: LineLayer,
    /// Its CRS.
    pub epsg: Option<u32>,
}

/// Read line-string layer `layer` of the GeoPackage `bytes` (named `file` in errors). Integer, real and
/// text fields are kept; other field types are read as text. A feature without a line-string geometry
/// or with a non-finite vertex is an error naming it.
pub fn read_line_layer(file: &str, bytes: Vec<u8>, layer: &str) -> Result<ReadLines, LineReadError> {
    route_gdal_messages();
    let path = vsimem_path("gpkg");
    hold(file, &path, bytes)?;
    let result = read_from(file, &path, layer);
    let _ = gdal::vsi::unlink_mem_file(&path);
    result
}

fn read_from(file: &str, path: &str, name: &str) -> Result<ReadLines, LineReadError> {
    let ds = open(file, path)?;
    let mut lyr = layer_of(file, &ds, name)?;
    let epsg = lyr.spatial_ref().and_then(|s| s.auth_code().ok()).and_then(|c| u32::try_from(c).ok());
    let fields: Vec<(String, FieldType)> = lyr
        .defn()
        .fields()
        .map(|f| {
            let ty = match f.field_type() {
                gdal::vector::OGRFieldType::OFTInteger | gdal::vector::OGRFieldType::OFTInteger64 => FieldType::Integer,
                gdal::vector::OGRFieldType::OFTReal => FieldType::Real,
                _ => FieldType::Text,
            };
            (f.name(), ty)
        })
        .collect();
    let mut features = Vec::new();
    for f in lyr.features() {
        let id = f.fid().unwrap_or(0);
        let problem = |problem: String| LineReadError::Feature {
            file: file.to_owned(),
            layer: name.to_owned(),
            feature: id,
            problem,
        };
        let g = f.geometry().ok_or_else(|| problem("has no geometry".into()))?;
        if g.geometry_type() != OGRwkbGeometryType::wkbLineString {
            return Err(problem(format!("is a {} (a line string is needed)", g.geometry_name())));
        }
        let points: Vec<[f64; 2]> = (0..g.point_count())
            .map(|k| {
                let (x, y, _) = g.get_point(i32::try_from(k).unwrap_or(i32::MAX));
                [x, y]
            })
            .collect();
        if let Some(k) = points.iter().position(|p| !(p[0].is_finite() && p[1].is_finite())) {
            return Err(problem(format!("vertex {k} is not finite")));
        }
        let values = fields
            .iter()
            .enumerate()
            .map(|(k, (_, ty))| match (ty, f.field(k).ok().flatten()) {
                (_, None) => match ty {
                    FieldType::Integer => FieldValue::Integer(0),
                    FieldType::Real => FieldValue::Real(f64::NAN),
                    FieldType::Text => FieldValue::Text(String::new()),
                },
                (FieldType::Integer, Some(v)) => FieldValue::Integer(v.into_int64().unwrap_or(0)),
                (FieldType::Real, Some(v)) => FieldValue::Real(v.into_real().unwrap_or(f64::NAN)),
                (FieldType::Text, Some(v)) => FieldValue::Text(text_of(v)),
            })
            .collect();
        features.push(LineFeature { points, values });
    }
    Ok(ReadLines { layer: LineLayer { name: name.to_owned(), fields, features }, epsg })
}

/// A field's text: strings as they are, anything else (dates, lists) as GDAL's value prints.
fn text_of(v: GdalValue) -> String {
    match v {
        GdalValue::StringValue(s) => s,
        other => format!("{other:?}"),
    }
}

/// The (x, y) of every point feature of layer `layer` of the GeoPackage `bytes` (features without a point
/// geometry are left out).
pub fn read_points(file: &str, bytes: Vec<u8>, layer: &str) -> Result<Vec<[f64; 2]>, LineReadError> {
    route_gdal_messages();
    let path = vsimem_path("gpkg");
    hold(file, &path, bytes)?;
    let result = open(file, &path).and_then(|ds| {
        let mut lyr = layer_of(file, &ds, layer)?;
        let points = lyr
            .features()
            .filter_map(|f| {
                let g = f.geometry()?;
                (g.geometry_type() == OGRwkbGeometryType::wkbPoint).then(|| {
                    let (x, y, _) = g.get_point(0);
                    [x, y]
                })
            })
            .collect();
        Ok(points)
    });
    let _ = gdal::vsi::unlink_mem_file(&path);
    result
}

/// Put `bytes` into GDAL's memory file system at `path` once they look like a GeoPackage (SQLite's header,
/// at least one page: GDAL is never handed an empty or foreign file).
fn hold(file: &str, path: &str, bytes: Vec<u8>) -> Result<(), LineReadError> {
    let open_error = |message: String| LineReadError::Open { file: file.to_owned(), message };
    crate::cadastre::sniff(&bytes[..bytes.len().min(100)], bytes.len() as u64).map_err(open_error)?;
    gdal::vsi::create_mem_file(path, bytes).map_err(|e| open_error(e.to_string()))
}

fn open(file: &str, path: &str) -> Result<Dataset, LineReadError> {
    let options = DatasetOptions {
        open_flags: GdalOpenFlags::GDAL_OF_VECTOR | GdalOpenFlags::GDAL_OF_READONLY,
        allowed_drivers: Some(&["GPKG"]),
        ..DatasetOptions::default()
    };
    Dataset::open_ex(path, options).map_err(|e| LineReadError::Open { file: file.to_owned(), message: e.to_string() })
}

fn layer_of<'a>(file: &str, ds: &'a Dataset, name: &str) -> Result<gdal::vector::Layer<'a>, LineReadError> {
    ds.layer_by_name(name).map_err(|_| {
        let present: Vec<String> = ds.layers().map(|l| l.name()).collect();
        LineReadError::NoLayer { file: file.to_owned(), layer: name.to_owned(), present: present.join(", ") }
    })
}

/// The layer as a GeoJSON FeatureCollection after RFC 7946 (longitude/latitude on WGS 84; GDAL reprojects
/// from CRS `epsg` as it writes).
pub fn geojson_lines(layer: &LineLayer, epsg: u32) -> Result<Vec<u8>, GdalWriteError> {
    route_gdal_messages();
    let failed = |step: &str| {
        let step = step.to_owned();
        move |source| GdalWriteError::Gdal { step, source }
    };
    let srs = crate::gdal_write::srs(epsg)?;
    let path = vsimem_path("geojson");
    let driver = DriverManager::get_driver_by_name("GeoJSON").map_err(failed("find the GeoJSON driver"))?;
    let mut ds = driver.create_vector_only(&path).map_err(failed("create a GeoJSON file"))?;
    let result = (|| {
        let options = LayerOptions {
            name: &layer.name,
            srs: Some(&srs),
            ty: OGRwkbGeometryType::wkbLineString,
            options: Some(&["RFC7946=YES", "COORDINATE_PRECISION=8"]),
        };
        let lyr = ds.create_layer(options).map_err(failed("create the GeoJSON layer"))?;
        crate::gdal_write::add_fields(&lyr, &layer.name, &layer.fields)?;
        for (i, f) in layer.features.iter().enumerate() {
            let mut line = Geometry::empty(OGRwkbGeometryType::wkbLineString).map_err(failed("build a line"))?;
            for p in &f.points {
                line.add_point_2d((p[0], p[1]));
            }
            crate::gdal_write::write_values(&lyr, line, &f.values)
                .map_err(failed(&format!("write feature {i} of layer {}", layer.name)))?;
        }
        Ok(())
    })();
    let closed = ds.close().map_err(failed("close the GeoJSON file"));
    let bytes = gdal::vsi::get_vsi_mem_file_bytes_owned(&path).map_err(failed("read back the GeoJSON"));
    result?;
    closed?;
    bytes
}
