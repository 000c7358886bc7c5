//! End-to-end test of `plumbline run` on the simulated `tiny` campaign: the corrected trajectory is much
//! closer to the truth than the DG one, every output is readable (the trajectory parsed back, the
//! GeoPackage opened through GDAL, the report's JSON), a corrupted panorama and a broken cadastre feature
//! are skipped and reported without sinking the campaign, and a re-run resumes from the finished tiles of the
//! same inputs and parameters only.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::path::Path;

use gdal::Dataset;
use gdal::vector::LayerAccess;
use plumbline_geo::formats;
use serde_json::Value;
use support::plumbline;

/// The cadastre id of the listed object nearest to (e, n), from `truth/poles.csv`.
fn nearest_cadastre_id(campaign: &Path, e: f64, n: f64) -> i64 {
    let text = std::fs::read_to_string(campaign.join("truth/poles.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (id, le, ln) = (col("cadastre_id"), col("listed_e"), col("listed_n"));
    lines
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| !f[id].is_empty())
        .min_by(|a, b| {
            let d = |f: &Vec<&str>| (f[le].parse::<f64>().unwrap() - e).hypot(f[ln].parse::<f64>().unwrap() - n);
            d(a).total_cmp(&d(b))
        })
        .map(|f| f[id].parse().unwrap())
        .unwrap()
}

/// Give one cadastre feature a class the manifest does not know.
fn break_cadastre_feature(gpkg: &Path, cadastre_id: i64) -> (String, i64) {
    let ds = Dataset::open_ex(
        gpkg,
        gdal::DatasetOptions { open_flags: gdal::GdalOpenFlags::GDAL_OF_UPDATE, ..Default::default() },
    )
    .unwrap();
    for layer in ["poles", "trees"] {
        let sql = format!("SELECT fid FROM {layer} WHERE id = {cadastre_id}");
        let found = ds.execute_sql(&sql, None, gdal::vector::sql::Dialect::SQLITE).unwrap();
        let fid = found.and_then(|mut l| l.features().next().and_then(|f| f.fid()));
        if let Some(fid) = fid {
            let update = format!("UPDATE {layer} SET class = 'banana' WHERE fid = {fid}");
            ds.execute_sql(&update, None, gdal::vector::sql::Dialect::SQLITE).unwrap();
            return (layer.to_owned(), fid as i64);
        }
    }
    panic!("cadastre id {cadastre_id} is in neither layer");
}

fn first_panorama(campaign: &Path) -> (String, f64, f64) {
    let text = std::fs::read_to_string(campaign.join("truth/images.csv")).unwrap();
    let row: Vec<&str> = text.lines().nth(10).unwrap().split(',').collect();
    (row[0].to_owned(), row[8].parse().unwrap(), row[9].parse().unwrap())
}

#[test]
fn run_corrects_tiny_writes_every_output_skips_broken_inputs_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let campaign = dir.path().join("tiny");
    let out = campaign.to_str().unwrap();
    plumbline(&["simulate", "--preset", "tiny", "--seed", "2", "--profile", "canyon", "--out", out]).run().success();

    // Deliberately broken inputs: one panorama overwritten with garbage, one cadastre feature with an
    // unknown class (both near the 11th panorama, so some tile reads them).
    let (pano, e, n) = first_panorama(&campaign);
    let pano_file = campaign.join(format!("panoramas/{pano}.jpg"));
    std::fs::write(&pano_file, b"this is not a JPEG").unwrap();
    let cadastre_id = nearest_cadastre_id(&campaign, e, n);
    let (layer, fid) = break_cadastre_feature(&campaign.join("cadastre/poles.gpkg"), cadastre_id);

    let manifest = campaign.join("campaign.toml");
    let run = plumbline(&["run", "--quiet", manifest.to_str().unwrap()]).run();
    run.success();
    assert!(run.stdout.contains("report: "), "{}", run.stdout);

    // Accuracy: the report's before/after against the simulated truth.
    let results = campaign.join("results");
    let report: Value = serde_json::from_slice(&std::fs::read(results.join("report.json")).unwrap()).unwrap();
    let acc = &report["accuracy"];
    let (before, after) = (acc["before"]["rmse_2d"].as_f64().unwrap(), acc["after"]["rmse_2d"].as_f64().unwrap());
    let (cross_before, cross_after) =
        (acc["before"]["cross"]["p95"].as_f64().unwrap(), acc["after"]["cross"]["p95"].as_f64().unwrap());
    eprintln!("2D RMSE {before:.3} -> {after:.3} m; cross-track 95 % {cross_before:.3} -> {cross_after:.3} m");
    assert!(before > 0.3, "the canyon DG trajectory should be off by decimetres: {before}");
    assert!(after < before / 3.0, "2D RMSE {before:.3} -> {after:.3} m");
    assert!(cross_after < cross_before / 2.0, "cross-track 95 % {cross_before:.3} -> {cross_after:.3} m");
    assert!(report["summary"]["images_matched"].as_u64().unwrap() > 0);
    assert!(report["summary"]["pole_updates"].as_u64().unwrap() > 0);

    // The broken inputs are skipped and named.
    let skipped = report["skipped"].as_array().unwrap();
    let names = |needle: &str| skipped.iter().any(|s| s["detail"].as_str().unwrap_or("").contains(needle));
    assert!(names(&format!("{pano}.jpg")), "the corrupt panorama is not reported: {skipped:#?}");
    assert!(
        skipped.iter().any(|s| s["stage"] == "cadastre"
            && s["detail"].as_str().unwrap().contains(&format!("{fid}"))
            && s["detail"].as_str().unwrap().contains(&layer)),
        "the broken cadastre feature ({layer} fid {fid}) is not reported: {skipped:#?}"
    );

    // The corrected trajectory, as the input came (SBET + smrmsg), parses back at full rate.
    let dg = formats::parse_sbet(&std::fs::read(campaign.join("nav/dg.sbet")).unwrap(), "dg.sbet").unwrap();
    let corrected =
        formats::parse_sbet(&std::fs::read(results.join("trajectory.sbet")).unwrap(), "trajectory.sbet").unwrap();
    assert_eq!(corrected.len(), dg.len());
    let std = formats::parse_smrmsg(&std::fs::read(results.join("trajectory.smrmsg")).unwrap(), "smrmsg").unwrap();
    assert!(!std.is_empty());
    let corrections = std::fs::read_to_string(results.join("corrections.csv")).unwrap();
    assert_eq!(corrections.lines().count(), dg.len() + 1, "one correction row per record");

    // observations.gpkg through GDAL, in the campaign CRS.
    let gpkg = Dataset::open(results.join("observations.gpkg")).unwrap();
    let names: Vec<String> = gpkg.layers().map(|l| l.name()).collect();
    for expected in ["tie_points", "coordinate_updates", "panoramas"] {
        assert!(names.iter().any(|n| n == expected), "layer {expected} missing from {names:?}");
    }
    let ties = gpkg.layer_by_name("tie_points").unwrap();
    assert!(ties.feature_count() > 0);
    let epsg = ties.spatial_ref().unwrap().auth_code().unwrap();
    assert_eq!(epsg, 25832);
    check_road_lines(&campaign, &results, &gpkg);

    // The HTML report is self-contained: no network references.
    let html = std::fs::read_to_string(results.join("report.html")).unwrap();
    assert!(html.contains("<svg"), "plots are inline SVG");
    for remote in ["src=\"http", "href=\"http", "<link", "@import", "url(http"] {
        assert!(!html.contains(remote), "report.html loads something from the network ({remote})");
    }

    // A re-run resumes from the finished tiles and gives the same trajectory.
    let again = plumbline(&["run", "--quiet", manifest.to_str().unwrap()]).run();
    again.success();
    assert!(again.stdout.contains("reused from an earlier run"), "{}", again.stdout);
    let rerun = std::fs::read(results.join("trajectory.sbet")).unwrap();
    assert_eq!(formats::parse_sbet(&rerun, "trajectory.sbet").unwrap(), corrected);

    // Changed registration parameters: no tile is reused, every one is computed again; running the changed
    // manifest once more reuses them.
    let text = std::fs::read_to_string(&manifest).unwrap();
    assert!(!text.contains("[parameters"), "the simulated manifest sets no parameters");
    std::fs::write(&manifest, format!("{text}\n[parameters.registration]\nmin_correspondences = 12\n")).unwrap();
    let changed = plumbline(&["run", "--quiet", manifest.to_str().unwrap()]).run();
    changed.success();
    assert!(!changed.stdout.contains("reused from an earlier run"), "{}", changed.stdout);
    let same_again = plumbline(&["run", "--quiet", manifest.to_str().unwrap()]).run();
    same_again.success();
    assert!(same_again.stdout.contains("reused from an earlier run"), "{}", same_again.stdout);
}

