//! Reading manifests from TOML and JSON: what each kind of mistake reports, with its field path
//! and, for TOML and JSON syntax, its line and column.

use plumbline_campaign::{Manifest, ParseError, Position};

const TOML_HEAD: &str = "version = \"1\"\ncrs = 25832\noutput = \"results/\"\n[campaign]\nid = \"hh\"\nname = \"HH\"\n";
const SBET: &str = "[[trajectory]]\nformat = \"sbet\"\nurl = \"sbet.out\"\n";

/// Parses `text` as TOML and compares the error's text with `expect` (`None` = parses).
fn check(text: &str, expect: Option<&str>) {
    let error = Manifest::from_toml_str(text).err().map(|e| e.to_string());
    assert_eq!(error.as_deref(), expect, "\n{text}");
}

/// Parses `text` as JSON and compares the error's text with `expect` (`None` = parses).
fn check_json(text: &str, expect: Option<&str>) {
    let error = Manifest::from_json_str(text).err().map(|e| e.to_string());
    assert_eq!(error.as_deref(), expect, "\n{text}");
}

#[test]
fn toml_version() {
    check(&format!("{TOML_HEAD}{SBET}"), None);
    let body = &TOML_HEAD["version = \"1\"\n".len()..];
    check(
        &format!("{body}{SBET}"),
        Some(
            "`version`: missing; a manifest starts with its version; expected one of [\"1\"] as a quoted string, e.g. version = \"1\"",
        ),
    );
    check(
        &format!("version = \"2\"\n{body}"),
        Some(
            "`version` at line 1, column 11: unsupported version \"2\"; expected one of [\"1\"] as a quoted string, e.g. version = \"1\"",
        ),
    );
    check(
        &format!("version = 1\n{body}"),
        Some(
            "`version` at line 1, column 11: not a string; expected one of [\"1\"] as a quoted string, e.g. version = \"1\"",
        ),
    );
}

#[test]
fn toml_fields() {
    check(
        &format!("{TOML_HEAD}{SBET}[tilling]\n"),
        Some(
            "`tilling` at line 10, column 2: unknown field `tilling`, expected one of `campaign`, `crs`, `output`, \
         `trajectory`, `panoramas`, `depth`, `point_clouds`, `aerial`, `cadastres`, `tiling`, `parameters`",
        ),
    );
    check(
        &format!("{TOML_HEAD}{SBET}[tiling]\ntile_size_m = \"big\"\n"),
        Some("`tiling.tile_size_m` at line 11, column 15: invalid type: string \"big\", expected f64"),
    );
    check(
        &format!("{TOML_HEAD}{SBET}smrmg = \"x\"\n"),
        Some(
            "`trajectory[0].smrmg` at line 10, column 1: unknown field `smrmg`, expected one of `format`, `url`, `epsg`, \
         `attitude`, `smrmsg`, `gnss`, `imu`, `reference`",
        ),
    );
    check(
        &format!("{TOML_HEAD}{SBET}epsg = 4326\n"),
        Some("`trajectory[0]` at line 7, column 1: `epsg` is only for format = \"csv\"; SBET is always WGS 84"),
    );
    check(
        &format!("{TOML_HEAD}{SBET}[[cadastres]]\nurl = \"c.gpkg\"\nlayers = [\"x\"]\nclass = \"lamp\"\n"),
        Some(
            "`cadastres[0].class` at line 13, column 9: unknown variant `lamp`, expected one of `pole`, `light`, `sign`, `tree`",
        ),
    );
    check(
        &TOML_HEAD.replace("id = \"hh\"", "id = \"HH 2024\""),
        Some(
            "`campaign.id` at line 5, column 6: campaign id contains 'H'; expected only lowercase letters a-z, digits, '-' and '_'",
        ),
    );
    check(TOML_HEAD, Some("(manifest) at line 1, column 1: missing field `trajectory`"));
}

#[test]
fn toml_syntax() {
    check(
        &format!("{TOML_HEAD}{SBET}url = \"b\" x\n"),
        Some("TOML syntax error at line 10, column 11: unexpected key or value, expected newline, `#`"),
    );
    check(&format!("{TOML_HEAD}[campaign]\n"), Some("TOML syntax error at line 7, column 2: duplicate key"));
}

const JSON_HEAD: &str = r#""crs": 25832, "output": "r/", "campaign": {"id": "hh", "name": "HH"}"#;

#[test]
fn json() {
    let sbet = r#""trajectory": [{"format": "sbet", "url": "sbet.out"}]"#;
    check_json(&format!(r#"{{"version": "1", {JSON_HEAD}, {sbet}}}"#), None);
    check_json(
        &format!(r#"{{{JSON_HEAD}, {sbet}}}"#),
        Some(
            "`version`: missing; a manifest starts with its version; expected one of [\"1\"] as a quoted string, e.g. version = \"1\"",
        ),
    );
    check_json(
        &format!(r#"{{"version": "1", {JSON_HEAD}, {sbet}, "tiling": {{"tile_size": 1}}}}"#),
        Some("`tiling.tile_size`: unknown field `tile_size`, expected `tile_size_m` or `overlap_m`"),
    );
    check_json(
        &format!(r#"{{"version": "1", {JSON_HEAD}, "trajectory": [{{"format": "csv", "url": "a", "epsg": "x"}}]}}"#),
        Some("`trajectory[0].epsg`: invalid type: string \"x\", expected u32"),
    );
    check_json("{\n  \"version\": \"1\",\n}", Some("JSON syntax error at line 3, column 1: trailing comma"));
    check_json("[1]", Some("JSON syntax error at line 1, column 0: invalid type: sequence, expected a map"));
}

#[test]
fn errors_expose_path_and_position() {
    let text = format!("{TOML_HEAD}{SBET}[tiling]\ntile_size_m = \"big\"\n");
    let error = Manifest::from_toml_str(&text).err();
    assert_eq!(error.as_ref().and_then(ParseError::path), Some("tiling.tile_size_m"));
    assert_eq!(error.as_ref().and_then(ParseError::position), Some(Position { line: 11, column: 15 }));
}
