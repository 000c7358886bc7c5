//! Reading a manifest from TOML or JSON text: the `version` key picks the version's types, and
//! every error names the field path and, where the format keeps it, the line and column.

use std::fmt;

use serde::de::DeserializeOwned;
use toml::Spanned;
use toml::de::DeTable;

use crate::manifest::Manifest;

/// The versions this build reads.
pub const SUPPORTED_VERSIONS: &[&str] = &["1"];

/// A manifest's text format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// TOML, the format people write manifests in.
    Toml,
    /// JSON, the format programs exchange manifests in.
    Json,
}

/// A 1-based line and column in the manifest text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Position {
    /// Line, from 1.
    pub line: usize,
    /// Column in characters, from 1 (serde_json reports 0 for errors before the first character).
    pub column: usize,
}

/// Why a manifest text could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ParseError {
    /// The text is not well-formed TOML or JSON.
    #[error("{format} syntax error{}: {message}", at(*.position))]
    Syntax { format: Format, position: Option<Position>, message: String },
    /// The `version` key is missing, malformed or names a version this build does not read.
    #[error("`version`{}: {message}", at(*.position))]
    Version { position: Option<Position>, message: String },
    /// A field is unknown, missing, or has a value of the wrong type.
    #[error("{}{}: {message}", field(path), at(*.position))]
    Field { path: String, position: Option<Position>, message: String },
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Toml => "TOML",
            Self::Json => "JSON",
        })
    }
}

impl fmt::Display for Position {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}, column {}", self.line, self.column)
    }
}

/// A field path as error messages show it; the empty path is the manifest itself.
fn field(path: &str) -> String {
    if path.is_empty() { "(manifest)".to_owned() } else { format!("`{path}`") }
}

fn at(position: Option<Position>) -> String {
    position.map(|p| format!(" at {p}")).unwrap_or_default()
}

impl ParseError {
    /// The path of the field at fault (`cadastres[1].accuracy.trees`), when the error has one.
    pub fn path(&self) -> Option<&str> {
        match self {
            Self::Field { path, .. } => Some(path),
            Self::Version { .. } => Some("version"),
            Self::Syntax { .. } => None,
        }
    }

    /// Where in the text the error is, when the format tells.
    pub fn position(&self) -> Option<Position> {
        match self {
            Self::Syntax { position, .. } | Self::Version { position, .. } | Self::Field { position, .. } => *position,
        }
    }
}

impl Manifest {
    /// Reads a manifest from TOML text.
    pub fn from_toml_str(text: &str) -> Result<Self, ParseError> {
        let syntax = |e: toml::de::Error| ParseError::Syntax {
            format: Format::Toml,
            position: e.span().map(|s| position_of(text, s.start)),
            message: e.message().trim_end().to_owned(),
        };
        let mut root = DeTable::parse(text).map_err(syntax)?;
        let version = root.get_mut().remove("version");
        let found =
            version.as_ref().map_or(Found::Missing, |v| v.get_ref().as_str().map_or(Found::NotText, Found::Text));
        let position = version.as_ref().map(|v| position_of(text, v.span().start));
        match version_of(found).map_err(|message| ParseError::Version { position, message })? {
            Version::V1 => deserialize_toml(text, root).map(Manifest::V1),
        }
    }

    /// Reads a manifest from JSON text.
    pub fn from_json_str(text: &str) -> Result<Self, ParseError> {
        let syntax = |e: serde_json::Error| ParseError::Syntax {
            format: Format::Json,
            position: (e.line() > 0).then(|| Position { line: e.line(), column: e.column() }),
            message: json_message(&e),
        };
        let mut root: serde_json::Map<String, serde_json::Value> = serde_json::from_str(text).map_err(syntax)?;
        let version = root.remove("version");
        let found = version.as_ref().map_or(Found::Missing, |v| v.as_str().map_or(Found::NotText, Found::Text));
        match version_of(found).map_err(|message| ParseError::Version { position: None, message })? {
            Version::V1 => deserialize_json(serde_json::Value::Object(root)).map(Manifest::V1),
        }
    }
}

/// The manifest versions this build reads.
#[derive(Debug, Clone, Copy)]
enum Version {
    V1,
}

/// What a document holds under `version`.
#[derive(Debug, Clone, Copy)]
enum Found<'a> {
    Missing,
    NotText,
    Text(&'a str),
}

/// The supported version named by the `version` value, or what is wrong with it.
fn version_of(found: Found<'_>) -> Result<Version, String> {
    let expected = format!("expected one of {SUPPORTED_VERSIONS:?} as a quoted string, e.g. version = \"1\"");
    match found {
        Found::Text("1") => Ok(Version::V1),
        Found::Text(other) => Err(format!("unsupported version {other:?}; {expected}")),
        Found::NotText => Err(format!("not a string; {expected}")),
        Found::Missing => Err(format!("missing; a manifest starts with its version; {expected}")),
    }
}

