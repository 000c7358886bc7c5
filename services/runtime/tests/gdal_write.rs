//! GeoPackage and GeoTIFF bytes from `gdal_write` open again through GDAL with their layers, fields,
//! features, CRS, geotransform and pixels, image TIFFs with their bands; bad input names the item and field.

#![allow(clippy::unwrap_used)]

use gdal::vector::LayerAccess;
use gdal::{Dataset, Metadata};
use plumbline_runtime::gdal_write::{
    FieldType, FieldValue, GdalWriteError, PointFeature, PointLayer, Raster, RasterData, cloud_optimized_geotiff,
    geopackage, geotiff, image_tiff,
};

fn reopen(bytes: &[u8], name: &str) -> (tempfile::TempDir, Dataset) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    let ds = Dataset::open(&path).unwrap();
    (dir, ds)
}

fn layer(name: &str, n: usize) -> PointLayer {
    PointLayer {
        name: name.into(),
        fields: vec![
            ("id".into(), FieldType::Integer),
            ("class".into(), FieldType::Text),
            ("d".into(), FieldType::Real),
        ],
        features: (0..n)
            .map(|i| PointFeature {
                x: 9.9 + i as f64 * 1e-4,
                y: 53.55 - i as f64 * 1e-4,
                values: vec![
                    FieldValue::Integer(100 + i as i64),
                    FieldValue::Text(format!("c{i}")),
                    FieldValue::Real(0.1 * i as f64),
                ],
            })
            .collect(),
    }
}

#[test]
fn geopackage_round_trips_layers_fields_points_and_crs() {
    let bytes = geopackage(&[layer("poles", 5), layer("trees", 3)], 4258).unwrap();
    let (_dir, ds) = reopen(&bytes, "c.gpkg");
    assert_eq!(ds.layer_count(), 2);
    let mut poles = ds.layer_by_name("poles").unwrap();
    assert_eq!(poles.feature_count(), 5);
    assert_eq!(poles.spatial_ref().unwrap().auth_code().unwrap(), 4258);
    let f = poles.features().nth(3).unwrap();
    assert_eq!(f.field_as_integer64(f.field_index("id").unwrap()).unwrap(), Some(103));
    assert_eq!(f.field_as_string(f.field_index("class").unwrap()).unwrap().as_deref(), Some("c3"));
    assert!((f.field_as_double(f.field_index("d").unwrap()).unwrap().unwrap() - 0.3).abs() < 1e-12);
    // Traditional GIS order: x is the longitude.
    let (x, y, _) = f.geometry().unwrap().get_point(0);
    assert!((x - 9.9003).abs() < 1e-12 && (y - 53.5497).abs() < 1e-12, "{x} {y}");
    assert_eq!(ds.layer_by_name("trees").unwrap().feature_count(), 3);
}

#[test]
fn geotiff_round_trips_geotransform_crs_and_pixels() {
    let (w, h) = (7, 5);
    let band = |k: u8| (0..w * h).map(|i| (i as u8).wrapping_mul(3).wrapping_add(k)).collect::<Vec<u8>>();
    let gt = [565_000.0, 0.25, 0.0, 5_933_000.0, 0.0, -0.25];
    let raster = Raster {
        width: w,
        height: h,
        geotransform: gt,
        epsg: 25832,
        data: RasterData::U8(vec![band(0), band(1), band(2)]),
        nodata: None,
    };
    let (_dir, ds) = reopen(&geotiff(&raster).unwrap(), "o.tif");
    assert_eq!(ds.geo_transform().unwrap(), gt);
    assert_eq!(ds.spatial_ref().unwrap().auth_code().unwrap(), 25832);
    assert_eq!(ds.raster_count(), 3);
    let read = ds.rasterband(2).unwrap().read_as::<u8>((0, 0), (w, h), (w, h), None).unwrap();
    assert_eq!(read.data(), band(1).as_slice());
    let heights = Raster { data: RasterData::F32(vec![vec![12.5; w * h]]), nodata: Some(-9999.0), ..raster };
    let (_dir2, dem) = reopen(&geotiff(&heights).unwrap(), "t.tif");
    let b = dem.rasterband(1).unwrap();
    assert_eq!(b.no_data_value(), Some(-9999.0));
    assert!(b.read_as::<f32>((0, 0), (w, h), (w, h), None).unwrap().data().iter().all(|&v| v == 12.5));
}

