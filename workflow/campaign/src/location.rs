//! `Location`: where a campaign input or output lives, as an object-store URL or a path relative to
//! the manifest; and `resolve`, the pure join of the two that the service layer uses.

use std::fmt;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// URL schemes the object-store layer serves.
pub const SCHEMES: &[&str] = &["file", "s3", "gs", "az", "http", "https", "memory"];

/// An absolute object-store URL (`file:///data/x.csv`, `s3://bucket/key`, `memory:///x`) or a path
/// relative to the manifest's own location (`trajectory/drive-01.csv`).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(transparent)]
#[schemars(transparent)]
pub struct Location(pub String);

/// Why a reference cannot be resolved against a base URL.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ResolveError {
    /// The base has no `scheme://`.
    BaseNotAbsolute(String),
    /// The reference is the empty string.
    Empty,
    /// The reference is a URL with a scheme not in [`SCHEMES`]: the URL and its scheme.
    UnknownScheme(String, String),
    /// The reference starts with `/`.
    AbsolutePath(String),
    /// The reference contains `//`.
    EmptySegment(String),
    /// The reference climbs above the base's directory with `..`.
    EscapesBase(String),
    /// A file named by an index row is an absolute URL: rows name files below the manifest's images prefix.
    NotBelowPrefix(String),
}

impl ResolveError {
    /// What is wrong with the reference (or the base).
    pub fn found(&self) -> String {
        match self {
            Self::BaseNotAbsolute(base) => format!("base {base:?} is not an absolute URL"),
            Self::Empty => "the location is empty".to_owned(),
            Self::UnknownScheme(url, scheme) => format!("{url:?} uses the unknown scheme {scheme:?}"),
            Self::AbsolutePath(path) => format!("{path:?} is an absolute path"),
            Self::EmptySegment(path) => format!("{path:?} has an empty path segment (\"//\")"),
            Self::EscapesBase(path) => format!("{path:?} leaves the manifest's directory through \"..\""),
            Self::NotBelowPrefix(url) => format!("{url:?} is an absolute URL"),
        }
    }

    /// What would be right instead.
    pub fn expected(&self) -> String {
        match self {
            Self::BaseNotAbsolute(_) => "a base of the form scheme://authority/path".to_owned(),
            Self::UnknownScheme(..) => format!("one of the schemes {}", SCHEMES.join(", ")),
            Self::Empty | Self::AbsolutePath(_) | Self::EmptySegment(_) | Self::EscapesBase(_) => {
                "a path below the manifest's directory (a/b.csv), or an absolute URL (file:///…, s3://…)".to_owned()
            }
            Self::NotBelowPrefix(_) => "a file name relative to the images prefix (day1/p0001.jpg)".to_owned(),
        }
    }
}

impl fmt::Display for ResolveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}; expected {}", self.found(), self.expected())
    }
}

impl std::error::Error for ResolveError {}

impl Location {
    /// The location as written.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// The URL scheme (`s3`, `file`, …) when the location is an absolute URL.
    pub fn scheme(&self) -> Option<&str> {
        scheme_of(&self.0)
    }

    /// The location's last path segment in lowercase letters after its final dot (`laz`, `tif`).
    pub fn extension(&self) -> Option<String> {
        let name = self.0.rsplit('/').next()?;
        name.rsplit_once('.').map(|(_, ext)| ext.to_ascii_lowercase())
    }

    /// Checks the location's form without a base: resolving it against any absolute base works.
    pub fn check(&self) -> Result<(), ResolveError> {
        resolve("memory:///", &self.0).map(|_| ())
    }
}

