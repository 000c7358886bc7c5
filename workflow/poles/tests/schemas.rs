//! Keeps `schemas/pole-frames.v1.schema.json` equal to the schema the frame-report types generate, and the
//! golden example parsing.

use std::path::{Path, PathBuf};

use plumbline_poles::FrameReport;

const UPDATE_ENV: &str = "PLUMBLINE_UPDATE_SCHEMAS";
const SCHEMA_FILE: &str = "pole-frames.v1.schema.json";

fn schemas_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../schemas")
}

#[test]
fn frame_report_schema_is_current() {
    let schema = serde_json::to_value(schemars::schema_for!(FrameReport)).expect("schema serialises");
    let generated = plumbline_campaign::canonical_json(&schema);
    let path = schemas_dir().join(SCHEMA_FILE);
    if std::env::var(UPDATE_ENV).is_ok_and(|v| v == "1") {
        std::fs::write(&path, &generated).expect("write schema");
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == generated,
        "schemas/{SCHEMA_FILE} is stale or missing; regenerate it with\n\n    \
         {UPDATE_ENV}=1 cargo test -p plumbline-poles --test schemas\n\nand commit the result"
    );
}

#[test]
fn golden_example_parses_and_keeps_its_version() {
    let text = std::fs::read_to_string(schemas_dir().join("examples/pole-frames.v1.example.json")).expect("example");
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
