#![allow(clippy::unwrap_used)]
//! `finish` end to end into a temporary directory: every output file is written and reads back — the
//! GeoPackage through GDAL (layers, feature counts, CRS), the corrected trajectory through
//! `plumbline_geo::formats`, `corrections.csv`, and `report.json` as the report schema with the before/after
//! figures of `metrics::compare`.

use plumbline_fixtures::adjuster;

use std::sync::Mutex;

use gdal::Dataset;
use gdal::vector::LayerAccess;
use plumbline_adjuster::{AdjusterConfig, LAYERS, LINE_LAYERS, finish};
use plumbline_campaign::Stage;
use plumbline_campaign::progress::Progress;
use plumbline_geo::formats::{AttitudeConvention, parse_csv};
use plumbline_geo::metrics::compare;
use plumbline_report::{Figures, ReportDoc};
use plumbline_runtime::Files;

/// Records every progress call.
#[derive(Debug, Default)]
struct Recorder(Mutex<Vec<String>>);

impl Progress for Recorder {
    fn begin(&self, stage: Stage, total: Option<u64>) {
        self.0.lock().unwrap().push(format!("begin {stage} {total:?}"));
    }
    fn advance(&self, stage: Stage, n: u64) {
        self.0.lock().unwrap().push(format!("advance {stage} {n}"));
    }
    fn skip(&self, stage: Stage, n: u64) {
        self.0.lock().unwrap().push(format!("skip {stage} {n}"));
    }
    fn note(&self, stage: Stage, text: &str) {
        self.0.lock().unwrap().push(format!("note {stage} {text}"));
    }
    fn end(&self, stage: Stage) {
        self.0.lock().unwrap().push(format!("end {stage}"));
    }
}

fn assert_figures_eq(got: &Figures, want: &Figures, what: &str) {
    let pairs = [
        (got.rmse_2d, want.rmse_2d),
        (got.rmse_3d, want.rmse_3d),
        (got.cross.p95, want.cross.p95),
        (got.cross.max, want.cross.max),
        (got.along.p99, want.along.p99),
        (got.height.median, want.height.median),
    ];
    for (a, b) in pairs {
        assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0), "{what}: {got:?} vs {want:?}");
    }
    assert_eq!(got.cross.count, want.cross.count, "{what}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn finish_writes_every_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = format!("{}/", dir.path().display());
    let s = adjuster::scenario(2);
    let mut poles = s.poles.clone();
    let wrong = adjuster::best_light(&poles);
    poles[wrong].cadastre[0] += 0.6;
    poles[wrong].cadastre[1] += 0.8;
    let tiles = adjuster::tiles(&s, &poles);
    let campaign = adjuster::campaign(&s, &out);
    let progress = Recorder::default();
    let done = finish(&Files::default(), &campaign, &tiles, &AdjusterConfig::default(), &progress).await.unwrap();

    let names = ["trajectory.csv", "corrections.csv", "observations.gpkg", "report.json", "report.html"];
    let want: Vec<String> = names.iter().map(|n| format!("{out}{n}")).collect();
    assert_eq!(done.written, want);
    let calls = progress.0.lock().unwrap().clone();
    assert_eq!(calls.first().map(String::as_str), Some("begin adjustment None"));
    assert_eq!(calls.last().map(String::as_str), Some("end adjustment"));
    assert!(calls.iter().any(|c| c.starts_with("note adjustment") && c.contains("σ0")), "{calls:?}");
    // Every Gauss–Newton/LM iteration shows as it ends: one advance and a note each, numbered in order.
    let advances = calls.iter().filter(|c| *c == "advance adjustment 1").count();
    let notes: Vec<&String> = calls.iter().filter(|c| c.starts_with("note adjustment iteration ")).collect();
    let summary = calls.iter().rev().find_map(|c| c.strip_prefix("note adjustment ")?.split_once(" iterations, "));
    let total: usize = summary.and_then(|(n, _)| n.parse().ok()).unwrap_or(0);
    assert!(total >= 2 && advances == total && notes.len() == total, "{calls:?}");
    assert!(notes.iter().enumerate().all(|(i, n)| n.starts_with(&format!("note adjustment iteration {}: σ0 ", i + 1))));
    assert!(notes.iter().all(|n| n.ends_with(" rejected")), "{notes:?}");

    // The corrected trajectory parses back with one record per DG record.
    let bytes = std::fs::read(dir.path().join("trajectory.csv")).unwrap();
    let parsed = parse_csv(&bytes, "trajectory.csv", AttitudeConvention::Applanix).unwrap();
    assert_eq!(parsed.trajectory.records.len(), s.dg.len());
    let csv = std::fs::read_to_string(dir.path().join("corrections.csv")).unwrap();
    assert_eq!(csv.lines().count(), s.dg.len() + 1);
    assert!(csv.starts_with("time_s,d_east_m,"));
    // Each row is the correction that record got: corrected − DG.
    let corrected = parsed_trajectory(&bytes);
    for k in [0, s.dg.len() / 3, s.dg.len() - 1] {
        let row: Vec<f64> = csv.lines().nth(k + 1).unwrap().split(',').map(|v| v.parse().unwrap()).collect();
        let (a, b) = (&s.dg.records()[k], &corrected.records()[k]);
        let d = b.position - a.position;
        assert_eq!(row[0], a.time);
        for (got, want) in row[1..4].iter().zip([d.x(), d.y(), d.z()]) {
            assert!((got - want).abs() < 1e-6, "record {k}: {row:?} vs {d:?}");
        }
        assert!(row[7] > 0.0 && row[7] < 0.5, "record {k}: σ east {}", row[7]);
    }

    // report.json is a version-1 report whose figures are metrics::compare's.
    let json = std::fs::read(dir.path().join("report.json")).unwrap();
    let ReportDoc::V1(report) = serde_json::from_slice::<ReportDoc>(&json).unwrap();
    assert_eq!(report, done.report);
    let accuracy = report.accuracy.as_ref().unwrap();
    let before = Figures::from(&compare(&s.dg, &s.truth).unwrap());
    assert_figures_eq(&accuracy.before, &before, "before");
    let after = Figures::from(&compare(&corrected, &s.truth).unwrap());
    assert_figures_eq(&accuracy.after, &after, "after");
    assert_eq!(done.before, Some(accuracy.before));
    assert!(after.rmse_2d < before.rmse_2d / 4.0);
    let html = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("adjuster-test") && !html.contains("<script"));

    check_geopackage(&dir.path().join("observations.gpkg"), &tiles, &done.report, &campaign);
}