/// The road lines: line strings in both layers, the corrected ones mostly on the simulated paint and more
/// often than the DG's, exported as GeoJSON on WGS 84.
fn check_road_lines(campaign: &Path, results: &Path, gpkg: &Dataset) {
    for name in ["road_lines", "road_lines_dg"] {
        let mut layer = gpkg.layer_by_name(name).unwrap();
        assert!(layer.feature_count() > 5, "layer {name} has {} lines", layer.feature_count());
        let f = layer.features().next().unwrap();
        assert_eq!(f.geometry().unwrap().geometry_name(), "LINESTRING");
    }
    let observations = results.join("observations.gpkg");
    let truth = campaign.join("truth/road_markings.csv");
    let cmp = plumbline(&["lines", "compare", "--json", observations.to_str().unwrap(), truth.to_str().unwrap()]).run();
    cmp.success();
    let scores: Value = serde_json::from_str(&cmp.stdout).unwrap();
    let share = |layer: &str, part: &str, whole: &str| {
        scores[layer][part].as_f64().unwrap() / scores[layer][whole].as_f64().unwrap()
    };
    let (correct, correct_dg) = (
        share("road_lines", "correct_length_m", "extracted_length_m"),
        share("road_lines_dg", "correct_length_m", "extracted_length_m"),
    );
    let (recovered, within) = (
        share("road_lines", "recovered_length_m", "truth_length_m"),
        share("road_lines", "vertices_within", "vertices"),
    );
    eprintln!(
        "road lines: correct {correct:.3} (DG {correct_dg:.3}), recovered {recovered:.3}, within 5 cm {within:.3}"
    );
    // Seed 2's DG is off by 0.49 m RMSE: its lines are less often on the paint (0.88 of their length here).
    assert!(correct > 0.9 && correct > correct_dg, "correct {correct:.3}, DG {correct_dg:.3}");
    assert!(recovered > 0.3 && within > 0.6, "recovered {recovered:.3}, within 5 cm {within:.3}");
    // Per kind of the reference's markings: the kinds' lengths add up to the whole, and so do the
    // recovered lengths at most (a piece near two kinds counts for both).
    let kinds = scores["road_lines"]["by_kind"].as_array().unwrap();
    let sum = |key: &str| kinds.iter().map(|k| k[key].as_f64().unwrap()).sum::<f64>();
    let whole = scores["road_lines"]["truth_length_m"].as_f64().unwrap();
    assert!((sum("truth_length_m") - whole).abs() < 1e-6 * whole, "{kinds:?} against {whole}");
    assert!(sum("recovered_length_m") >= scores["road_lines"]["recovered_length_m"].as_f64().unwrap() - 1e-6);
    assert!(
        kinds.iter().any(|k| k["kind"] == "solid") && kinds.iter().all(|k| k["truth_length_m"].as_f64() > Some(0.0))
    );

    // Per marking: each once, their lengths adding up to the whole, most of the found ones within 5 cm.
    let markings = scores["road_lines"]["markings"].as_array().unwrap();
    let ids: std::collections::HashSet<&str> = markings.iter().map(|m| m["id"].as_str().unwrap()).collect();
    assert!(markings.len() > 10 && ids.len() == markings.len(), "{} markings, {} ids", markings.len(), ids.len());
    let length: f64 = markings.iter().map(|m| m["length_m"].as_f64().unwrap()).sum();
    assert!((length - whole).abs() < 1e-6 * whole, "{length} m of markings against {whole} m");
    let found: Vec<f64> = markings
        .iter()
        .filter(|m| m["recovered_length_m"].as_f64().unwrap() >= 0.5 * m["length_m"].as_f64().unwrap())
        .map(|m| m["deviation_median_m"].as_f64().unwrap())
        .collect();
    let close = found.iter().filter(|&&d| d <= 0.05).count();
    assert!(found.len() > 5 && 2 * close > found.len(), "{close} of {} found markings within 5 cm", found.len());

    // Every registered panorama is counted: with strokes, or skipped without (no paint kept in its patch).
    let report: Value = serde_json::from_slice(&std::fs::read(results.join("report.json")).unwrap()).unwrap();
    let (panoramas, summary) = (&report["road_line_panoramas"], &report["summary"]);
    let count = |key: &str| panoramas[key].as_u64().unwrap_or_else(|| panic!("{key} in {panoramas}"));
    let registered = count("with_strokes") + count("without_strokes") + count("unplaced");
    let planned = |key: &str| summary[key].as_u64().unwrap();
    assert!(count("with_strokes") > 5 && count("without_strokes") > 0, "{panoramas}");
    assert!((planned("images_matched")..=planned("images")).contains(&registered), "{panoramas} of {summary}");

    let geojson = results.join("road_lines.geojson");
    let export = ["lines", "export", "--format", "geojson", observations.to_str().unwrap(), "--out"];
    plumbline(&[&export[..], &[geojson.to_str().unwrap()]].concat()).run().success();
    let doc: Value = serde_json::from_slice(&std::fs::read(&geojson).unwrap()).unwrap();
    let features = doc["features"].as_array().unwrap();
    assert_eq!(features.len() as u64, gpkg.layer_by_name("road_lines").unwrap().feature_count());
    let [lon, lat] = [0, 1].map(|k| features[0]["geometry"]["coordinates"][0][k].as_f64().unwrap());
    assert!((5.0..15.0).contains(&lon) && (47.0..56.0).contains(&lat), "not WGS 84 in UTM 32N's zone: {lon}, {lat}");
    assert!(features[0]["properties"]["kind"].is_string());
}

