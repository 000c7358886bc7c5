//! The manifests of `docs/guide.md`: every TOML block holding a manifest parses and conforms to the
//! checked-in schema; a block followed directly by a `text` block must fail validation with exactly the
//! problems that block shows, every other one must validate.

use std::fs;
use std::path::Path;

use plumbline_campaign::Manifest;

use super::{json_schema, schema};

/// A fenced block of the guide: its language tag, its text, and the line it starts on.
struct Block {
    lang: String,
    text: String,
    line: usize,
}

/// The fenced blocks in `markdown`, with whether each follows the previous one with only blank lines
/// between them.
fn blocks(markdown: &str) -> Vec<(Block, bool)> {
    let mut found = Vec::new();
    let mut open: Option<Block> = None;
    let mut adjacent = false;
    for (i, line) in markdown.lines().enumerate() {
        match open.take() {
            Some(mut block) if line.trim_start().starts_with("```") => {
                block.text.pop();
                found.push((block, adjacent));
                adjacent = true;
            }
            Some(mut block) => {
                block.text.push_str(line);
                block.text.push('\n');
                open = Some(block);
            }
            None if line.trim_start().starts_with("```") => {
                let lang = line.trim_start().trim_start_matches('`').trim().to_string();
                open = Some(Block { lang, text: String::new(), line: i + 1 });
            }
            None => adjacent &= line.trim().is_empty(),
        }
    }
    assert!(open.is_none(), "docs/guide.md ends inside a fenced block");
    found
}

#[test]
fn the_guides_manifests_validate_and_its_broken_one_fails_as_shown() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/guide.md");
    let guide = fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let schema = schema();
    let all = blocks(&guide);
    let (mut valid, mut broken) = (0, 0);
    for (k, (block, _)) in all.iter().enumerate() {
        if block.lang != "toml" || !block.text.contains("version = \"1\"") {
            continue;
        }
        let at = format!("docs/guide.md line {}", block.line);
        let manifest = Manifest::from_toml_str(&block.text).unwrap_or_else(|e| panic!("{at}: {e}"));
        let value: serde_json::Value = toml::from_str(&block.text).unwrap_or_else(|e| panic!("{at}: {e}"));
        let violations = json_schema::violations(&schema, &value);
        assert!(violations.is_empty(), "{at} breaks the schema:\n{}", violations.join("\n"));
        match all.get(k + 1) {
            Some((expected, true)) if expected.lang == "text" => {
                let problems = manifest
                    .validate()
                    .err()
                    .unwrap_or_else(|| panic!("{at}: validates, but the guide shows problems"));
                assert_eq!(problems.to_string(), expected.text.trim(), "{at}: the problems differ from the guide's");
                broken += 1;
            }
            _ => {
                if let Err(problems) = manifest.validate() {
                    panic!("{at} does not validate:\n{problems}");
                }
                valid += 1;
            }
        }
    }
    assert!(
        valid >= 4 && broken >= 1,
        "expected the guide's four manifest set-ups and its broken example, found {valid} and {broken}"
    );
}
