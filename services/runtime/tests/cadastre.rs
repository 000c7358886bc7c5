//! Reading cadastre GeoPackages written by GDAL in the test: reprojection against `CrsTransform`, every
//! kind of messy feature with its diagnostic and FID, the exact tile-box filter, classes and accuracies.

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use gdal::DriverManager;
use gdal::spatial_ref::SpatialRef;
use gdal::vector::{Feature, FieldValue, Geometry, LayerAccess, LayerOptions, OGRFieldType, OGRwkbGeometryType};
use plumbline_campaign::manifest::{Cadastre, ClassAccuracy, PoleClass};
use plumbline_campaign::{Epsg, Location};
use plumbline_runtime::CrsTransform;
use plumbline_runtime::cadastre::{
    CadastreError, CadastreRead, CadastreSource, Consequence, DiagnosticKind, inspect_cadastre, read_cadastre,
};

const UTM32: Epsg = Epsg(25832);

/// A layer to write: name, SRS (None = none), and features as (WKT or None, art, dm).
struct TestLayer {
    name: &'static str,
    srs: Option<SpatialRef>,
    features: Vec<(Option<String>, Option<FieldValue>, Option<FieldValue>)>,
    dm_type: OGRFieldType::Type,
    ty: OGRwkbGeometryType::Type,
}

fn layer(name: &'static str, srs: Option<SpatialRef>) -> TestLayer {
    TestLayer { name, srs, features: Vec::new(), dm_type: OGRFieldType::OFTReal, ty: OGRwkbGeometryType::wkbUnknown }
}

impl TestLayer {
    fn add(mut self, wkt: Option<&str>, art: Option<&str>, dm: Option<FieldValue>) -> Self {
        let art = art.map(|a| FieldValue::StringValue(a.to_owned()));
        self.features.push((wkt.map(str::to_owned), art, dm));
        self
    }
}

/// Writes the layers into a new GeoPackage with GDAL's GPKG driver; FIDs are 1, 2, … in order.
fn write_gpkg(dir: &Path, file: &str, layers: &[TestLayer]) -> PathBuf {
    let path = dir.join(file);
    let driver = DriverManager::get_driver_by_name("GPKG").unwrap();
    let mut ds = driver.create_vector_only(&path).unwrap();
    for l in layers {
        let options = LayerOptions { name: l.name, srs: l.srs.as_ref(), ty: l.ty, options: None };
        let lyr = ds.create_layer(options).unwrap();
        lyr.create_defn_fields(&[("art", OGRFieldType::OFTString), ("dm", l.dm_type)]).unwrap();
        for (wkt, art, dm) in &l.features {
            let mut f = Feature::new(lyr.defn()).unwrap();
            if let Some(wkt) = wkt {
                f.set_geometry(Geometry::from_wkt(wkt).unwrap()).unwrap();
            }
            for (i, v) in [art, dm].into_iter().enumerate() {
                match v {
                    Some(v) => f.set_field(i, v).unwrap(),
                    None => f.set_field_null(i).unwrap(),
                }
            }
            f.create(&lyr).unwrap();
        }
    }
    ds.close().unwrap();
    path
}

fn srs(epsg: u32) -> Option<SpatialRef> {
    Some(SpatialRef::from_epsg(epsg).unwrap())
}

fn spec(layers: &[&str]) -> Cadastre {
    Cadastre {
        url: Location("cadastre.gpkg".into()),
        layers: layers.iter().map(|s| (*s).to_owned()).collect(),
        class_attribute: Some("art".into()),
        class_values: [("Lichtmast", PoleClass::Light), ("Baum", PoleClass::Tree), ("Ampel", PoleClass::Sign)]
            .into_iter()
            .map(|(k, v)| (k.to_owned(), v))
            .collect(),
        class: None,
        accuracy: ClassAccuracy::default(),
        diameter_attribute: Some("dm".into()),
        epsg: None,
    }
}

fn real(v: f64) -> Option<FieldValue> {
    Some(FieldValue::RealValue(v))
}

