//! Cadastre reading throughput: a city-sized ETRS89 point layer (GDAL-written GeoPackage) read into
//! EPSG:25832 whole, through one 250 m tile box, and inspected. Run with
//! `cargo bench -p plumbline-runtime --bench cadastre [-- sizes...]`; prints a table (best of 3 runs).
#![allow(clippy::unwrap_used)]

use std::path::Path;
use std::time::Instant;

use gdal::DriverManager;
use gdal::spatial_ref::SpatialRef;
use gdal::vector::{Feature, FieldValue, Geometry, LayerAccess, LayerOptions, OGRFieldType, OGRwkbGeometryType};
use plumbline_campaign::manifest::{Cadastre, ClassAccuracy, PoleClass};
use plumbline_campaign::{Epsg, Location};
use plumbline_runtime::cadastre::{CadastreSource, inspect_cadastre, read_cadastre};

/// `n` points on a square grid of about 10 km side near Hamburg, a class value each.
fn write_layer(path: &Path, n: usize) {
    let mut ds = DriverManager::get_driver_by_name("GPKG").unwrap().create_vector_only(path).unwrap();
    let srs = SpatialRef::from_epsg(4258).unwrap();
    let mut tx = ds.start_transaction().unwrap();
    let options = LayerOptions { name: "lights", srs: Some(&srs), ty: OGRwkbGeometryType::wkbPoint, options: None };
    let layer = tx.create_layer(options).unwrap();
    layer.create_defn_fields(&[("art", OGRFieldType::OFTString), ("dm", OGRFieldType::OFTReal)]).unwrap();
    let side = (n as f64).sqrt().ceil() as usize;
    let step = 0.15 / side as f64;
    for k in 0..n {
        let (lon, lat) = (9.9 + step * (k % side) as f64, 53.5 + 0.6 * step * (k / side) as f64);
        let mut f = Feature::new(layer.defn()).unwrap();
        f.set_geometry(Geometry::from_wkt(&format!("POINT ({lon} {lat})")).unwrap()).unwrap();
        let art = if k % 3 == 0 { "Baum" } else { "Lichtmast" };
        f.set_field(0, &FieldValue::StringValue(art.into())).unwrap();
        f.set_field_double(1, 0.3).unwrap();
        f.create(&layer).unwrap();
    }
    tx.commit().unwrap();
}

fn spec() -> Cadastre {
    Cadastre {
        url: Location("bench.gpkg".into()),
        layers: vec!["lights".into()],
        class_attribute: Some("art".into()),
        class_values: [("Lichtmast".into(), PoleClass::Light), ("Baum".into(), PoleClass::Tree)].into(),
        class: None,
        accuracy: ClassAccuracy::default(),
        diameter_attribute: Some("dm".into()),
        epsg: None,
    }
}

/// Best of three wall-clock runs, seconds, and the last result's object count.
fn best_of_3(mut run: impl FnMut() -> usize) -> (f64, usize) {
    (0..3).fold((f64::INFINITY, 0), |(best, _), _| {
        let t = Instant::now();
        let count = run();
        (best.min(t.elapsed().as_secs_f64()), count)
    })
}

fn main() {
    let sizes: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let sizes = if sizes.is_empty() { vec![10_000, 100_000] } else { sizes };
    println!("| points | read all s | points/s | tile 250 m s | in tile | inspect s |");
    println!("|---|---|---|---|---|---|");
    for n in sizes {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bench.gpkg");
        write_layer(&path, n);
        let source = CadastreSource::Path(&path);
        let (all_s, all) = best_of_3(|| read_cadastre(source, &spec(), Epsg(25832), None).unwrap().features.len());
        // A tile in the middle of the grid (about 566 km E, 5 935 km N in UTM 32).
        let tile = [565_000.0, 5_932_000.0, 565_250.0, 5_932_250.0];
        let (tile_s, in_tile) =
            best_of_3(|| read_cadastre(source, &spec(), Epsg(25832), Some(tile)).unwrap().features.len());
        let (inspect_s, _) = best_of_3(|| inspect_cadastre(source, None).unwrap().layers[0].feature_count);
        println!("| {n} | {all_s:.3} | {:.0} | {tile_s:.4} | {in_tile} | {inspect_s:.3} |", all as f64 / all_s);
    }
}