#[test]
fn a_campaign_without_a_usable_trajectory_stops_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = support::write(
        &dir,
        "campaign.toml",
        "version = \"1\"\ncrs = 25832\noutput = \"results/\"\n[campaign]\nid = \"broken\"\nname = \"broken\"\n\
         [[trajectory]]\nformat = \"csv\"\nurl = \"missing.csv\"\n\
         [panoramas]\nindex = \"index.csv\"\nimages = \"p/\"\n[panoramas.mount]\nlever_arm_m = [0, 0, 0]\n\
         boresight_deg = [0, 0, 0]\n",
    );
    let run = plumbline(&["run", "--quiet", &manifest]).run();
    run.failure_with(2);
    assert!(run.stderr.contains("missing.csv"), "{}", run.stderr);
    assert!(!dir.path().join("results/tiles").exists(), "no tile may be processed");
}

/// Rows of a CSV file with a header, as numbers where they parse (NaN otherwise).
fn csv_rows(path: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines().skip(1).map(|l| l.split(',').map(|v| v.parse().unwrap_or(f64::NAN)).collect()).collect()
}

/// A campaign whose only pole sensor is the simulated roof laser scanner: `run` reads its strips (written as
/// COPC, read by octree node; then the same points as time-ordered LAZ), finds the stems per time slice and
/// every coordinate update it makes is of the right cadastre object, its observed position off the truth by
/// the DG error of its time only (within a few centimetres; trees lean).
#[test]
fn a_laser_scanner_cloud_alone_gives_correct_pole_control() {
    let dir = tempfile::tempdir().unwrap();
    let campaign = dir.path().join("mls");
    let out = campaign.to_str().unwrap();
    let args = ["--length", "200", "--panorama-width", "512", "--point-cloud", "copc", "--no-depth", "--out", out];
    plumbline(&[&["simulate", "--preset", "tiny", "--seed", "3", "--profile", "canyon"][..], &args].concat())
        .run()
        .success();
    let manifest = std::fs::read_to_string(campaign.join("campaign.toml")).unwrap();
    assert!(manifest.contains("[[point_clouds]]") && !manifest.contains("[[depth]]"), "{manifest}");
    assert!(manifest.contains("format = \"copc\"") && manifest.contains(".copc.laz"), "{manifest}");
    let run = plumbline(&["run", "--quiet", campaign.join("campaign.toml").to_str().unwrap()]).run();
    run.success();

    let results = campaign.join("results");
    let (timed, after) = check_cloud_control(&campaign, &results, true);
    eprintln!("{timed} pole updates from the COPC cloud's GPS times; 2D RMSE after {after:.3} m");
    check_not_seen(&campaign, &results);

    // The same points as LAZ strips in GPS-time order, streamed whole: the same control.
    let strips = |dir: &str, transform: &dyn Fn(&mut Vec<plumbline_poles::LasPoint>), wkt: Option<String>| {
        std::fs::create_dir_all(campaign.join(dir)).unwrap();
        for entry in std::fs::read_dir(campaign.join("lidar")).unwrap() {
            let path = entry.unwrap().path();
            let mut points = Vec::new();
            plumbline_poles::stream_las_points("strip", std::fs::read(&path).unwrap(), |b| points.extend_from_slice(b))
                .unwrap();
            points.sort_by(|a, b| a.gps_time.total_cmp(&b.gps_time));
            transform(&mut points);
            let encoding =
                plumbline_poles::LasEncoding { compressed: true, wkt: wkt.clone(), adjusted_standard_week: None };
            let laz = plumbline_poles::encode_las(&points, &encoding).unwrap();
            let name = path.file_name().unwrap().to_str().unwrap().replace(".copc.laz", ".laz");
            std::fs::write(campaign.join(dir).join(name), laz).unwrap();
        }
    };
    // The manifest naming the LAZ strips of `dir` instead, with its results in `output`; run.
    let run_laz = |dir: &str, output: &str| {
        let laz = manifest
            .replace("\"lidar/", &format!("\"{dir}/"))
            .replace(".copc.laz\"", ".laz\"")
            .replace("format = \"copc\"", "format = \"laz\"")
            .replace("output = \"results/\"", &format!("output = \"{output}/\""));
        let path = campaign.join(format!("{output}.toml"));
        std::fs::write(&path, laz).unwrap();
        plumbline(&["run", "--quiet", path.to_str().unwrap()]).run().success();
    };
    strips("lidar_laz", &|_| {}, Some(plumbline_runtime::crs::wkt_of_epsg(25832).unwrap()));
    run_laz("lidar_laz", "laz");
    let (n, after) = check_cloud_control(&campaign, &campaign.join("laz"), true);
    eprintln!("{n} pole updates from the same points as LAZ; 2D RMSE after {after:.3} m");
    assert_eq!(n, timed, "COPC read by node and LAZ read whole give the same updates");

    // The same clouds declared without GPS time: each stem takes the time the drive passed nearest to it.
    let untimed = manifest
        .replace("time = \"week_seconds\"", "time = \"none\"")
        .replace("output = \"results/\"", "output = \"untimed/\"");
    assert_ne!(untimed, manifest);
    std::fs::write(campaign.join("untimed.toml"), untimed).unwrap();
    plumbline(&["run", "--quiet", campaign.join("untimed.toml").to_str().unwrap()]).run().success();
    let (n, after) = check_cloud_control(&campaign, &campaign.join("untimed"), false);
    eprintln!("{n} pole updates by the nearest pass; 2D RMSE after {after:.3} m");

    // The same clouds in ETRS89 / UTM zone 33N (the campaign is in zone 32N), saying so in their WKT: the
    // run moves them into the campaign's CRS as it streams them.
    let to_33 = |points: &mut Vec<plumbline_poles::LasPoint>| {
        let (mut xs, mut ys): (Vec<f64>, Vec<f64>) = points.iter().map(|p| (p.position[0], p.position[1])).unzip();
        plumbline_runtime::CrsTransform::new(25832, 25833).unwrap().transform(&mut xs, &mut ys, &mut []).unwrap();
        for (p, (x, y)) in points.iter_mut().zip(xs.into_iter().zip(ys)) {
            (p.position[0], p.position[1]) = (x, y);
        }
    };
    strips("lidar33", &to_33, Some(plumbline_runtime::crs::wkt_of_epsg(25833).unwrap()));
    run_laz("lidar33", "utm33");
    let (n, after) = check_cloud_control(&campaign, &campaign.join("utm33"), true);
    eprintln!("{n} pole updates from clouds in EPSG:25833; 2D RMSE after {after:.3} m");
}