/// A grid of `n × n` ETRS89 points near Hamburg, `step` degrees apart.
fn grid(n: usize, step: f64) -> Vec<(f64, f64)> {
    (0..n * n).map(|k| (9.99 + step * (k % n) as f64, 53.55 + step * (k / n) as f64)).collect()
}

fn grid_layer(name: &'static str, points: &[(f64, f64)]) -> TestLayer {
    points.iter().fold(layer(name, srs(4258)), |l, (x, y)| {
        l.add(Some(&format!("POINT ({x} {y})")), Some("Lichtmast"), real(0.3))
    })
}

fn read(path: &Path, spec: &Cadastre, bbox: Option<[f64; 4]>) -> CadastreRead {
    read_cadastre(CadastreSource::Path(path), spec, UTM32, bbox).unwrap()
}

#[test]
fn a_clean_etrs89_file_is_read_into_utm_matching_crs_transform_to_1_mm() {
    let dir = tempfile::tempdir().unwrap();
    let points = grid(7, 0.001);
    let path = write_gpkg(dir.path(), "clean.gpkg", &[grid_layer("lights", &points)]);
    let got = read(&path, &spec(&["lights"]), None);
    assert!(got.diagnostics.is_empty(), "{:?}", got.diagnostics);
    assert_eq!(got.features.len(), points.len());
    let reference = CrsTransform::new(4258, 25832).unwrap();
    for (k, (f, (lon, lat))) in got.features.iter().zip(&points).enumerate() {
        let (e, n, _) = reference.transform_point(*lon, *lat, 0.0).unwrap();
        assert!((f.easting - e).abs() < 1e-3 && (f.northing - n).abs() < 1e-3, "point {k}: {f:?} vs {e} {n}");
        assert_eq!((f.id.layer, f.id.fid, f.id.part), (0, k as u64 + 1, 0));
        assert_eq!((f.class, f.accuracy_m, f.diameter_m), (PoleClass::Light, 0.10, Some(0.3)));
    }
    assert_eq!(got.layers[0].used, points.len());
    // The same file from bytes (an object fetched from a store) reads the same.
    let bytes = std::fs::read(&path).unwrap();
    let from_bytes = CadastreSource::Bytes { name: "s3://bucket/clean.gpkg", bytes: &bytes };
    assert_eq!(read_cadastre(from_bytes, &spec(&["lights"]), UTM32, None).unwrap().features, got.features);
}

/// (kind, consequence, layer, fid, field) of every diagnostic.
type Key = (DiagnosticKind, Consequence, String, Option<u64>, Option<String>);

fn keys(read: &CadastreRead) -> BTreeSet<String> {
    read.diagnostics.iter().map(|d| format!("{:?}", (d.kind, d.consequence, &d.layer, d.fid, &d.field))).collect()
}

fn key(kind: DiagnosticKind, consequence: Consequence, layer: &str, fid: Option<u64>, field: Option<&str>) -> String {
    let k: Key = (kind, consequence, layer.to_owned(), fid, field.map(str::to_owned));
    format!("{:?}", (k.0, k.1, &k.2, k.3, &k.4))
}

