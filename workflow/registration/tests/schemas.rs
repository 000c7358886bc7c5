//! Keeps `schemas/tile-result.v1.schema.json` equal to the schema the tile-result types generate, and the
//! golden example parsing with valid ties.

use plumbline_registration::TileResult;

const SCHEMA_FILE: &str = "tile-result.v1.schema.json";

#[test]
fn tile_result_schema_is_current() {
    let schema = serde_json::to_value(schemars::schema_for!(TileResult)).expect("schema serialises");
    plumbline_testkit::schemas::assert_current(SCHEMA_FILE, &schema, "plumbline-registration");
}

#[test]
fn golden_example_parses_and_its_ties_have_no_problems() {
    let text = plumbline_testkit::schemas::example("tile-result.v1.json");
    let result = serde_json::from_str::<TileResult>(&text).expect("example parses").into_latest();
    assert_eq!((result.ties.len(), result.images.len()), (2, 2));
    assert_eq!(result.summary.images_matched, 1);
    let problems: Vec<_> = result.ties.iter().enumerate().flat_map(|(i, t)| t.problems(i)).collect();
    assert!(problems.is_empty(), "{problems:?}");
    assert!(result.images[1].discarded.as_ref().is_some_and(|d| d.key() == "aerial.too_few_plausible"));
    // The frames of the aerial tie are recorded with the panorama that produced it; older results have none.
    let recorded = &result.images[0].aerial_frames;
    assert_eq!((recorded.len(), recorded[0].tie.as_str()), (1, result.ties[0].id.0.as_str()));
    assert_eq!(recorded[0].frames, ["aerial0024", "aerial0025"]);
    assert!(result.images[1].aerial_frames.is_empty());
    let again = serde_json::to_value(TileResult::V1(result)).expect("serialise");
    assert_eq!(again["version"], "1");
}
