//! Keeps `schemas/pole-frames.v1.schema.json` equal to the schema the frame-report types generate, and the
//! golden example parsing.

use plumbline_poles::FrameReport;

const SCHEMA_FILE: &str = "pole-frames.v1.schema.json";

#[test]
fn frame_report_schema_is_current() {
    let schema = serde_json::to_value(schemars::schema_for!(FrameReport)).expect("schema serialises");
    plumbline_testkit::schemas::assert_current(SCHEMA_FILE, &schema, "plumbline-poles");
}

#[test]
fn golden_example_parses_and_keeps_its_version() {
    let text = plumbline_testkit::schemas::example("pole-frames.v1.example.json");
    let reports: Vec<FrameReport> = serde_json::from_str(&text).expect("example parses");
    assert_eq!(reports.len(), 2);
    let FrameReport::V1(ok) = &reports[0];
    assert_eq!((ok.detections.len(), ok.matches.len(), ok.unmatched.len(), ok.unseen.len()), (2, 1, 1, 1));
    assert!(ok.matches[0].detection < ok.detections.len() && ok.problem.is_none());
    let FrameReport::V1(failed) = &reports[1];
    assert!(failed.problem.is_some() && failed.detections.is_empty());
    let again = serde_json::to_value(&reports[0]).expect("serialise");
    assert_eq!(again["version"], "1");
    assert!(serde_json::from_str::<FrameReport>(r#"{"version":"9"}"#).is_err());
}
