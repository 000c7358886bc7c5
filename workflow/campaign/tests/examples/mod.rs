//! The golden examples under `schemas/examples/`: every `manifest.*` file parses, validates and
//! conforms to the checked-in JSON Schema; every file under `invalid/` fails, naming the fields
//! listed in its `# expect:` lines.

mod guide;
mod json_schema;

use std::fs;
use std::path::{Path, PathBuf};

use plumbline_campaign::{Manifest, ParseError};
use serde_json::{Value, json};

fn examples_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../schemas/examples")
}

fn read(path: &Path) -> String {
    fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// The files in `dir` whose names start with `manifest.`, sorted.
fn manifests_in(dir: &Path) -> Vec<PathBuf> {
    let entries = fs::read_dir(dir).unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()));
    let mut files: Vec<PathBuf> = entries
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("manifest.")))
        .collect();
    files.sort();
    files
}

fn parse(path: &Path) -> Result<Manifest, ParseError> {
    let text = read(path);
    match path.extension().and_then(|e| e.to_str()) {
        Some("json") => Manifest::from_json_str(&text),
        _ => Manifest::from_toml_str(&text),
    }
}

/// The file as a JSON value, whatever its format, to check against the schema.
fn as_json(path: &Path) -> Value {
    let text = read(path);
    match path.extension().and_then(|e| e.to_str()) {
        Some("json") => serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
        _ => toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    }
}

fn schema() -> Value {
    let path = examples_dir().join("..").join(plumbline_campaign::MANIFEST_SCHEMA_FILE);
    serde_json::from_str(&read(&path)).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn examples_parse_validate_and_conform_to_the_schema() {
    let (files, schema) = (manifests_in(&examples_dir()), schema());
    assert!(files.len() >= 3, "expected the minimal, full and JSON examples, found {files:?}");
    for path in files {
        let manifest = parse(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        if let Err(problems) = manifest.validate() {
            panic!("{} does not validate:\n{problems}", path.display());
        }
        let violations = json_schema::violations(&schema, &as_json(&path));
        assert!(violations.is_empty(), "{} breaks the schema:\n{}", path.display(), violations.join("\n"));
    }
}

#[test]
fn full_toml_and_json_examples_agree() {
    let toml = parse(&examples_dir().join("manifest.v1.full.toml"));
    let json = parse(&examples_dir().join("manifest.v1.full.json"));
    assert_eq!(toml, json);
}

#[test]
fn serialised_manifests_read_back_and_conform_to_the_schema() {
    let schema = schema();
    for path in manifests_in(&examples_dir()) {
        let manifest = parse(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let value = serde_json::to_value(&manifest).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let violations = json_schema::violations(&schema, &value);
        assert!(violations.is_empty(), "{} serialised breaks the schema:\n{}", path.display(), violations.join("\n"));
        let again = Manifest::from_json_str(&value.to_string());
        assert_eq!(again.as_ref().ok(), Some(&manifest), "{} does not read back: {again:?}", path.display());
    }
}

/// The error text of an invalid manifest: its parse error, or its validation problems.
fn failure(path: &Path) -> String {
    match parse(path) {
        Err(error) => error.to_string(),
        Ok(manifest) => match manifest.validate() {
            Err(problems) => problems.to_string(),
            Ok(_) => panic!("{} is valid but lies under invalid/", path.display()),
        },
    }
}

fn check_invalid(path: &Path) {
    let expected: Vec<String> =
        read(path).lines().filter_map(|l| l.strip_prefix("# expect:")).map(|s| s.trim().to_owned()).collect();
    assert!(!expected.is_empty(), "{} has no `# expect: <field path>` line", path.display());
    let message = failure(path);
    for field in expected {
        assert!(
            message.contains(&format!("{field}:")) || message.contains(&format!("`{field}`")),
            "{}: expected a problem at {field}, got:\n{message}",
            path.display()
        );
    }
}

#[test]
fn invalid_examples_fail_at_the_expected_fields() {
    let dir = examples_dir().join("invalid");
    let entries = fs::read_dir(&dir).unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()));
    let mut files: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    files.sort();
    assert!(files.len() >= 3, "expected several invalid examples, found {files:?}");
    files.iter().for_each(|path| check_invalid(path));
}

fn check_schema(mutate: fn(&mut Value), expect: &str) {
    let mut value = as_json(&examples_dir().join("manifest.v1.minimal.toml"));
    mutate(&mut value);
    let violations = json_schema::violations(&schema(), &value).join("\n");
    assert!(violations.contains(expect), "expected a violation containing {expect:?}, got:\n{violations}");
}

#[test]
fn schema_rejects_what_the_types_reject() {
    check_schema(|v| v["tiling"] = json!({ "tile_size": 200.0 }), "/tiling/tile_size: is not allowed here");
    check_schema(|v| v["crs"] = json!(77), "/crs: is below 1024");
    check_schema(|v| v["trajectory"] = json!([]), "/trajectory: has fewer than 1 items");
    check_schema(|v| v["trajectory"][0]["format"] = json!("gpx"), "matches 0 branches");
    check_schema(|v| v["version"] = json!("2"), "matches 0 branches");
    check_schema(|v| _ = v.as_object_mut().map(|o| o.remove("output")), "lacks required property \"output\"");
}
