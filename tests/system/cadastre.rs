//! End-to-end tests of `plumbline cadastre inspect` on GeoPackages made by `ogr2ogr` from GeoJSON and CSV,
//! and of `plumbline poles detect`, the pole and tree inventory that goes beside a cadastre.

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

use crate::support;

use std::path::{Path, PathBuf};
use std::process::Command;

use support::plumbline;

const LIGHTS: &str = r#"{"type": "FeatureCollection",
 "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::4258"}},
 "features": [
  {"type": "Feature", "properties": {"art": "Lichtmast", "dm": 0.3}, "geometry": {"type": "Point", "coordinates": [9.99, 53.55]}},
  {"type": "Feature", "properties": {"art": "Lichtmast", "dm": 0.3}, "geometry": null},
  {"type": "Feature", "properties": {"art": "Ampel", "dm": 0.2}, "geometry": {"type": "Point", "coordinates": [9.991, 53.55, 7.5]}},
  {"type": "Feature", "properties": {"art": null, "dm": 0.2}, "geometry": {"type": "MultiPoint", "coordinates": [[9.992, 53.55], [9.993, 53.55]]}},
  {"type": "Feature", "properties": {"art": "Baum", "dm": 0.5},
   "geometry": {"type": "Polygon", "coordinates": [[[9.99, 53.55], [9.991, 53.55], [9.991, 53.551], [9.99, 53.55]]]}}
 ]}"#;

const TREES_WITHOUT_SRS: &str = "id,wkt,typ\n1,\"POINT (560000 5930000)\",Baum\n2,\"POINT (560010 5930000)\",Baum\n";

/// `ogr2ogr` the GeoJSON layer `lights` and the SRS-less CSV layer `trees` into one GeoPackage.
fn cadastre(dir: &Path) -> PathBuf {
    let (json, csv, gpkg) = (dir.join("lights.geojson"), dir.join("trees.csv"), dir.join("cadastre.gpkg"));
    std::fs::write(&json, LIGHTS).unwrap();
    std::fs::write(&csv, TREES_WITHOUT_SRS).unwrap();
    ogr2ogr(&[gpkg.to_str().unwrap(), json.to_str().unwrap(), "-nln", "lights"]);
    let csv_options = ["-oo", "GEOM_POSSIBLE_NAMES=wkt", "-oo", "KEEP_GEOM_COLUMNS=NO", "-nln", "trees", "-update"];
    ogr2ogr(&[&[gpkg.to_str().unwrap(), csv.to_str().unwrap()][..], &csv_options].concat());
    gpkg
}