fn messy_layers() -> Vec<TestLayer> {
    let p = |x: f64| format!("POINT ({x} 5930000)");
    let poles = layer("poles", srs(25832))
        .add(Some(&p(560000.0)), Some("Lichtmast"), real(0.3)) // 1 good
        .add(None, Some("Lichtmast"), real(0.3)) // 2 null geometry
        .add(Some("POINT EMPTY"), Some("Lichtmast"), real(0.3)) // 3 empty
        .add(Some("MULTIPOINT ((560010 5930000),(560011 5930001))"), Some("Ampel"), real(0.2)) // 4 split
        .add(Some("POINT Z (560020 5930000 12.5)"), Some("Lichtmast"), real(0.3)) // 5 height dropped
        .add(Some("POLYGON ((0 0,1 0,1 1,0 0))"), Some("Lichtmast"), real(0.3)) // 6 not a point
        .add(Some(&p(560030.0)), None, real(0.3)) // 7 null class
        .add(Some(&p(560040.0)), Some("Hydrant"), real(0.3)) // 8 unknown class
        .add(Some(&p(560050.0)), Some("Lichtmast"), None) // 9 null diameter, kept
        .add(Some("MULTIPOINT ((560060 5930000))"), Some("Baum"), real(0.4)) // 10 one point: a point
        .add(Some("LINESTRING (0 0,1 1)"), Some("Baum"), real(0.4)); // 11 not a point
    let s = |v: &str| Some(FieldValue::StringValue(v.to_owned()));
    let mut trees = layer("trees", srs(25832))
        .add(Some(&p(560100.0)), Some("Baum"), s("0.45")) // 1 numeric text: read
        .add(Some(&p(560110.0)), Some("Baum"), s("thick")) // 2 wrong type, kept without diameter
        .add(Some(&p(560120.0)), Some("Baum"), s("45")); // 3 centimetres, kept without diameter
    trees.dm_type = OGRFieldType::OFTString;
    let engineering = SpatialRef::from_wkt(r#"LOCAL_CS["site grid",UNIT["metre",1],AXIS["X",EAST],AXIS["Y",NORTH]]"#);
    let mut table = layer("table", None).add(None, Some("Baum"), real(0.4));
    table.ty = OGRwkbGeometryType::wkbNone;
    vec![
        poles,
        trees,
        table,
        layer("empty", srs(25832)),
        layer("nosrs", None).add(Some(&p(560200.0)), Some("Baum"), real(0.4)),
        layer("local", Some(engineering.unwrap())).add(Some("POINT (1 2)"), Some("Baum"), real(0.4)),
    ]
}

#[test]
fn each_defect_gives_its_diagnostic_with_fid_and_field_and_the_rest_is_read() {
    use Consequence::{FeatureSkipped as Skip, Kept, LayerSkipped};
    use DiagnosticKind as K;
    let dir = tempfile::tempdir().unwrap();
    let path = write_gpkg(dir.path(), "messy.gpkg", &messy_layers());
    let got = read(&path, &spec(&["poles", "trees", "empty", "nosrs", "local", "absent", "table"]), None);
    let expected: BTreeSet<String> = [
        key(K::NullGeometry, Skip, "poles", Some(2), None),
        key(K::EmptyGeometry, Skip, "poles", Some(3), None),
        key(K::MultiPoint, Kept, "poles", Some(4), None),
        key(K::HeightDropped, Kept, "poles", Some(5), None),
        key(K::NotAPoint, Skip, "poles", Some(6), None),
        key(K::NullClass, Skip, "poles", Some(7), Some("art")),
        key(K::UnknownClass, Skip, "poles", Some(8), Some("art")),
        key(K::NullDiameter, Kept, "poles", Some(9), Some("dm")),
        key(K::NotAPoint, Skip, "poles", Some(11), None),
        key(K::BadDiameter, Kept, "trees", Some(2), Some("dm")),
        key(K::BadDiameter, Kept, "trees", Some(3), Some("dm")),
        key(K::EmptyLayer, Kept, "empty", None, None),
        key(K::MissingSrs, LayerSkipped, "nosrs", None, None),
        key(K::UnknownSrs, LayerSkipped, "local", None, None),
        key(K::MissingLayer, LayerSkipped, "absent", None, None),
        key(K::NotAPoint, LayerSkipped, "table", None, None),
    ]
    .into_iter()
    .collect();
    assert_eq!(keys(&got), expected);
    assert_eq!(got.diagnostics.len(), expected.len(), "each problem once");
    assert!(got.diagnostics.iter().all(|d| d.file == path.display().to_string()));
    let ids: Vec<(u32, u64, u32)> = got.features.iter().map(|f| (f.id.layer, f.id.fid, f.id.part)).collect();
    assert_eq!(
        ids,
        [(0, 1, 0), (0, 4, 0), (0, 4, 1), (0, 5, 0), (0, 9, 0), (0, 10, 0), (1, 1, 0), (1, 2, 0), (1, 3, 0)]
    );
    let by_id: BTreeMap<(u32, u64, u32), _> = ids.iter().copied().zip(&got.features).collect();
    let split = by_id[&(0, 4, 1)];
    assert_eq!((split.easting, split.northing, split.class), (560011.0, 5930001.0, PoleClass::Sign));
    assert_eq!((by_id[&(0, 5, 0)].easting, by_id[&(0, 10, 0)].class), (560020.0, PoleClass::Tree));
    assert_eq!(by_id[&(0, 9, 0)].diameter_m, None);
    assert_eq!([by_id[&(1, 1, 0)].diameter_m, by_id[&(1, 2, 0)].diameter_m], [Some(0.45), None]);
    let counts: Vec<(bool, usize, usize, usize)> =
        got.layers.iter().map(|l| (l.read, l.examined, l.used, l.skipped)).collect();
    assert_eq!(
        counts,
        [
            (true, 11, 6, 6),
            (true, 3, 3, 0),
            (true, 0, 0, 0),
            (false, 0, 0, 0),
            (false, 0, 0, 0),
            (false, 0, 0, 0),
            (false, 0, 0, 0)
        ]
    );
}

#[test]
fn the_manifest_epsg_supplies_a_missing_srs_but_not_for_an_engineering_one_as_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_gpkg(dir.path(), "nosrs.gpkg", &messy_layers());
    let mut with_override = spec(&["nosrs"]);
    with_override.epsg = Some(Epsg(4258));
    let wrong = read(&path, &with_override, None);
    // 560200 "degrees" of longitude cannot be placed anywhere: the coordinate is reported, not invented.
    assert!(wrong.features.is_empty());
    assert_eq!(wrong.diagnostics.len(), 1, "{:?}", wrong.diagnostics);
    assert_eq!((wrong.diagnostics[0].kind, wrong.diagnostics[0].fid), (DiagnosticKind::BadCoordinate, Some(1)));
    with_override.epsg = Some(UTM32);
    let got = read(&path, &with_override, None);
    assert!(got.diagnostics.is_empty(), "{:?}", got.diagnostics);
    assert_eq!((got.features[0].easting, got.features[0].northing), (560200.0, 5930000.0));
}

