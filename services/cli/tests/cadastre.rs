//! End-to-end tests of `plumbline cadastre inspect` on GeoPackages made by `ogr2ogr` from GeoJSON and CSV.

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

mod support;

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
