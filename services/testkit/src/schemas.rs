//! The checked-in JSON Schemas under `schemas/`: compare them with what the types generate, or rewrite them
//! when `PLUMBLINE_UPDATE_SCHEMAS=1`; read golden examples.

use std::path::{Path, PathBuf};

/// Set to `1` to rewrite the checked-in schemas instead of comparing them.
pub const UPDATE_ENV: &str = "PLUMBLINE_UPDATE_SCHEMAS";

/// The workspace's `schemas/` folder.
pub fn schemas_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../schemas")
}

/// The text of `schemas/examples/{name}`.
pub fn example(name: &str) -> String {
    let path = schemas_dir().join("examples").join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// Fail unless `schemas/{file}` equals `schema` in canonical form (or rewrite it under [`UPDATE_ENV`]);
/// `package` names the crate whose `--test schemas` regenerates it.
pub fn assert_current(file: &str, schema: &serde_json::Value, package: &str) {
    let generated = plumbline_campaign::canonical_json(schema);
    let path = schemas_dir().join(file);
    if std::env::var(UPDATE_ENV).is_ok_and(|v| v == "1") {
        std::fs::write(&path, &generated).unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    let first_difference = checked_in.lines().zip(generated.lines()).position(|(a, b)| a != b);
    assert!(
        checked_in == generated,
        "schemas/{file} is stale or missing (first difference at line {}); regenerate it with\n\n    \
         {UPDATE_ENV}=1 cargo test -p {package} --test schemas\n\nand commit the result",
        first_difference.map_or(checked_in.lines().count().min(generated.lines().count()), |i| i) + 1
    );
}
