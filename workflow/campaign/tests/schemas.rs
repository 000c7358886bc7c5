//! Keeps the checked-in JSON Schemas under `schemas/` equal to the ones the types generate.

use std::path::{Path, PathBuf};

/// Set to `1` to rewrite the checked-in schemas instead of comparing them.
const UPDATE_ENV: &str = "PLUMBLINE_UPDATE_SCHEMAS";

fn schemas_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../schemas")
}

fn check(file: &str, generated: &str) {
    let path = schemas_dir().join(file);
    if std::env::var(UPDATE_ENV).is_ok_and(|v| v == "1") {
        std::fs::write(&path, generated).unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    let first_difference = checked_in.lines().zip(generated.lines()).position(|(a, b)| a != b);
    assert!(
        checked_in == generated,
        "schemas/{file} is stale or missing (first difference at line {}); regenerate it with\n\n    \
         {UPDATE_ENV}=1 cargo test -p plumbline-campaign --test schemas\n\nand commit the result",
        first_difference.map_or(checked_in.lines().count().min(generated.lines().count()), |i| i) + 1
    );
}

#[test]
fn schemas_are_current() {
    check(plumbline_campaign::MANIFEST_SCHEMA_FILE, &plumbline_campaign::manifest_schema_json());
}

#[test]
fn plan_schema_is_current() {
    let schema = serde_json::to_value(schemars::schema_for!(plumbline_campaign::plan::PlanDoc)).unwrap_or_default();
    check("plan.v1.schema.json", &plumbline_campaign::canonical_json(&schema));
}