#[test]
fn the_tile_box_filter_is_exact_on_a_grid_and_uses_the_spatial_filter() {
    let dir = tempfile::tempdir().unwrap();
    let points = grid(21, 0.0005);
    let path = write_gpkg(dir.path(), "grid.gpkg", &[grid_layer("lights", &points)]);
    let all = read(&path, &spec(&["lights"]), None).features;
    // Box edges exactly on projected points, to test the closed box; the grid is rotated against UTM.
    let e: Vec<f64> = all.iter().map(|f| f.easting).collect();
    let n: Vec<f64> = all.iter().map(|f| f.northing).collect();
    for bbox in
        [[e[66], n[66], e[88] + 0.5, n[310]], [e[0] - 1.0, n[0] - 1.0, e[0], n[0]], [e[200], n[200], e[200], n[200]]]
    {
        let inside = |f: &&plumbline_campaign::CadastreFeature| {
            bbox[0] <= f.easting && f.easting <= bbox[2] && bbox[1] <= f.northing && f.northing <= bbox[3]
        };
        let expected: Vec<_> = all.iter().filter(inside).map(|f| f.id).collect();
        let got = read(&path, &spec(&["lights"]), Some(bbox));
        assert!(!expected.is_empty());
        assert_eq!(got.features.iter().map(|f| f.id).collect::<Vec<_>>(), expected, "box {bbox:?}");
        let counts = &got.layers[0];
        assert!(counts.examined < all.len() / 2, "GDAL's filter preselects: {counts:?}");
        assert_eq!(counts.used + counts.outside_bbox, counts.examined);
    }
    let bad = read_cadastre(CadastreSource::Path(&path), &spec(&["lights"]), UTM32, Some([1.0, 0.0, 0.0, 1.0]));
    assert!(matches!(bad, Err(CadastreError::BadBox { .. })));
}