/// `cadastre_changes`' `not_seen` objects: none matched by any slice of the cloud, and every cadastre entry of
/// an object gone in reality (a ghost of the truth table) within 8 m of the scanner in a slice whose stems
/// matched is among them.
fn check_not_seen(campaign: &Path, results: &Path) {
    let (mut matched, mut covered) = (std::collections::HashSet::new(), Vec::new());
    for entry in std::fs::read_dir(results.join("tiles")).unwrap() {
        let tile: Value = serde_json::from_slice(&std::fs::read(entry.unwrap().path()).unwrap()).unwrap();
        for f in tile["pole_frames"].as_array().into_iter().flatten() {
            for m in f["matches"].as_array().into_iter().flatten() {
                matched.insert(m["cadastre_id"].as_str().unwrap().to_owned());
            }
            if !f["offset"].is_null() {
                let o = &f["view"]["origin"];
                covered.push([o[0].as_f64().unwrap(), o[1].as_f64().unwrap()]);
            }
        }
    }
    let gpkg = Dataset::open(results.join("observations.gpkg")).unwrap();
    let mut layer = gpkg.layer_by_name("cadastre_changes").unwrap();
    let (change, id) = (layer.defn().field_index("change").unwrap(), layer.defn().field_index("cadastre_id").unwrap());
    let not_seen: Vec<(String, f64, f64)> = layer
        .features()
        .filter(|f| f.field_as_string(change).unwrap().as_deref() == Some("not_seen"))
        .map(|f| {
            let (x, y, _) = f.geometry().unwrap().get_point(0);
            (f.field_as_string(id).unwrap().unwrap(), x, y)
        })
        .collect();
    for (id, ..) in &not_seen {
        assert!(!matched.contains(id), "{id} is listed as not seen but a slice matched it");
    }
    // Ghosts: cadastre entries of objects gone in reality (the truth's id, listed east and north).
    let truth = std::fs::read_to_string(campaign.join("truth/poles.csv")).unwrap();
    let ghosts: Vec<(String, f64, f64)> = truth
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[8] == "gone_in_reality")
        .map(|c| (c[1].to_owned(), c[6].parse().unwrap(), c[7].parse().unwrap()))
        .collect();
    let near: Vec<&(String, f64, f64)> =
        ghosts.iter().filter(|g| covered.iter().any(|o| (o[0] - g.1).hypot(o[1] - g.2) <= 8.0)).collect();
    for g in &near {
        assert!(not_seen.iter().any(|n| (n.1 - g.1).hypot(n.2 - g.2) < 0.01), "ghost {g:?} not listed: {not_seen:?}");
    }
    eprintln!(
        "{} not seen, {} of {} ghosts within 8 m of a matched slice among them",
        not_seen.len(),
        near.len(),
        ghosts.len()
    );
}

