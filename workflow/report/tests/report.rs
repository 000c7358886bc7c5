//! The report's JSON round trip and schema, and the HTML page being self-contained and showing the figures.

use plumbline_geo::metrics::Stats;
use plumbline_report::{
    Accuracy, CampaignInfo, CorrectionSeries, Figures, MapData, MapMark, MarkState, Report, ReportDoc, Residuals,
    SkippedItem, Summary, TrackPoint, html,
};

fn stats(median: f64) -> Stats {
    Stats { count: 100, median, p95: 2.0 * median, p99: 3.0 * median, max: 4.0 * median, rms: 1.5 * median }
}

fn figures(median: f64) -> Figures {
    Figures { along: stats(median), cross: stats(median), height: stats(median), rmse_2d: median, rmse_3d: median }
}

fn sample() -> Report {
    let time: Vec<f64> = (0..50).map(f64::from).collect();
    Report {
        campaign: CampaignInfo {
            id: "hh-2024".into(),
            name: "Hamburg <north>".into(),
            crs: 25832,
            generated_by: "plumbline test".into(),
        },
        summary: Summary { epochs: 50, images: 10, images_matched: 4, ties: 120, ..Summary::default() },
        accuracy: Some(Accuracy { reference: "truth.csv".into(), before: figures(0.731), after: figures(0.0421) }),
        correction: CorrectionSeries {
            east: time.iter().map(|t| (t * 0.1).sin()).collect(),
            north: time.iter().map(|t| (t * 0.1).cos()).collect(),
            up: vec![0.0; 50],
            sigma_horizontal: vec![0.02; 50],
            time,
        },
        cross_track: None,
        map: MapData {
            track: (0..20).map(|i| TrackPoint { e: f64::from(i), n: 0.0, correction: f64::from(i) / 20.0 }).collect(),
            images: vec![MapMark { id: "pano1".into(), e: 1.0, n: 0.5, state: MarkState::Used }],
            poles: vec![MapMark { id: "pole7".into(), e: 3.0, n: -1.0, state: MarkState::Unused }],
        },
        residuals: vec![Residuals { kind: "pole".into(), normalised: vec![-1.0, 0.2, 0.5, 2.5] }],
        skipped: vec![
            SkippedItem {
                stage: "registration".into(),
                item: "pano7.jpg".into(),
                reason: "decode".into(),
                detail: "not a JPEG <broken>".into(),
            },
            SkippedItem {
                stage: "registration".into(),
                item: "pano8.jpg".into(),
                reason: "decode".into(),
                detail: "truncated".into(),
            },
        ],
        ..Report::default()
    }
}

#[test]
fn json_round_trips_with_its_version() {
    let report = sample();
    let json = report.to_json();
    let value: serde_json::Value = serde_json::from_slice(&json).unwrap();
    assert_eq!(value["version"], "1");
    let ReportDoc::V1(back) = serde_json::from_slice::<ReportDoc>(&json).unwrap();
    assert_eq!(back, report);
}

#[test]
fn html_is_self_contained_and_shows_the_figures() {
    let page = html::render(&sample());
    assert!(page.starts_with("<!DOCTYPE html>") && page.trim_end().ends_with("</html>"));
    for forbidden in ["<script", "src=", "href=", "https://", "@import", "url("] {
        assert!(!page.contains(forbidden), "page contains {forbidden}");
    }
    // The only http:// is the SVG namespace, one per plot.
    assert_eq!(page.matches("http://").count(), page.matches("xmlns=\"http://www.w3.org/2000/svg\"").count());
    assert!(page.contains("Hamburg &lt;north&gt;"), "names are escaped");
    assert!(page.contains("<td>0.731</td>") && page.contains("<td>0.042</td>"), "before/after medians");
    assert!(page.contains("4 / 10 (40 %)"));
    assert!(page.contains("<td>registration</td><td>decode</td><td>2</td>"), "skips counted by reason");
    assert!(page.contains("not a JPEG &lt;broken&gt;"));
}

#[test]
fn report_schema_is_current() {
    let schema = plumbline_report::report_schema();
    plumbline_testkit::schemas::assert_current(plumbline_report::REPORT_SCHEMA_FILE, &schema, "plumbline-report");
}