#[test]
fn classes_and_accuracies_follow_the_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let p = |x: f64| Some(format!("POINT ({x} 5930000)"));
    let mixed = [("Lichtmast", 1.0), ("Ampel", 2.0), ("Baum", 3.0), ("light", 4.0), (" Tree ", 5.0), ("pole", 6.0)]
        .into_iter()
        .fold(layer("mixed", srs(25832)), |l, (art, x)| l.add(p(x).as_deref(), Some(art), real(0.3)));
    let path = write_gpkg(dir.path(), "classes.gpkg", &[mixed]);
    let mut mapped = spec(&["mixed"]);
    mapped.accuracy = ClassAccuracy { poles: 0.05, lights: 0.12, signs: 0.2, trees: 0.7 };
    let got = read(&path, &mapped, None);
    let classes: Vec<_> = got.features.iter().map(|f| (f.id.fid, f.class, f.accuracy_m)).collect();
    assert_eq!(classes, [(1, PoleClass::Light, 0.12), (2, PoleClass::Sign, 0.2), (3, PoleClass::Tree, 0.7)]);
    assert!(got.diagnostics.iter().all(|d| d.kind == DiagnosticKind::UnknownClass && d.fid >= Some(4)));
    // Without class_values the values are class names, any case; German names are then unknown.
    let mut named = spec(&["mixed"]);
    named.class_values.clear();
    let got = read(&path, &named, None);
    let classes: Vec<_> = got.features.iter().map(|f| (f.id.fid, f.class, f.accuracy_m)).collect();
    assert_eq!(classes, [(4, PoleClass::Light, 0.10), (5, PoleClass::Tree, 0.50), (6, PoleClass::Pole, 0.10)]);
    assert_eq!(got.diagnostics.len(), 3);
    // A fixed class ignores the attribute; a missing diameter field is noted once and the layer read.
    let mut fixed = spec(&["mixed"]);
    (fixed.class, fixed.class_attribute, fixed.diameter_attribute) = (Some(PoleClass::Tree), None, Some("dbh".into()));
    fixed.class_values.clear();
    let got = read(&path, &fixed, None);
    assert_eq!(got.features.len(), 6);
    assert!(got.features.iter().all(|f| f.class == PoleClass::Tree && f.accuracy_m == 0.5 && f.diameter_m.is_none()));
    assert_eq!(got.diagnostics.len(), 1);
    assert_eq!(
        (got.diagnostics[0].kind, got.diagnostics[0].field.as_deref()),
        (DiagnosticKind::MissingField, Some("dbh"))
    );
    // A missing class attribute stops the layer.
    let mut absent = spec(&["mixed"]);
    absent.class_attribute = Some("klasse".into());
    let got = read(&path, &absent, None);
    assert!(got.features.is_empty());
    assert_eq!(got.diagnostics[0].consequence, Consequence::LayerSkipped);
}

#[test]
fn a_file_that_is_not_a_geopackage_is_an_open_error_naming_it() {
    let bytes = b"fid,x,y\n1,2,3\n";
    let source = CadastreSource::Bytes { name: "memory:///not.gpkg", bytes };
    let err = read_cadastre(source, &spec(&["lights"]), UTM32, None).unwrap_err();
    assert!(matches!(err, CadastreError::NotVector { .. }) && err.to_string().contains("memory:///not.gpkg"), "{err}");
    assert!(err.to_string().contains("no SQLite header"), "{err}");
    let err = inspect_cadastre(CadastreSource::Path(Path::new("/nonexistent/x.gpkg")), None).unwrap_err();
    assert!(err.to_string().contains("/nonexistent/x.gpkg"), "{err}");
}

