//! `Problem`s found by validation, each naming the field by its path, and the `Checker` that
//! collects them so that validation reports every problem at once.

use std::fmt;

use crate::location::Location;

/// The path of a manifest field as written in the file: `aerial.interior.focal_length_mm`,
/// `cadastres[1].accuracy.trees`. The empty path is the manifest itself.
#[derive(Debug, Clone, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FieldPath(String);

impl FieldPath {
    /// The manifest itself.
    pub fn root() -> Self {
        Self::default()
    }

    /// The field `name` below this path.
    pub fn field(&self, name: &str) -> Self {
        match self.0.is_empty() {
            true => Self(name.to_owned()),
            false => Self(format!("{}.{name}", self.0)),
        }
    }

    /// The list element `index` of this path.
    pub fn index(&self, index: usize) -> Self {
        Self(format!("{}[{index}]", self.0))
    }

    /// The path as text; empty for the manifest itself.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for FieldPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0.is_empty() {
            true => f.write_str("(manifest)"),
            false => f.write_str(&self.0),
        }
    }
}

/// One thing wrong with a manifest: where, what was found, and what is expected instead.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    /// The field at fault.
    pub path: FieldPath,
    /// What is wrong, e.g. "300 m is not less than tiling.tile_size_m (250 m)".
    pub found: String,
    /// What would be right, e.g. "an overlap smaller than the tile size".
    pub expected: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}; expected {}", self.path, self.found, self.expected)
    }
}

/// Every problem of a manifest; never empty when returned as an error.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problems(Vec<Problem>);

impl Problems {
    /// The problems in the order the fields appear in the manifest.
    pub fn as_slice(&self) -> &[Problem] {
        &self.0
    }

    /// Iterates over the problems.
    pub fn iter(&self) -> std::slice::Iter<'_, Problem> {
        self.0.iter()
    }

    /// How many problems there are.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether there are none (never true for a validation error).
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl fmt::Display for Problems {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut lines = self.0.iter();
        if let Some(first) = lines.next() {
            write!(f, "{first}")?;
        }
        lines.try_for_each(|problem| write!(f, "\n{problem}"))
    }
}

impl std::error::Error for Problems {}

impl IntoIterator for Problems {
    type Item = Problem;
    type IntoIter = std::vec::IntoIter<Problem>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.into_iter()
    }
}

impl<'a> IntoIterator for &'a Problems {
    type Item = &'a Problem;
    type IntoIter = std::slice::Iter<'a, Problem>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

/// Collects problems while the validation walks the manifest.
#[derive(Debug, Default)]
pub(crate) struct Checker {
    problems: Vec<Problem>,
}

/// Longest free text (a campaign's name, its agency) a manifest may hold: reports and job states repeat it.
const MAX_TEXT_CHARS: usize = 1000;

impl Checker {
    /// Records a problem at `path`.
    pub(crate) fn report(&mut self, path: &FieldPath, found: impl Into<String>, expected: impl Into<String>) {
        self.problems.push(Problem { path: path.clone(), found: found.into(), expected: expected.into() });
    }

    /// Reports `value` at `path` unless it is finite and lies in `min..=max` (in `unit`).
    pub(crate) fn in_range(&mut self, path: &FieldPath, value: f64, min: f64, max: f64, unit: &str) {
        if !(value.is_finite() && (min..=max).contains(&value)) {
            self.report(
                path,
                format!("{value}{unit} is out of range"),
                format!("a value in {min}{unit}..={max}{unit}"),
            );
        }
    }

    /// Reports `value` at `path` unless it is finite, above zero and at most `max` (in `unit`).
    pub(crate) fn positive(&mut self, path: &FieldPath, value: f64, max: f64, unit: &str) {
        if !(value.is_finite() && value > 0.0 && value <= max) {
            self.report(
                path,
                format!("{value}{unit} is out of range"),
                format!("a value above 0{unit} and at most {max}{unit}"),
            );
        }
    }

    /// Reports an integer `value` at `path` unless it lies in `min..=max`.
    pub(crate) fn count(&mut self, path: &FieldPath, value: u32, min: u32, max: u32) {
        if !(min..=max).contains(&value) {
            self.report(path, format!("{value} is out of range"), format!("a whole number in {min}..={max}"));
        }
    }

    /// Reports a text field that is empty or only white space.
    pub(crate) fn not_blank(&mut self, path: &FieldPath, value: &str) {
        if value.trim().is_empty() {
            self.report(path, "it is empty", "a non-empty text");
        }
        let chars = value.chars().count();
        if chars > MAX_TEXT_CHARS {
            self.report(path, format!("it is {chars} characters long"), format!("at most {MAX_TEXT_CHARS} characters"));
        }
    }

    /// Reports a location that no base could resolve.
    pub(crate) fn location(&mut self, path: &FieldPath, location: &Location) {
        if let Err(e) = location.check() {
            self.report(path, e.found(), e.expected());
        }
    }

    /// The problems found, or `Ok` when there are none.
    pub(crate) fn finish(self) -> Result<(), Problems> {
        match self.problems.is_empty() {
            true => Ok(()),
            false => Err(Problems(self.problems)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_render_as_written_in_the_manifest() {
        let path = FieldPath::root().field("cadastres").index(1).field("accuracy").field("trees");
        assert_eq!(path.to_string(), "cadastres[1].accuracy.trees");
        assert_eq!(FieldPath::root().to_string(), "(manifest)");
    }

    #[test]
    fn problems_display_one_per_line() {
        let mut checker = Checker::default();
        checker.positive(&FieldPath::root().field("tiling").field("tile_size_m"), -1.0, 10_000.0, " m");
        checker.not_blank(&FieldPath::root().field("campaign").field("name"), " ");
        let text = checker.finish().err().map(|p| p.to_string()).unwrap_or_default();
        let expect = "tiling.tile_size_m: -1 m is out of range; expected a value above 0 m and at most 10000 m\n\
                      campaign.name: it is empty; expected a non-empty text";
        assert_eq!(text, expect);
    }
}