/// The written CSV as a trajectory in the campaign CRS (projected, so no reprojection).
fn parsed_trajectory(bytes: &[u8]) -> plumbline_geo::Trajectory {
    let raw = parse_csv(bytes, "trajectory.csv", AttitudeConvention::Applanix).unwrap().trajectory;
    let records = raw.into_map(|_, _, _| Err::<plumbline_geo::formats::MapPoint, ()>(())).unwrap();
    plumbline_geo::Trajectory::new(records, &plumbline_geo::ValidationLimits { max_speed: f64::INFINITY }).unwrap()
}

fn check_geopackage(
    path: &std::path::Path,
    tiles: &[plumbline_worker::TileOutputV1],
    report: &plumbline_report::Report,
    campaign: &plumbline_campaign::Campaign,
) {
    let ds = Dataset::open(path).unwrap();
    let mut names: Vec<String> = ds.layers().map(|l| l.name()).collect();
    names.sort();
    let mut want: Vec<String> = LAYERS.iter().chain(&LINE_LAYERS).map(|s| (*s).to_owned()).collect();
    want.sort();
    assert_eq!(names, want);
    let ties: usize = tiles.iter().map(|t| t.registration.as_ref().unwrap().ties.len()).sum();
    let poles: usize = tiles.iter().map(|t| t.poles.len()).sum();
    let counts = [
        ("tie_points", ties),
        ("pole_detections", 0),
        ("pole_matches", 0),
        ("coordinate_updates", poles),
        ("rejected_observations", report.rejected.len()),
        ("flagged_epochs", report.flags.len()),
        ("panoramas", campaign.plan.panoramas.len()),
    ];
    for (name, count) in counts {
        let mut layer = ds.layer_by_name(name).unwrap();
        assert_eq!(layer.feature_count() as usize, count, "layer {name}");
        let srs = layer.spatial_ref().unwrap();
        assert_eq!(srs.auth_code().unwrap(), adjuster::EPSG as i32, "layer {name}");
        if count > 0 {
            assert!(layer.features().next().is_some());
        }
    }
    assert!(report.rejected.iter().any(|r| r.kind == "pole"), "{:?}", report.rejected);
    assert!(!report.flags.is_empty());
}