fn deserialize_toml<T: DeserializeOwned>(text: &str, root: Spanned<DeTable<'_>>) -> Result<T, ParseError> {
    serde_path_to_error::deserialize(toml::de::Deserializer::from(root)).map_err(|e| ParseError::Field {
        path: path_text(e.path()),
        position: e.inner().span().map(|s| position_of(text, s.start)),
        message: e.inner().message().trim_end().to_owned(),
    })
}

fn deserialize_json<T: DeserializeOwned>(value: serde_json::Value) -> Result<T, ParseError> {
    serde_path_to_error::deserialize(value).map_err(|e| ParseError::Field {
        path: path_text(e.path()),
        position: None,
        message: json_message(e.inner()),
    })
}

/// serde_json's message without the position it appends (the error carries it apart).
fn json_message(e: &serde_json::Error) -> String {
    let text = e.to_string();
    let suffix = format!(" at line {} column {}", e.line(), e.column());
    text.strip_suffix(&suffix).map_or(text.clone(), str::to_owned)
}

/// serde_path_to_error writes the root as "."; plumbline paths write it as the empty string.
fn path_text(path: &serde_path_to_error::Path) -> String {
    let text = path.to_string();
    if text == "." { String::new() } else { text }
}

/// The 1-based line and column (in characters) of byte `offset` in `text`.
fn position_of(text: &str, offset: usize) -> Position {
    let before = text.get(..offset).unwrap_or(text);
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    Position { line: before.matches('\n').count() + 1, column: before[line_start..].chars().count() + 1 }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use plumbline_testkit::mutation::{edits, mutate};

    const FULL_TOML: &str = include_str!("../../../schemas/examples/manifest.v1.full.toml");
    const FULL_JSON: &str = include_str!("../../../schemas/examples/manifest.v1.full.json");

    /// Both readers on `bytes` (lossy UTF-8, as a caller that decoded them would pass text): a manifest holds
    /// no more list entries than the text has room for (3 bytes: `"",`), an error names a field path or a
    /// position (the toml crate gives its recursion limit no position: see `deep_nesting_is_an_error`).
    fn check(bytes: &[u8]) -> Result<(), TestCaseError> {
        let text = String::from_utf8_lossy(bytes);
        for outcome in [Manifest::from_toml_str(&text), Manifest::from_json_str(&text)] {
            match outcome {
                Ok(Manifest::V1(m)) => {
                    let entries = m.trajectory.len() + m.depth.len() + m.point_clouds.len() + m.cadastres.len();
                    prop_assert!(entries * 3 <= text.len(), "{entries} entries");
                }
                Err(ParseError::Syntax { position: None, message, .. }) => {
                    prop_assert!(message.contains("recursion limit"), "{message}");
                }
                Err(e) => prop_assert!(e.path().is_some() || e.position().is_some(), "{e}"),
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 256,
            rng_seed: proptest::test_runner::RngSeed::Fixed(22),
            ..ProptestConfig::default()
        })]

        #[test]
        fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..4096)) {
            check(&bytes)?;
        }

        #[test]
        fn arbitrary_manifest_like_text_never_panics(text in "[a-z0-9_.=\\[\\]{}\":, \\n#-]{0,4000}") {
            check(format!("version = \"1\"\n{text}").as_bytes())?;
            check(format!("{{\"version\": \"1\", {text}").as_bytes())?;
        }

        #[test]
        fn mutated_manifests_parse_or_name_the_field(json in any::<bool>(), edits in edits()) {
            let valid = if json { FULL_JSON } else { FULL_TOML };
            check(&mutate(valid.as_bytes().to_vec(), &edits))?;
        }
    }

    /// 100 000 open brackets or dotted keys: an error from the parsers' recursion limits, not a stack
    /// overflow (which would abort the process).
    #[test]
    fn deep_nesting_is_an_error() {
        let n = 100_000;
        for text in [
            format!("version = \"1\"\nx = {}", "[".repeat(n)),
            format!("version = \"1\"\nx = {}1{}", "{a=".repeat(n), "}".repeat(n)),
            format!("version = \"1\"\n[{}]", vec!["a"; n].join(".")),
        ] {
            let e = Manifest::from_toml_str(&text).unwrap_err();
            assert!(e.to_string().starts_with("TOML syntax error") && e.to_string().contains("recursion"), "{e}");
        }
        let e = Manifest::from_json_str(&format!("{{\"version\": \"1\", \"x\": {}", "[".repeat(n))).unwrap_err();
        assert_eq!(e.to_string(), "JSON syntax error at line 1, column 149: recursion limit exceeded");
    }

    #[test]
    fn the_mutated_examples_parse_unmutated() {
        assert!(Manifest::from_toml_str(FULL_TOML).is_ok());
        assert!(Manifest::from_json_str(FULL_JSON).is_ok());
    }
}
