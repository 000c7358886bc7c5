//! Parsing a store URL (`file://`, `memory://`, `s3://`, or a plain path) into a [`StoreLocation`]; no I/O.

use std::path::PathBuf;

use object_store::path::Path;
use url::Url;

use super::error::{StoreError, StoreErrorKind};

/// Where a store URL points, before any store is built.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StoreLocation {
    /// A local directory (`file:///abs/dir` or a plain path, relative to the working directory).
    Local(PathBuf),
    /// A fresh in-memory store (`memory://`), with an optional key prefix (`memory://some/prefix`).
    Memory { prefix: Path },
    /// An S3 bucket and key prefix (`s3://bucket/prefix`).
    S3 { bucket: String, prefix: Path },
}

impl StoreLocation {
    /// Parses `url`. A string without `://` is a filesystem path and means `file://`.
    pub fn parse(url: &str) -> Result<Self, StoreError> {
        if url.trim().is_empty() {
            return Err(invalid(url, "the store URL is empty"));
        }
        if !url.contains("://") {
            return Ok(Self::Local(PathBuf::from(url)));
        }
        let parsed = Url::parse(url).map_err(|e| invalid(url, &format!("not a valid URL: {e}")))?;
        match parsed.scheme() {
            "file" => parse_file(url, &parsed),
            "memory" => Ok(Self::Memory { prefix: url_prefix(url, parsed.host_str(), parsed.path())? }),
            "s3" => parse_s3(url, &parsed),
            other => Err(invalid(
                url,
                &format!("unsupported scheme `{other}` (expected file://, memory://, s3:// or a plain path)"),
            )),
        }
    }
}

fn parse_file(url: &str, parsed: &Url) -> Result<StoreLocation, StoreError> {
    let path = parsed.to_file_path().map_err(|()| {
        invalid(url, "a file URL must hold an absolute path (file:///abs/dir); use a plain path for a relative one")
    })?;
    Ok(StoreLocation::Local(path))
}

fn parse_s3(url: &str, parsed: &Url) -> Result<StoreLocation, StoreError> {
    let bucket = match parsed.host_str() {
        Some(bucket) if !bucket.is_empty() => bucket.to_owned(),
        _ => return Err(invalid(url, "missing bucket (expected s3://bucket/prefix)")),
    };
    Ok(StoreLocation::S3 { bucket, prefix: url_prefix(url, None, parsed.path())? })
}

/// The key prefix from the URL's (percent-encoded) path, led by `host` where the host is part of it.
fn url_prefix(url: &str, host: Option<&str>, path: &str) -> Result<Path, StoreError> {
    let path = path.trim_matches('/');
    let joined = match host {
        Some(host) if !host.is_empty() => format!("{host}/{path}"),
        _ => path.to_owned(),
    };
    Path::from_url_path(joined.trim_end_matches('/')).map_err(|e| invalid(url, &format!("invalid key prefix: {e}")))
}

pub(super) fn invalid(url: &str, reason: &str) -> StoreError {
    StoreError::new(StoreErrorKind::Config, format!("store URL `{url}`: {reason}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(url: &str, expect: StoreLocation) {
        assert_eq!(StoreLocation::parse(url).expect(url), expect, "{url}");
    }

    fn check_err(url: &str, expect_in_message: &str) {
        let err = StoreLocation::parse(url).expect_err(url);
        let message = err.to_string();
        assert!(message.contains(expect_in_message), "{message}");
        assert!(message.contains(url), "{message}");
        assert_eq!(err.kind(), StoreErrorKind::Config);
    }

    fn prefix(p: &str) -> Path {
        Path::from(p)
    }

    #[test]
    fn parses_supported_urls() {
        check("file:///data/plumbline", StoreLocation::Local("/data/plumbline".into()));
        check("file://localhost/data", StoreLocation::Local("/data".into()));
        check("./plumbline-data", StoreLocation::Local("./plumbline-data".into()));
        check("/abs/dir", StoreLocation::Local("/abs/dir".into()));
        check("memory://", StoreLocation::Memory { prefix: Path::default() });
        check("memory://a/b", StoreLocation::Memory { prefix: prefix("a/b") });
        check("s3://bucket", StoreLocation::S3 { bucket: "bucket".into(), prefix: Path::default() });
        check("s3://bucket/", StoreLocation::S3 { bucket: "bucket".into(), prefix: Path::default() });
        check("s3://bucket/camp/one/", StoreLocation::S3 { bucket: "bucket".into(), prefix: prefix("camp/one") });
        check("s3://bucket/with%20space", StoreLocation::S3 { bucket: "bucket".into(), prefix: prefix("with space") });
    }

    #[test]
    fn rejects_bad_urls_naming_them() {
        check_err("gs://bucket/x", "unsupported scheme `gs`");
        check_err("s3:///prefix", "missing bucket");
        check_err("s3://", "missing bucket");
        check_err("file://./relative", "absolute path");
        check_err("", "empty");
    }
}