impl From<&str> for Location {
    fn from(s: &str) -> Self {
        Self(s.to_owned())
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// Joins `reference` to the directory of `base` (an absolute URL, usually the manifest's own).
///
/// Absolute URLs come back unchanged. A relative path is appended to `base` up to its last `/`,
/// with `.` segments dropped and `..` segments applied; a `..` that would climb above that
/// directory is an error, so a manifest only reaches what lies beside or below it unless it names
/// a URL. A trailing `/` (a prefix) is kept.
pub fn resolve(base: &str, reference: &str) -> Result<String, ResolveError> {
    if reference.is_empty() {
        return Err(ResolveError::Empty);
    }
    if let Some(scheme) = scheme_of(reference) {
        return match SCHEMES.contains(&scheme) {
            true => Ok(reference.to_owned()),
            false => Err(ResolveError::UnknownScheme(reference.to_owned(), scheme.to_owned())),
        };
    }
    if reference.starts_with('/') {
        return Err(ResolveError::AbsolutePath(reference.to_owned()));
    }
    let segments = normalise(reference)?;
    let dir = base_directory(base)?;
    Ok(format!("{dir}{}", segments.join("/")))
}

/// The scheme of `s` when it starts like `scheme://`, per RFC 3986 §3.1 letters.
fn scheme_of(s: &str) -> Option<&str> {
    let (scheme, _) = s.split_once("://")?;
    let mut chars = scheme.chars();
    let first_ok = chars.next().is_some_and(|c| c.is_ascii_alphabetic());
    let rest_ok = chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'));
    (first_ok && rest_ok).then_some(scheme)
}

/// Joins a file named by an index row to its images prefix `dir` (an absolute URL ending in `/`), and refuses
/// any way out of it: an absolute URL or path, or `..` above the prefix. Index rows are data an agency
/// uploads, so unlike a manifest location they may only name files below the prefix the manifest gives.
pub fn resolve_below(dir: &str, reference: &str) -> Result<String, ResolveError> {
    if scheme_of(reference).is_some() {
        return Err(ResolveError::NotBelowPrefix(reference.to_owned()));
    }
    resolve(dir, reference)
}

/// `base` cut after its last `/`, or with a `/` added when it names only an authority.
fn base_directory(base: &str) -> Result<String, ResolveError> {
    let not_absolute = || ResolveError::BaseNotAbsolute(base.to_owned());
    let scheme = scheme_of(base).ok_or_else(not_absolute)?;
    let after_authority = scheme.len() + "://".len();
    match base[after_authority..].rfind('/') {
        Some(i) => Ok(base[..after_authority + i + 1].to_owned()),
        None => Ok(format!("{base}/")),
    }
}

/// The segments of a relative path with `.` dropped and `..` applied.
fn normalise(reference: &str) -> Result<Vec<&str>, ResolveError> {
    let parts: Vec<&str> = reference.split('/').collect();
    let last = parts.len() - 1;
    let mut kept: Vec<&str> = Vec::with_capacity(parts.len());
    for (i, part) in parts.into_iter().enumerate() {
        match part {
            "" if i == last => kept.push(""),
            "" => return Err(ResolveError::EmptySegment(reference.to_owned())),
            "." if i == last => kept.push(""),
            "." => {}
            ".." => {
                kept.pop().ok_or_else(|| ResolveError::EscapesBase(reference.to_owned()))?;
                if i == last {
                    kept.push("");
                }
            }
            _ => kept.push(part),
        }
    }
    Ok(kept)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(base: &str, reference: &str, expect: Result<&str, ResolveError>) {
        assert_eq!(resolve(base, reference), expect.map(str::to_owned), "{base} + {reference}");
    }

    const HH: &str = "s3://campaigns/hamburg/manifest.toml";

    #[test]
    fn joins_relative_paths() {
        check(HH, "trajectory/drive-01.csv", Ok("s3://campaigns/hamburg/trajectory/drive-01.csv"));
        check(HH, "./a/./b.csv", Ok("s3://campaigns/hamburg/a/b.csv"));
        check(HH, "a/../b.csv", Ok("s3://campaigns/hamburg/b.csv"));
        check(HH, "panoramas/", Ok("s3://campaigns/hamburg/panoramas/"));
        check(HH, "panoramas/x/..", Ok("s3://campaigns/hamburg/panoramas/"));
        check("s3://bucket", "x.csv", Ok("s3://bucket/x.csv"));
        check("file:///data/hh/", "x.csv", Ok("file:///data/hh/x.csv"));
        check("memory:///m.toml", "x.csv", Ok("memory:///x.csv"));
    }

    #[test]
    fn keeps_absolute_urls() {
        check(HH, "file:///data/x.csv", Ok("file:///data/x.csv"));
        check(HH, "memory:///x", Ok("memory:///x"));
        check("not a url", "s3://b/k", Ok("s3://b/k"));
    }

    #[test]
    fn rejects_bad_references() {
        check(HH, "", Err(ResolveError::Empty));
        check(HH, "../x.csv", Err(ResolveError::EscapesBase("../x.csv".into())));
        check(HH, "a/../../x.csv", Err(ResolveError::EscapesBase("a/../../x.csv".into())));
        check(HH, "/data/x.csv", Err(ResolveError::AbsolutePath("/data/x.csv".into())));
        check(HH, "a//b.csv", Err(ResolveError::EmptySegment("a//b.csv".into())));
        check(HH, "ftp://h/x", Err(ResolveError::UnknownScheme("ftp://h/x".into(), "ftp".into())));
        check("data/m.toml", "x.csv", Err(ResolveError::BaseNotAbsolute("data/m.toml".into())));
    }

    #[test]
    fn extension_is_lowercase() {
        assert_eq!(Location::from("s3://b/cloud.LAZ").extension().as_deref(), Some("laz"));
        assert_eq!(Location::from("s3://b.x/cloud").extension(), None);
    }

    #[test]
    fn index_rows_only_reach_files_below_their_prefix() {
        let dir = "s3://agency-a/campaign/panoramas/";
        assert_eq!(resolve_below(dir, "day1/p1.jpg").unwrap(), "s3://agency-a/campaign/panoramas/day1/p1.jpg");
        assert_eq!(resolve_below(dir, "day1/../p1.jpg").unwrap(), "s3://agency-a/campaign/panoramas/p1.jpg");
        for escape in ["s3://agency-b/panoramas/p1.jpg", "file:///etc/hostname", "/etc/hostname", "../depth/d1.png"] {
            assert!(resolve_below(dir, escape).is_err(), "{escape}");
        }
        let e = resolve_below(dir, "s3://agency-b/p1.jpg").unwrap_err();
        assert!(e.to_string().contains("relative to the images prefix"), "{e}");
    }
}
