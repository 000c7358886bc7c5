//! Keeps `schemas/observations.v1.schema.json` equal to the schema the observation types generate, and the
//! golden example parsing and valid.

use plumbline_adjustment::ObservationSet;

const SCHEMA_FILE: &str = "observations.v1.schema.json";

#[test]
fn observation_schema_is_current() {
    let schema = serde_json::to_value(schemars::schema_for!(ObservationSet)).expect("schema serialises");
    plumbline_testkit::schemas::assert_current(SCHEMA_FILE, &schema, "plumbline-adjustment");
}

#[test]
fn golden_example_parses_and_has_no_problems() {
    let text = plumbline_testkit::schemas::example("observations.v1.example.json");
    let set = serde_json::from_str::<ObservationSet>(&text).expect("example parses").into_latest();
    assert_eq!((set.ties.len(), set.poles.len(), set.gnss.len(), set.aerial_frame_sets.len()), (2, 1, 1, 1));
    let listed = &set.aerial_frame_sets[0].ties;
    assert!(listed.iter().all(|id| set.ties.iter().any(|t| &t.id == id && t.aerial.is_some())), "{listed:?}");
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
