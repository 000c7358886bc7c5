//! Keeps `schemas/tile-output.v1.schema.json` equal to the schema the tile-output types generate.

use plumbline_worker::TileOutput;

const SCHEMA_FILE: &str = "tile-output.v1.schema.json";

#[test]
fn tile_output_schema_is_current() {
    let schema = serde_json::to_value(schemars::schema_for!(TileOutput)).expect("schema serialises");
    plumbline_testkit::schemas::assert_current(SCHEMA_FILE, &schema, "plumbline-worker");
}
