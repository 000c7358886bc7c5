//! Reading and writing the files a command names, by path or object-store URL, with the runtime config.

use std::collections::HashMap;
use std::path::Path;

use anyhow::Context as _;
use bytes::Bytes;
use plumbline_runtime::{RuntimeConfig, S3Options, StoreErrorKind};

use crate::exit::invalid;

/// What every command needs from the runtime: how to reach object stores.
#[derive(Debug)]
pub struct Context {
    s3: S3Options,
}

impl Context {
    /// Load the runtime config (an optional TOML file plus the environment map) and start logging to stderr.
    pub fn load(config: Option<&Path>, env: &HashMap<String, String>) -> anyhow::Result<Self> {
        let bytes = match config {
            Some(path) => std::fs::read(path).with_context(|| format!("reading config file {}", path.display()))?,
            None => Vec::new(),
        };
        let config = RuntimeConfig::load(&bytes, env).map_err(|e| {
            let origin = config.map_or_else(|| "environment".to_owned(), |p| p.display().to_string());
            invalid(format!("runtime config ({origin}): {e}"))
        })?;
        plumbline_runtime::init_tracing(&config.log, env.get("RUST_LOG").map(String::as_str))
            .map_err(|e| invalid(format!("logging: {e}")))?;
        Ok(Self { s3: config.store.s3 })
    }

    /// Read a whole file named by path or URL. A missing file is invalid input.
    pub async fn read(&self, url: &str) -> anyhow::Result<Bytes> {
        plumbline_runtime::read_url(url, &self.s3).await.map_err(|e| {
            if e.kind() == StoreErrorKind::NotFound { invalid(format!("{url}: not found")) } else { e.into() }
        })
    }

    /// Whether the object a path or URL names exists.
    pub async fn exists(&self, url: &str) -> anyhow::Result<bool> {
        match plumbline_runtime::head_url(url, &self.s3).await {
            Ok(()) => Ok(true),
            Err(e) if e.kind() == StoreErrorKind::NotFound => Ok(false),
            Err(e) => Err(e.into()),
        }
    }

    /// Write a whole file named by path or URL, replacing it.
    pub async fn write(&self, url: &str, bytes: Vec<u8>) -> anyhow::Result<()> {
        plumbline_runtime::write_url(url, &self.s3, Bytes::from(bytes)).await.with_context(|| format!("writing {url}"))
    }
}

/// The last path segment of a path or URL, for messages.
pub fn file_name(url: &str) -> &str {
    url.rsplit(['/', '\\']).next().filter(|s| !s.is_empty()).unwrap_or(url)
}
