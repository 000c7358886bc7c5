//! The JSON Schema of the manifest, generated from the types and written out deterministically
//! (keys sorted, pretty, trailing newline) so the checked-in copy under `schemas/` can be compared.

use serde_json::{Map, Value};

use crate::manifest::Manifest;

/// File name of the manifest schema under `schemas/`.
pub const MANIFEST_SCHEMA_FILE: &str = "manifest.v1.schema.json";

/// The JSON Schema (draft 2020-12) of [`Manifest`], every version.
pub fn manifest_schema() -> schemars::Schema {
    schemars::schema_for!(Manifest)
}

/// [`manifest_schema`] as the text checked in under `schemas/`.
pub fn manifest_schema_json() -> String {
    canonical_json(&manifest_schema().to_value())
}

/// Pretty JSON with object keys sorted at every level and a trailing newline.
pub fn canonical_json(value: &Value) -> String {
    let mut text = serde_json::to_string_pretty(&sorted(value)).unwrap_or_default();
    text.push('\n');
    text
}

/// `value` with its objects' keys in lexicographic order, whatever order the map type keeps.
fn sorted(value: &Value) -> Value {
    match value {
        Value::Object(map) => {
            let mut keys: Vec<&String> = map.keys().collect();
            keys.sort();
            Value::Object(keys.into_iter().map(|k| (k.clone(), sorted(&map[k]))).collect::<Map<_, _>>())
        }
        Value::Array(items) => Value::Array(items.iter().map(sorted).collect()),
        other => other.clone(),
    }
}