#[test]
fn inspect_lists_layers_geometry_counts_crs_fields_class_values_and_problems() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_gpkg(dir.path(), "messy.gpkg", &messy_layers());
    let got = inspect_cadastre(CadastreSource::Path(&path), None).unwrap();
    let names: BTreeSet<&str> = got.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["empty", "local", "nosrs", "poles", "table", "trees"].into());
    let layer = |name: &str| got.layers.iter().find(|l| l.name == name).unwrap();
    let poles = layer("poles");
    assert_eq!(poles.feature_count, 11);
    assert_eq!((poles.crs.epsg, poles.crs.name.as_deref()), (Some(25832), Some("ETRS89 / UTM zone 32N")));
    assert_eq!(poles.geometry_counts.values().sum::<usize>(), 11);
    assert_eq!(poles.geometry_counts["none"], 1);
    assert_eq!(poles.geometry_counts["Polygon"], 1);
    let fields: Vec<(&str, &str)> = poles.fields.iter().map(|f| (f.name.as_str(), f.type_name.as_str())).collect();
    assert_eq!(fields, [("art", "String"), ("dm", "Real")]);
    assert_eq!(poles.class_values.len(), 1, "the text field `art` looks like a class");
    let art = &poles.class_values[0];
    let values: Vec<(&str, usize)> = art.values.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    assert_eq!(values, [("Ampel", 1), ("Baum", 2), ("Hydrant", 1), ("Lichtmast", 6)]);
    assert_eq!((art.nulls, art.other), (1, 0));
    assert_eq!((layer("nosrs").crs.epsg, layer("nosrs").crs.name.as_deref()), (None, None));
    assert_eq!((layer("empty").feature_count, layer("trees").fields[1].type_name.as_str()), (0, "String"));
    let kinds: BTreeSet<DiagnosticKind> = got.diagnostics.iter().map(|d| d.kind).collect();
    for kind in [
        DiagnosticKind::NullGeometry,
        DiagnosticKind::EmptyLayer,
        DiagnosticKind::MissingSrs,
        DiagnosticKind::UnknownSrs,
    ] {
        assert!(kinds.contains(&kind), "{kind:?}: {:?}", got.diagnostics);
    }
    let table: Vec<_> = got.diagnostics.iter().filter(|d| d.layer == "table").map(|d| (d.kind, d.fid)).collect();
    assert_eq!(table, [(DiagnosticKind::NotAPoint, None), (DiagnosticKind::NullGeometry, Some(1))]);
    let fids: Vec<u64> = got.diagnostics.iter().filter(|d| d.layer == "poles").filter_map(|d| d.fid).collect();
    assert_eq!(fids, [2, 3, 4, 5, 6, 11]);
}

// --- Damaged and wrong files: named for what they are, never a crash, never a silently shorter read ---------

/// The root page of `table` (1-based) and the file's page size, through GDAL's SQL on the GeoPackage.
fn root_page(path: &Path, table: &str) -> (usize, usize) {
    let ds = gdal::Dataset::open(path).unwrap();
    let sql = format!("SELECT rootpage FROM sqlite_master WHERE name = '{table}'");
    let mut rows = ds.execute_sql(&sql, None, gdal::vector::sql::Dialect::DEFAULT).unwrap().unwrap();
    let root = rows.features().next().unwrap().field_as_integer(0).unwrap().unwrap();
    let bytes = std::fs::read(path).unwrap();
    let size = match u16::from_be_bytes([bytes[16], bytes[17]]) {
        1 => 65_536,
        n => usize::from(n),
    };
    (usize::try_from(root).unwrap(), size)
}

/// Overwrite page `page` (1-based) of the SQLite file with garbage.
fn smash_page(path: &Path, page: usize, size: usize) {
    let mut bytes = std::fs::read(path).unwrap();
    bytes[(page - 1) * size..page * size].fill(0xAB);
    std::fs::write(path, bytes).unwrap();
}

/// The child page in the middle of an interior table page (SQLite b-tree page type 5).
fn middle_child(path: &Path, page: usize, size: usize) -> usize {
    let bytes = std::fs::read(path).unwrap();
    let p = &bytes[(page - 1) * size..page * size];
    assert_eq!(p[0], 0x05, "the root page of a 3000-row table is an interior page");
    let cells = usize::from(u16::from_be_bytes([p[3], p[4]]));
    let at = 12 + 2 * (cells / 2);
    let cell = usize::from(u16::from_be_bytes([p[at], p[at + 1]]));
    u32::from_be_bytes([p[cell], p[cell + 1], p[cell + 2], p[cell + 3]]) as usize
}

