//! Keeps the checked-in JSON Schemas under `schemas/` equal to the ones the types generate.

use plumbline_testkit::schemas::assert_current;

#[test]
fn schemas_are_current() {
    let manifest = plumbline_campaign::manifest_schema().to_value();
    assert_current(plumbline_campaign::MANIFEST_SCHEMA_FILE, &manifest, "plumbline-campaign");
}

#[test]
fn plan_schema_is_current() {
    let schema = serde_json::to_value(schemars::schema_for!(plumbline_campaign::plan::PlanDoc)).unwrap_or_default();
    assert_current("plan.v1.schema.json", &schema, "plumbline-campaign");
}