/// The orthophoto as agencies serve it: a COG whose pixels, georeferencing and nodata are the raster's, with
/// averaged overviews down to one 512 px tile, and which GDAL itself recognises as cloud-optimised.
#[test]
fn a_cloud_optimized_geotiff_has_the_pixels_and_overviews_down_to_one_tile() {
    let (w, h) = (1500, 1100);
    let band: Vec<u8> = (0..w * h).map(|i| ((i % w) / 6 + (i / w) / 5) as u8).collect();
    let gt = [565_000.0, 0.1, 0.0, 5_933_000.0, 0.0, -0.1];
    let data = RasterData::U8(vec![band.clone(), band.clone(), band.clone()]);
    let raster = Raster { width: w, height: h, geotransform: gt, epsg: 25832, data, nodata: Some(0.0) };
    let (_dir, ds) = reopen(&cloud_optimized_geotiff(&raster).unwrap(), "ortho.tif");
    assert_eq!((ds.geo_transform().unwrap(), ds.spatial_ref().unwrap().auth_code().unwrap()), (gt, 25832));
    let b = ds.rasterband(3).unwrap();
    assert_eq!(b.read_as::<u8>((0, 0), (w, h), (w, h), None).unwrap().data(), band.as_slice());
    assert_eq!((b.no_data_value(), b.block_size()), (Some(0.0), (512, 512)));
    // 1500 → 750 → 375: overviews halve until the smallest fits one tile.
    assert_eq!(b.overview_count().unwrap(), 2);
    assert_eq!(b.overview(1).unwrap().size(), (375, 275));
    let layout = ds.metadata_item("LAYOUT", "IMAGE_STRUCTURE");
    assert_eq!(layout.as_deref(), Some("COG"), "GDAL reads it as a COG");
}

/// An aerial frame as large-format cameras deliver it: every band of a 16-bit, pixel-interleaved image TIFF
/// comes back to the value, in 512 px tiles, including the partial tiles at the right and bottom edges (the
/// writer sends one row of tiles at a time).
#[test]
fn an_image_tiff_keeps_every_band_and_pixel_across_partial_tiles() {
    let (w, h) = (1100, 1300);
    let bands: Vec<Vec<u16>> =
        (0..4).map(|k| (0..w * h).map(|i| (256 + k * 1000 + (i % w) + 3 * (i / w)) as u16).collect()).collect();
    let (_dir, ds) = reopen(&image_tiff(w, h, &RasterData::U16(bands.clone())).unwrap(), "frame.tif");
    assert_eq!((ds.raster_size(), ds.raster_count()), ((w, h), 4));
    for (k, band) in bands.iter().enumerate() {
        let b = ds.rasterband(k + 1).unwrap();
        assert_eq!(b.block_size(), (512, 512));
        assert_eq!(b.read_as::<u16>((0, 0), (w, h), (w, h), None).unwrap().data(), band.as_slice(), "band {}", k + 1);
    }
    let structure = |item| ds.metadata_item(item, "IMAGE_STRUCTURE");
    assert_eq!(
        (structure("INTERLEAVE").as_deref(), structure("COMPRESSION").as_deref()),
        (Some("PIXEL"), Some("DEFLATE"))
    );
}

#[test]
fn inconsistent_input_names_item_and_field() {
    let mut bad = layer("poles", 3);
    bad.features[2].values.pop();
    let err = geopackage(&[bad], 4258).unwrap_err();
    assert!(matches!(err, GdalWriteError::Invalid { field: "values", .. }), "{err}");
    assert!(err.to_string().contains("layer poles feature 2"), "{err}");
    let short = Raster {
        width: 4,
        height: 4,
        geotransform: [0.0, 1.0, 0.0, 0.0, 0.0, -1.0],
        epsg: 25832,
        data: RasterData::U8(vec![vec![0; 16], vec![0; 15]]),
        nodata: None,
    };
    let err = geotiff(&short).unwrap_err();
    assert!(err.to_string().contains("band 2 holds 15 pixels"), "{err}");
    assert!(geotiff(&Raster { epsg: 999_999, data: RasterData::U8(vec![vec![0; 16]]), ..short }).is_err());
}