fn two_layers(dir: &Path) -> PathBuf {
    let many = grid(55, 0.0001); // 3025 points: a table of many pages
    write_gpkg(dir, "two.gpkg", &[grid_layer("lights", &many), grid_layer("trees", &grid(5, 0.001))])
}

#[test]
fn a_corrupted_page_is_a_diagnostic_and_the_features_before_it_and_the_other_layers_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let path = two_layers(dir.path());
    let (root, size) = root_page(&path, "lights");
    smash_page(&path, middle_child(&path, root, size), size);
    let got = read(&path, &spec(&["lights", "trees"]), None);
    let failed: Vec<_> = got.diagnostics.iter().filter(|d| d.kind == DiagnosticKind::ReadFailed).collect();
    assert_eq!(failed.len(), 1, "{:?}", got.diagnostics);
    assert_eq!((failed[0].layer.as_str(), failed[0].consequence), ("lights", Consequence::Kept));
    assert!(failed[0].detail.contains("of 3025 features") && failed[0].detail.contains("malformed"), "{failed:?}");
    let lights = &got.layers[0];
    assert!(lights.used > 100 && lights.used < 3025, "the rows before the damaged page are kept: {lights:?}");
    assert_eq!(got.layers[1].used, 25, "the intact layer is read whole");
    // The run reads through the spatial filter of its tile box: the same.
    let everywhere = [0.0, 0.0, 1e7, 1e7];
    let boxed = read(&path, &spec(&["lights", "trees"]), Some(everywhere));
    assert!(boxed.diagnostics.iter().any(|d| d.kind == DiagnosticKind::ReadFailed && d.layer == "lights"));
    assert_eq!(boxed.layers[1].used, 25);
    // inspect says the same.
    let inspected = inspect_cadastre(CadastreSource::Path(&path), Some("art")).unwrap();
    assert!(inspected.diagnostics.iter().any(|d| d.kind == DiagnosticKind::ReadFailed && d.layer == "lights"));
    assert_eq!(inspected.layers[1].feature_count, 25);
}

#[test]
fn a_corrupted_root_page_skips_its_layer_loudly_and_reads_the_next() {
    let dir = tempfile::tempdir().unwrap();
    let path = two_layers(dir.path());
    let (root, size) = root_page(&path, "lights");
    smash_page(&path, root, size);
    let got = read(&path, &spec(&["lights", "trees"]), None);
    let failed: Vec<_> = got.diagnostics.iter().filter(|d| d.kind == DiagnosticKind::ReadFailed).collect();
    assert_eq!(failed.len(), 1, "{:?}", got.diagnostics);
    assert_eq!(failed[0].consequence, Consequence::LayerSkipped);
    assert!(failed[0].detail.starts_with("reading stopped after 0 of 3025 features"), "{failed:?}");
    assert_eq!((got.layers[0].used, got.layers[1].used), (0, 25));
}

#[test]
fn an_undecodable_geometry_blob_is_told_apart_from_a_null_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_gpkg(dir.path(), "blobs.gpkg", &[grid_layer("lights", &grid(3, 0.001))]);
    {
        let options = gdal::DatasetOptions {
            open_flags: gdal::GdalOpenFlags::GDAL_OF_VECTOR | gdal::GdalOpenFlags::GDAL_OF_UPDATE,
            ..Default::default()
        };
        let ds = gdal::Dataset::open_ex(&path, options).unwrap();
        for sql in [
            "UPDATE lights SET geom = X'47500001DEADBEEF' WHERE fid = 3",
            "UPDATE lights SET geom = NULL WHERE fid = 4",
        ] {
            ds.execute_sql(sql, None, gdal::vector::sql::Dialect::DEFAULT).unwrap();
        }
    }
    let got = read(&path, &spec(&["lights"]), None);
    let kinds: Vec<_> = got.diagnostics.iter().map(|d| (d.kind, d.fid)).collect();
    assert_eq!(kinds, [(DiagnosticKind::BadGeometry, Some(3)), (DiagnosticKind::NullGeometry, Some(4))]);
    assert!(got.diagnostics[0].detail.contains("cannot be decoded"), "{:?}", got.diagnostics[0]);
    assert_eq!(got.features.len(), 7);
}