fn ogr2ogr(args: &[&str]) {
    let out = Command::new("ogr2ogr").args(["-f", "GPKG"]).args(args).output().expect("ogr2ogr (gdal-bin) runs");
    assert!(out.status.success(), "ogr2ogr {args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn inspect_prints_layers_counts_crs_fields_classes_and_problems_and_exits_0() {
    let dir = tempfile::tempdir().unwrap();
    let gpkg = cadastre(dir.path());
    let r = plumbline(&["cadastre", "inspect", gpkg.to_str().unwrap()]).run();
    r.success();
    let out = &r.stdout;
    for expected in [
        "2 layer(s)",
        "layer lights: 5 feature(s), CRS EPSG:4258 (ETRS89)",
        "layer trees: 2 feature(s), no CRS",
        "art (String)",
        "class values of art: \"Ampel\" 1, \"Baum\" 1, \"Lichtmast\" 2; null 1",
        "class values of typ: \"Baum\" 2; null 0",
        "none 1",
        "Polygon 1",
        "layer \"lights\", feature 2: NullGeometry",
        "layer \"lights\", feature 3: HeightDropped",
        "layer \"lights\", feature 4: MultiPoint",
        "layer \"lights\", feature 5: NotAPoint",
        "layer \"trees\": MissingSrs",
    ] {
        assert!(out.contains(expected), "missing {expected:?} in:\n{out}");
    }
}

#[test]
fn inspect_json_has_every_layer_and_problem() {
    let dir = tempfile::tempdir().unwrap();
    let gpkg = cadastre(dir.path());
    let r = plumbline(&["cadastre", "inspect", gpkg.to_str().unwrap(), "--json", "--class-attribute", "art"]).run();
    r.success();
    let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    let layers = v["layers"].as_array().unwrap();
    assert_eq!(layers.len(), 2);
    let lights = layers.iter().find(|l| l["name"] == "lights").unwrap();
    assert_eq!((lights["feature_count"].as_u64(), lights["crs"]["epsg"].as_u64()), (Some(5), Some(4258)));
    let problems: Vec<(String, Option<u64>)> = v["diagnostics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| (d["kind"].as_str().unwrap().to_owned(), d["fid"].as_u64()))
        .collect();
    let has = |kind: &str, fid: Option<u64>| problems.contains(&(kind.to_owned(), fid));
    assert!(has("null_geometry", Some(2)) && has("null_class", Some(4)) && has("not_a_point", Some(5)), "{problems:?}");
    // `trees` has no field `art`: named as a missing field of that layer.
    assert!(has("missing_srs", None) && has("missing_field", None), "{problems:?}");
}

#[test]
fn a_file_that_is_not_a_geopackage_or_missing_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("trees.gpkg");
    std::fs::write(&csv, TREES_WITHOUT_SRS).unwrap();
    let r = plumbline(&["cadastre", "inspect", csv.to_str().unwrap()]).run();
    r.failure_with(2);
    assert!(r.stderr.contains("trees.gpkg") && r.stderr.contains("GeoPackage"), "{}", r.stderr);
    let r = plumbline(&["cadastre", "inspect", dir.path().join("absent.gpkg").to_str().unwrap()]).run();
    r.failure_with(2);
}

/// The scanned street of `plumbline_synth::scan` as a LAS 1.2 file (format 0; LAZ when `compressed`), with
/// a GeoTIFF-keys CRS record of `epsg` when given.
fn street_cloud(compressed: bool, epsg: Option<u16>) -> (Vec<u8>, Vec<plumbline_synth::scan::StemTruth>) {
    let (points, truth) = plumbline_synth::scan::scan_scene(&plumbline_synth::scan::ScanScene::default(), 3);
    let mut builder = las::Builder::from((1, 2));
    builder.point_format = las::point::Format::new(0).unwrap();
    builder.point_format.is_compressed = compressed;
    let t = |offset: f64| las::Transform { scale: 0.001, offset };
    builder.transforms = las::Vector { x: t(512_000.0), y: t(5_403_000.0), z: t(0.0) };
    if let Some(code) = epsg {
        // GeoKeyDirectory: version 1.1.0, two keys: GTModelType = projected, ProjectedCSType = code.
        let keys: [u16; 12] = [1, 1, 0, 2, 1024, 0, 1, 1, 3072, 0, 1, code];
        let data = keys.iter().flat_map(|k| k.to_le_bytes()).collect();
        builder.vlrs.push(las::Vlr {
            user_id: "LASF_Projection".to_owned(),
            record_id: 34735,
            description: String::new(),
            data,
        });
    }
    let mut writer = las::Writer::new(std::io::Cursor::new(Vec::new()), builder.into_header().unwrap()).unwrap();
    for p in points {
        writer.write_point(las::Point { x: p[0], y: p[1], z: p[2], ..Default::default() }).unwrap();
    }
    (writer.into_inner().unwrap().into_inner(), truth)
}

/// The scanned street in feet — Oregon GIC Lambert (international feet) with NAVD88 heights in US survey
/// feet, as a compound WKT like Autzen's — is measured in metres and written back in feet: the same four
/// stems, centres within 3 cm, diameters within 2 cm (in metres).
#[test]
fn poles_detect_measures_a_cloud_in_feet_in_metres() {
    use gdal::vector::LayerAccess as _;
    let (ft, us_ft) = (0.3048, 0.304800609601219);
    let (points, truth) = plumbline_synth::scan::scan_scene(&plumbline_synth::scan::ScanScene::default(), 3);
    let horizontal = plumbline_runtime::crs::wkt_of_epsg(2992).unwrap();
    let wkt = format!(
        "COMPD_CS[\"NAD83 / Oregon GIC Lambert (ft) + NAVD88 height (ftUS)\",{horizontal},VERT_CS[\"NAVD88 height \
         (ftUS)\",VERT_DATUM[\"North American Vertical Datum 1988\",2005],UNIT[\"US survey foot\",{us_ft}],AXIS[\"Up\",UP]]]"
    );
    let feet: Vec<plumbline_poles::LasPoint> = points
        .iter()
        .map(|p| plumbline_poles::LasPoint { position: [p[0] / ft, p[1] / ft, p[2] / us_ft], gps_time: 0.0 })
        .collect();
    let encoding = plumbline_poles::LasEncoding { compressed: true, wkt: Some(wkt), adjusted_standard_week: None };
    let dir = tempfile::tempdir().unwrap();
    let (cloud, out) = (dir.path().join("street_ft.laz"), dir.path().join("poles.gpkg"));
    std::fs::write(&cloud, plumbline_poles::encode_las(&feet, &encoding).unwrap()).unwrap();
    let r = plumbline(&["poles", "detect", cloud.to_str().unwrap(), "--out", out.to_str().unwrap()]).run();
    r.success();
    assert!(r.stderr.contains("CRS EPSG:2992") && r.stderr.contains("heights in US survey foot"), "{}", r.stderr);
    assert!(r.stderr.contains("4 stems: 2 poles, 2 trunks"), "{}", r.stderr);
    let ds = gdal::Dataset::open(&out).unwrap();
    let mut layer = ds.layer_by_name("detected_poles").unwrap();
    let di = layer.defn().field_index("diameter_m").unwrap();
    let found: Vec<(f64, f64, f64)> = layer
        .features()
        .map(|f| {
            let (x, y, _) = f.geometry().unwrap().get_point(0);
            (x * ft, y * ft, f.field_as_double(di).unwrap().unwrap())
        })
        .collect();
    assert_eq!(found.len(), 4, "{found:?}");
    for t in &truth {
        let c = t.centre_at(1.3);
        let near = found.iter().any(|(x, y, d)| (x - c[0]).hypot(y - c[1]) < 0.03 && (d - t.diameter_m).abs() < 0.02);
        assert!(near, "{t:?}: {found:?}");
    }
}

/// `plumbline poles detect` on a scanned street (two trees, two poles, a facade, a car, a bush): the four
/// stems in a GeoPackage layer with the cloud's CRS, centres within 3 cm and diameters within 2 cm; a cloud
/// without a CRS record is written without one and said so, or takes `--epsg`; a truncated LAZ is an error
/// naming the file and the records; a cloud with no stem is a warning.
#[test]
fn poles_detect_writes_the_stems_of_a_scanned_street() {
    use gdal::vector::LayerAccess as _;
    let dir = tempfile::tempdir().unwrap();
    let (laz, truth) = street_cloud(true, Some(25832));
    let cloud = dir.path().join("street.laz");
    std::fs::write(&cloud, &laz).unwrap();
    let out = dir.path().join("poles.gpkg");
    let r = plumbline(&["poles", "detect", cloud.to_str().unwrap(), "--out", out.to_str().unwrap()]).run();
    r.success();
    assert!(r.stderr.contains("street.laz: LAS 1.2, point format 0 (LAZ)") && r.stderr.contains("CRS EPSG:25832"));
    assert!(r.stderr.contains("4 stems: 2 poles, 2 trunks, 0 unclassified"), "{}", r.stderr);
    let ds = gdal::Dataset::open(&out).unwrap();
    let mut layer = ds.layer_by_name("detected_poles").unwrap();
    assert_eq!(layer.spatial_ref().unwrap().auth_code().unwrap(), 25832);
    let (di, ci) = (layer.defn().field_index("diameter_m").unwrap(), layer.defn().field_index("class").unwrap());
    let found: Vec<(f64, f64, f64, String)> = layer
        .features()
        .map(|f| {
            let (x, y, _) = f.geometry().unwrap().get_point(0);
            let d = f.field_as_double(di).unwrap().unwrap();
            (x, y, d, f.field_as_string(ci).unwrap().unwrap())
        })
        .collect();
    assert_eq!(found.len(), 4, "{found:?}");
    for t in &truth {
        let c = t.centre_at(1.3);
        let (x, y, d, class) = found
            .iter()
            .min_by(|a, b| (a.0 - c[0]).hypot(a.1 - c[1]).total_cmp(&(b.0 - c[0]).hypot(b.1 - c[1])))
            .unwrap();
        assert!((x - c[0]).hypot(y - c[1]) < 0.03 && (d - t.diameter_m).abs() < 0.02, "{t:?}: {found:?}");
        assert_eq!(class, if t.crown { "trunk" } else { "pole" });
    }

    // A cadastre of three of the four stems (10 cm off), one object the cloud covers but does not hold, and
    // one far outside the cloud: three matched, one not in the cadastre, one not seen, one outside.
    let mut csv = String::from("id,wkt,typ\n");
    for (i, t) in truth.iter().enumerate().skip(1) {
        let c = t.centre_at(1.3);
        csv += &format!("{i},\"POINT ({} {})\",{}\n", c[0] + 0.1, c[1], if t.crown { "tree" } else { "light" });
    }
    csv += "7,\"POINT (512006.0 5403050.0)\",sign\n8,\"POINT (513000.0 5404000.0)\",pole\n";
    let (csv_path, registry) = (dir.path().join("objects.csv"), dir.path().join("registry.gpkg"));
    std::fs::write(&csv_path, csv).unwrap();
    let options =
        ["-oo", "GEOM_POSSIBLE_NAMES=wkt", "-oo", "KEEP_GEOM_COLUMNS=NO", "-nln", "objects", "-a_srs", "EPSG:25832"];
    ogr2ogr(&[&[registry.to_str().unwrap(), csv_path.to_str().unwrap()][..], &options].concat());
    let compared = dir.path().join("compared.gpkg");
    let r = plumbline(&["poles", "compare", out.to_str().unwrap(), "--cadastre", registry.to_str().unwrap()])
        .args(["--layer", "objects", "--class-attribute", "typ", "--out", compared.to_str().unwrap()])
        .run();
    r.success();
    assert!(
        r.stderr.contains("4 detections, 4 cadastre objects in the covered cells (1 outside): 3 matched")
            && r.stderr.contains("1 in the cloud but not in the cadastre, 1 in the cadastre but not seen"),
        "{}",
        r.stderr
    );
    let ds = gdal::Dataset::open(&compared).unwrap();
    let count = |name: &str| ds.layer_by_name(name).unwrap().feature_count();
    assert_eq!((count("matched"), count("not_in_cadastre"), count("not_seen")), (3, 1, 1));
    let mut matched = ds.layer_by_name("matched").unwrap();
    let di = matched.defn().field_index("distance_m").unwrap();
    for f in matched.features() {
        let d = f.field_as_double(di).unwrap().unwrap();
        assert!((d - 0.1).abs() < 0.04, "distance {d}");
    }

    let (las, _) = street_cloud(false, None);
    let plain = dir.path().join("street.las");
    std::fs::write(&plain, &las).unwrap();
    let r = plumbline(&["poles", "detect", plain.to_str().unwrap(), "--out", out.to_str().unwrap()]).run();
    r.success();
    assert!(r.stderr.contains("CRS not recorded") && r.stderr.contains("written without a CRS"), "{}", r.stderr);
    let r = plumbline(&["poles", "detect", plain.to_str().unwrap(), "--epsg", "25832", "--out", out.to_str().unwrap()])
        .run();
    r.success();
    assert!(!r.stderr.contains("without a CRS"), "{}", r.stderr);

    let cut = dir.path().join("cut.laz");
    std::fs::write(&cut, &laz[..laz.len() / 2]).unwrap();
    let r = plumbline(&["poles", "detect", cut.to_str().unwrap(), "--out", out.to_str().unwrap()]).run();
    r.failure_with(2);
    assert!(r.stderr.contains("point cloud cut.laz") && r.stderr.contains("the file is truncated"), "{}", r.stderr);

    let ground: Vec<u8> = {
        let mut builder = las::Builder::from((1, 2));
        builder.point_format = las::point::Format::new(0).unwrap();
        let mut w = las::Writer::new(std::io::Cursor::new(Vec::new()), builder.into_header().unwrap()).unwrap();
        for i in 0..400 {
            w.write_point(las::Point { x: f64::from(i % 20), y: f64::from(i / 20), z: 5.0, ..Default::default() })
                .unwrap();
        }
        w.into_inner().unwrap().into_inner()
    };
    let flat = dir.path().join("flat.las");
    std::fs::write(&flat, ground).unwrap();
    let r = plumbline(&["poles", "detect", flat.to_str().unwrap(), "--epsg", "25832", "--out", out.to_str().unwrap()])
        .run();
    r.success();
    assert!(r.stderr.contains("warning: no pole or trunk found in 400 points"), "{}", r.stderr);
}
