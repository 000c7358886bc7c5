//! Keeps `schemas/observations.v1.schema.json` equal to the schema the observation types generate, and the
//! golden example parsing and valid.

use std::path::{Path, PathBuf};

use plumbline_adjustment::ObservationSet;

const UPDATE_ENV: &str = "PLUMBLINE_UPDATE_SCHEMAS";
const SCHEMA_FILE: &str = "observations.v1.schema.json";

fn schemas_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../schemas")
}

#[test]
fn observation_schema_is_current() {
    let schema = serde_json::to_value(schemars::schema_for!(ObservationSet)).expect("schema serialises");
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
         {UPDATE_ENV}=1 cargo test -p plumbline-adjustment --test schemas\n\nand commit the result"
    );
}

#[test]
fn golden_example_parses_and_has_no_problems() {
    let text = std::fs::read_to_string(schemas_dir().join("examples/observations.v1.example.json")).expect("example");
    let set = serde_json::from_str::<ObservationSet>(&text).expect("example parses").into_latest();
    assert_eq!((set.ties.len(), set.poles.len(), set.gnss.len()), (2, 1, 1));
    let problems: Vec<_> = set
        .ties
        .iter()
        .enumerate()
        .flat_map(|(i, t)| t.problems(i))
        .chain(set.poles.iter().enumerate().flat_map(|(i, p)| p.problems(i)))
        .chain(set.gnss.iter().enumerate().flat_map(|(i, g)| g.problems(i)))
        .collect();
    assert!(problems.is_empty(), "{problems:?}");
    // Round trip keeps the version tag.
    let again = serde_json::to_value(ObservationSet::V1(set)).expect("serialise");
    assert_eq!(again["version"], "1");
}