/// The pole updates of a run's tiles are from the cloud and each of the right cadastre object: its observed
/// position less the DG error at its time within 0.15 m of the truth — or, with `timed` false (a cloud
/// without GPS time, whose stems may have been scanned on another pass than the time they are given), less
/// the DG error at some time of the drive. Returns their count and the 2D RMSE after the adjustment (which
/// must beat the DG trajectory's).
fn check_cloud_control(campaign: &Path, results: &Path, timed: bool) -> (usize, f64) {
    let mut updates = Vec::new();
    let (mut cloud_frames, mut stems) = (0, 0);
    for entry in std::fs::read_dir(results.join("tiles")).unwrap() {
        let tile: Value = serde_json::from_slice(&std::fs::read(entry.unwrap().path()).unwrap()).unwrap();
        updates.extend(tile["poles"].as_array().cloned().unwrap_or_default());
        let frames = tile["pole_frames"].as_array().cloned().unwrap_or_default();
        let clouds: Vec<&Value> =
            frames.iter().filter(|f| f["frame"].as_str().unwrap().starts_with("point_clouds[")).collect();
        cloud_frames += clouds.len();
        stems += clouds.iter().map(|f| f["detections"].as_array().map_or(0, Vec::len)).sum::<usize>();
    }
    assert!(cloud_frames > 0, "no time slice of the cloud was searched");
    // The inventory: every stem of the clouds in `detected_poles`, at its corrected position.
    let gpkg = Dataset::open(results.join("observations.gpkg")).unwrap();
    let detected = gpkg.layer_by_name("detected_poles").unwrap().feature_count();
    assert_eq!(detected as usize, stems, "one feature per stem");
    assert!(gpkg.layer_by_name("cadastre_changes").is_ok());
    assert!(updates.len() >= 5, "{} pole updates from the cloud", updates.len());

    // Truth: DG error per epoch (time, east, north) and the poles (true and listed positions).
    let dg_errors = csv_rows(&campaign.join("truth/dg_errors.csv"));
    let poles: Vec<Vec<f64>> =
        csv_rows(&campaign.join("truth/poles.csv")).into_iter().filter(|p| p[6].is_finite()).collect();
    let mut other_time = 0;
    for u in &updates {
        let (t, cadastre, observed) = (u["time"].as_f64().unwrap(), &u["cadastre"], &u["observed"]);
        let (ce, cn) = (cadastre[0].as_f64().unwrap(), cadastre[1].as_f64().unwrap());
        let listed = poles.iter().min_by(|a, b| (a[6] - ce).hypot(a[7] - cn).total_cmp(&(b[6] - ce).hypot(b[7] - cn)));
        let pole = listed.unwrap();
        let (oe, on) = (observed[0].as_f64().unwrap(), observed[1].as_f64().unwrap());
        let off_at = |r: &Vec<f64>| (oe - r[1] - pole[4]).hypot(on - r[2] - pole[5]);
        let own = off_at(&dg_errors[dg_errors.partition_point(|r| r[0] < t).min(dg_errors.len() - 1)]);
        let off = if timed { own } else { dg_errors.iter().map(off_at).fold(own, f64::min) };
        assert!(off < 0.15, "update {u}: the observed position less the DG error is {off:.3} m off the pole it names");
        other_time += usize::from(own >= 0.15);
    }
    if !timed {
        eprintln!("{other_time} of {} updates were scanned at another time than they are given", updates.len());
    }
    let report: Value = serde_json::from_slice(&std::fs::read(results.join("report.json")).unwrap()).unwrap();
    let acc = &report["accuracy"];
    let (before, after) = (acc["before"]["rmse_2d"].as_f64().unwrap(), acc["after"]["rmse_2d"].as_f64().unwrap());
    assert!(after < before, "2D RMSE {before:.3} -> {after:.3} m");
    (updates.len(), after)
}
