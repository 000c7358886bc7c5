//! The report's JSON round trip and schema, and the HTML page being self-contained and showing the figures.

use plumbline_campaign::{SkipReason, SkippedInput, Stage};
use plumbline_geo::metrics::Stats;
use plumbline_report::{
    Accuracy, CampaignInfo, CorrectionSeries, Figures, HeightBiasLine, MapData, MapLine, MapMark, MarkState,
    RejectedObservation, Report, ReportDoc, Residuals, RoadLineKind, RoadLinePanoramas, Summary, TrackPoint, html,
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
            lines: Vec::new(),
        },
        residuals: vec![Residuals { kind: "pole".into(), normalised: vec![-1.0, 0.2, 0.5, 2.5] }],
        skipped: vec![
            SkippedInput::new(Stage::Registration, "pano7.jpg", SkipReason::Decode, "not a JPEG <broken>"),
            SkippedInput::new(Stage::Registration, "pano8.jpg", SkipReason::Decode, "truncated"),
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

fn with_height_biases() -> Report {
    let bias = |frames: &[&str], points, bias_m, sigma_m| HeightBiasLine {
        frames: frames.iter().map(|f| (*f).to_owned()).collect(),
        points,
        bias_m,
        sigma_m,
        prior_sigma_m: 0.61,
    };
    Report {
        height_biases: vec![bias(&["a01", "a02"], 37, 0.4376, 0.0212), bias(&["a02", "<a03>"], 5, -0.0624, 0.118)],
        ..sample()
    }
}

#[test]
fn height_biases_are_in_the_json_and_in_a_table_of_the_page() {
    let report = with_height_biases();
    let value: serde_json::Value = serde_json::from_slice(&report.to_json()).unwrap();
    let sets = value["height_biases"].as_array().unwrap();
    assert_eq!(sets.len(), 2);
    assert_eq!(sets[0]["frames"], serde_json::json!(["a01", "a02"]));
    assert_eq!((sets[0]["points"].as_u64(), sets[0]["bias_m"].as_f64()), (Some(37), Some(0.4376)));
    assert_eq!((sets[1]["sigma_m"].as_f64(), sets[1]["prior_sigma_m"].as_f64()), (Some(0.118), Some(0.61)));
    let page = html::render(&report);
    assert!(page.contains("<h2>Aerial height biases</h2>"));
    assert!(
        page.contains("<tr><td>a01 + a02</td><td>+0.438</td><td>0.021</td><td>0.610</td><td>37</td></tr>"),
        "{page}"
    );
    assert!(page.contains("<tr><td>a02 + &lt;a03&gt;</td><td>-0.062</td><td>0.118</td><td>0.610</td><td>5</td></tr>"));
    assert!(!html::render(&sample()).contains("height biases"), "no table without biases");
}

#[test]
fn road_lines_are_drawn_on_the_map_and_tabled_by_kind() {
    let report = Report {
        map: MapData {
            lines: vec![
                MapLine { kind: "dashed".into(), points: vec![[2.0, 0.0], [9.0, 0.5]] },
                MapLine { kind: "<solid>".into(), points: vec![[1.0, 1.0], [5.0, 1.0], [8.0, 1.2]] },
            ],
            ..sample().map
        },
        road_lines: vec![RoadLineKind { kind: "dashed".into(), lines: 1, length_m: 7.02, median_sigma_m: 0.0123 }],
        road_line_panoramas: Some(RoadLinePanoramas { with_strokes: 40, without_strokes: 12, unplaced: 1 }),
        ..sample()
    };
    let ReportDoc::V1(back) = serde_json::from_slice::<ReportDoc>(&report.to_json()).unwrap();
    assert_eq!(back, report);
    let page = html::render(&report);
    let drawn = "fill=\"none\" stroke=\"#333\"";
    assert_eq!(page.matches(drawn).count(), 2, "one polyline per line");
    assert_eq!(page.matches("stroke-dasharray").count(), 1, "the dashed line is drawn dashed");
    assert!(page.contains("&lt;solid&gt;"), "kinds are escaped");
    assert!(page.contains("<tr><td>dashed</td><td>1</td><td>7.0</td><td>0.012</td></tr>"), "{page}");
    assert!(page.contains("Strokes from 40 panorama(s); skipped: 12 registered panorama(s)"), "{page}");
    assert!(page.contains(", 1 whose strokes could not be placed"), "{page}");
    let plain = html::render(&sample());
    assert!(!plain.contains(drawn) && !plain.contains("Road lines"), "nothing without lines");
}

/// Two rejections by the test and one tie point left undetermined by the first: counted apart on the card,
/// the table names the ray, and a report without `follows` (written before it existed) still parses.
#[test]
fn undetermined_ties_are_told_apart_from_tested_rejections() {
    let rejected = |id: &str, follows: Option<&str>| RejectedObservation {
        kind: "tie".into(),
        id: id.into(),
        time: 12.0,
        w_test: 8.5,
        follows: follows.map(str::to_owned),
    };
    let report = Report {
        rejected: vec![
            rejected("p1:7.rays[1]", None),
            rejected("p1:7", Some("p1:7.rays[1]")),
            rejected("p2:3.aerial", None),
        ],
        ..sample()
    };
    assert_eq!(report.rejected_by_test(), 2);
    let page = html::render(&report);
    assert!(page.contains("<b>2 (+1 tie points left undetermined)</b>"), "card");
    assert!(page.contains("<td>p1:7</td><td>12.000</td><td>8.50</td><td>p1:7.rays[1]</td>"));
    assert!(page.contains("<td>p2:3.aerial</td><td>12.000</td><td>8.50</td><td></td>"));
    let mut value: serde_json::Value = serde_json::from_slice(&report.to_json()).unwrap();
    assert_eq!(value["rejected"][1]["follows"], "p1:7.rays[1]");
    assert!(value["rejected"][0].get("follows").is_none(), "absent unless it follows another");
    value["rejected"][1].as_object_mut().unwrap().remove("follows");
    let ReportDoc::V1(back) = serde_json::from_value::<ReportDoc>(value).unwrap();
    assert_eq!((back.rejected[1].follows.as_deref(), back.rejected_by_test()), (None, 3));
}

#[test]
fn a_report_written_before_height_biases_still_parses() {
    let report = with_height_biases();
    let mut value: serde_json::Value = serde_json::from_slice(&report.to_json()).unwrap();
    value.as_object_mut().unwrap().remove("height_biases");
    let ReportDoc::V1(back) = serde_json::from_value::<ReportDoc>(value).unwrap();
    assert_eq!(back, Report { height_biases: Vec::new(), ..report });
    let without: serde_json::Value = serde_json::from_slice(&sample().to_json()).unwrap();
    assert!(without.get("height_biases").is_none(), "an empty list is left out, as before");
}

#[test]
fn report_schema_is_current() {
    let schema = plumbline_report::report_schema();
    plumbline_testkit::schemas::assert_current(plumbline_report::REPORT_SCHEMA_FILE, &schema, "plumbline-report");
}

#[test]
fn inputs_that_gave_no_control_lead_the_page_and_are_in_the_json() {
    let warning = plumbline_report::InputWarning {
        input: "cadastres[0]".into(),
        location: "cadastre/<poles>.gpkg".into(),
        message: "0 pole updates from 2 layer(s)".into(),
    };
    let report = Report { warnings: vec![warning.clone()], ..sample() };
    let page = html::render(&report);
    let heading = page.find("Inputs that gave no control").expect("a warnings section");
    assert!(heading < page.find("Summary").unwrap_or(usize::MAX), "before everything else");
    assert!(page.contains("cadastre/&lt;poles&gt;.gpkg"), "escaped");
    let ReportDoc::V1(back) = serde_json::from_slice::<ReportDoc>(&report.to_json()).unwrap();
    assert_eq!(back.warnings, [warning]);
    assert!(!html::render(&sample()).contains("gave no control"), "no section when every input contributed");
}