#[test]
fn a_3d_point_layer_gives_one_aggregated_line_not_one_per_feature() {
    let dir = tempfile::tempdir().unwrap();
    let points = grid(20, 0.0005);
    let layer = points.iter().fold(layer("lights", srs(4258)), |l, (x, y)| {
        l.add(Some(&format!("POINT Z ({x} {y} 12.5)")), Some("Lichtmast"), real(0.3))
    });
    let path = write_gpkg(dir.path(), "z.gpkg", &[layer]);
    let got = read(&path, &spec(&["lights"]), None);
    assert_eq!(got.features.len(), 400);
    assert_eq!(got.diagnostics.len(), 1, "{:?}", got.diagnostics);
    let d = &got.diagnostics[0];
    assert_eq!((d.kind, d.fid), (DiagnosticKind::HeightDropped, None));
    assert!(d.detail.starts_with("400 features, the first is feature 1"), "{d:?}");
    let inspected = inspect_cadastre(CadastreSource::Path(&path), None).unwrap();
    assert_eq!(inspected.diagnostics.len(), 1, "{:?}", inspected.diagnostics);
}

#[test]
fn files_that_are_no_vector_geopackage_are_named_for_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.gpkg");
    std::fs::write(&empty, b"").unwrap();
    let text = dir.path().join("text.gpkg");
    std::fs::write(&text, b"layer,x,y\nlights,1,2\n").unwrap();
    let raster = dir.path().join("raster.gpkg");
    {
        let driver = DriverManager::get_driver_by_name("GPKG").unwrap();
        let mut ds = driver.create_with_band_type::<u8, _>(&raster, 16, 16, 1).unwrap();
        ds.set_geo_transform(&[500_000.0, 1.0, 0.0, 5_000_016.0, 0.0, -1.0]).unwrap();
        ds.set_spatial_ref(&SpatialRef::from_epsg(25832).unwrap()).unwrap();
        ds.rasterband(1).unwrap().fill(7.0, None).unwrap();
    }
    let sqlite = dir.path().join("plain.gpkg");
    {
        let driver = DriverManager::get_driver_by_name("SQLite").unwrap();
        let mut ds = driver.create_vector_only(&sqlite).unwrap();
        ds.create_layer(LayerOptions { name: "t", ..Default::default() }).unwrap();
    }
    let no_layer = dir.path().join("no_layer.gpkg");
    DriverManager::get_driver_by_name("GPKG").unwrap().create_vector_only(&no_layer).unwrap().close().unwrap();
    let empty_bytes: &[u8] = &[];
    let cases: [(CadastreSource<'_>, &str); 6] = [
        (CadastreSource::Path(&no_layer), "no vector layer"),
        (CadastreSource::Path(&empty), "the file is empty (0 bytes"),
        (CadastreSource::Bytes { name: "s3://b/upload.gpkg", bytes: empty_bytes }, "the file is empty (0 bytes"),
        (CadastreSource::Path(&text), "no SQLite header (the file's 21 bytes start with `layer,x,y.lights`)"),
        (CadastreSource::Path(&raster), "it holds raster tiles only"),
        (CadastreSource::Path(&sqlite), "GDAL: "),
    ];
    for (source, expected) in cases {
        for e in [
            read_cadastre(source, &spec(&["lights"]), UTM32, None).unwrap_err(),
            inspect_cadastre(source, None).unwrap_err(),
        ] {
            assert!(matches!(e, CadastreError::NotVector { .. }), "{e:?}");
            let text = e.to_string();
            assert!(text.starts_with(&format!("{} is not a GeoPackage with vector layers: ", source.name())), "{text}");
            assert!(text.contains(expected), "{text} should contain {expected}");
        }
    }
}
