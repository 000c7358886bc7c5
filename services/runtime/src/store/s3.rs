//! `S3Options` and building an `AmazonS3` store from them; nothing is read from the environment.

use object_store::aws::{AmazonS3, AmazonS3Builder};
use url::{Host, Url};

use super::error::{StoreError, StoreErrorKind};
use super::location::invalid;
use crate::secret::Secret;

/// Region used when none is configured; S3-compatible servers (MinIO, moto) accept any.
pub const DEFAULT_REGION: &str = "us-east-1";

/// How to reach an S3 or S3-compatible server. Supplied by [`crate::RuntimeConfig`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct S3Options {
    /// Endpoint of an S3-compatible server, e.g. `http://127.0.0.1:9000`; `None` means AWS.
    pub endpoint: Option<String>,
    /// Region; [`DEFAULT_REGION`] when `None`.
    pub region: Option<String>,
    pub access_key_id: Option<String>,
    pub secret_access_key: Option<Secret>,
    /// Allow plain `http://` endpoints. Loopback endpoints (127.0.0.1, ::1, localhost) are always
    /// allowed, since nothing leaves the machine.
    pub allow_http: bool,
    /// Address buckets as `https://bucket.endpoint/` instead of `https://endpoint/bucket/`.
    pub virtual_hosted_style: bool,
}

impl S3Options {
    /// Checks the options on their own (no URL): endpoint syntax and credentials in pairs.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(endpoint) = &self.endpoint {
            let url = Url::parse(endpoint).map_err(|e| format!("s3 endpoint `{endpoint}` is not a URL: {e}"))?;
            if !matches!(url.scheme(), "http" | "https") {
                return Err(format!("s3 endpoint `{endpoint}` must be http:// or https://"));
            }
            if url.scheme() == "http" && !self.allow_http && !is_loopback(&url) {
                return Err(format!("s3 endpoint `{endpoint}` is plain http: set allow_http = true to allow it"));
            }
        }
        match (&self.access_key_id, &self.secret_access_key) {
            (Some(_), None) => Err("s3 access_key_id is set but secret_access_key is not".to_owned()),
            (None, Some(_)) => Err("s3 secret_access_key is set but access_key_id is not".to_owned()),
            _ => Ok(()),
        }
    }

    fn http_allowed(&self) -> bool {
        self.allow_http || self.endpoint.as_deref().and_then(|e| Url::parse(e).ok()).is_some_and(|u| is_loopback(&u))
    }
}

fn is_loopback(url: &Url) -> bool {
    match url.host() {
        Some(Host::Domain(domain)) => domain == "localhost",
        Some(Host::Ipv4(ip)) => ip.is_loopback(),
        Some(Host::Ipv6(ip)) => ip.is_loopback(),
        None => false,
    }
}

/// Builds the store for `bucket`; `url` is only for error messages.
pub(super) fn build(url: &str, bucket: &str, options: &S3Options) -> Result<AmazonS3, StoreError> {
    options.validate().map_err(|reason| invalid(url, &reason))?;
    let mut builder = AmazonS3Builder::new()
        .with_bucket_name(bucket)
        .with_region(options.region.as_deref().unwrap_or(DEFAULT_REGION))
        .with_allow_http(options.http_allowed())
        .with_virtual_hosted_style_request(options.virtual_hosted_style);
    if let Some(endpoint) = &options.endpoint {
        builder = builder.with_endpoint(endpoint);
    }
    if let (Some(key), Some(secret)) = (&options.access_key_id, &options.secret_access_key) {
        builder = builder.with_access_key_id(key).with_secret_access_key(secret.expose());
    }
    builder.build().map_err(|e| StoreError::new(StoreErrorKind::Config, format!("store URL `{url}`: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with_endpoint(endpoint: &str, allow_http: bool) -> S3Options {
        S3Options { endpoint: Some(endpoint.to_owned()), allow_http, ..S3Options::default() }
    }

    #[test]
    fn plain_http_needs_allow_http_unless_loopback() {
        assert!(with_endpoint("http://127.0.0.1:9000", false).validate().is_ok());
        assert!(with_endpoint("http://localhost:9000", false).validate().is_ok());
        assert!(with_endpoint("http://[::1]:9000", false).validate().is_ok());
        assert!(with_endpoint("https://minio.example:9000", false).validate().is_ok());
        assert!(with_endpoint("http://minio:9000", true).validate().is_ok());
        let err = with_endpoint("http://minio:9000", false).validate().expect_err("plain http");
        assert!(err.contains("allow_http"), "{err}");
    }

    #[test]
    fn credentials_come_in_pairs() {
        let half = S3Options { access_key_id: Some("key".into()), ..S3Options::default() };
        assert!(half.validate().expect_err("half").contains("secret_access_key"));
        let other_half = S3Options { secret_access_key: Some(Secret::new("s")), ..S3Options::default() };
        assert!(other_half.validate().is_err());
    }

    #[test]
    fn bad_endpoint_is_named() {
        let err = with_endpoint("minio:9000", true).validate().expect_err("scheme");
        assert!(err.contains("minio:9000"), "{err}");
    }
}
