//! Keeps `schemas/tile-result.v1.schema.json` equal to the schema the tile-result types generate, and the
//! golden example parsing with valid ties.

use std::path::{Path, PathBuf};

use plumbline_registration::TileResult;

const UPDATE_ENV: &str = "PLUMBLINE_UPDATE_SCHEMAS";
const SCHEMA_FILE: &str = "tile-result.v1.schema.json";

fn schemas_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../schemas")
}

#[test]
fn tile_result_schema_is_current() {
    let schema = serde_json::to_value(schemars::schema_for!(TileResult)).expect("schema serialises");
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
         {UPDATE_ENV}=1 cargo test -p plumbline-registration --test schemas\n\nand commit the result"
    );
}

#[test]
fn golden_example_parses_and_its_ties_have_no_problems() {
    let text = std::fs::read_to_string(schemas_dir().join("examples/tile-result.v1.json")).expect("example");
    let result = serde_json::from_str::<TileResult>(&text).expect("example parses").into_latest();
    assert_eq!((result.ties.len(), result.images.len()), (2, 2));
    assert_eq!(result.summary.images_matched, 1);
    let problems: Vec<_> = result.ties.iter().enumerate().flat_map(|(i, t)| t.problems(i)).collect();
    assert!(problems.is_empty(), "{problems:?}");
    assert!(result.images[1].discarded.as_ref().is_some_and(|d| d.key() == "aerial.too_few_plausible"));
    let again = serde_json::to_value(TileResult::V1(result)).expect("serialise");
    assert_eq!(again["version"], "1");
}
