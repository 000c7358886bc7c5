//! Reading and writing the files a command names, by path or object-store URL, with the runtime config.

use std::collections::HashMap;
use std::path::Path;

use anyhow::Context as _;
use bytes::Bytes;
pub use plumbline_runtime::file_name;
use plumbline_runtime::{Files, NatsConfig, OtlpExport, RuntimeConfig, TracingGuard};

use crate::exit::invalid;

/// What every command needs from the runtime: how to reach object stores; it also holds the span
/// exporter, which sends its last spans when the context is dropped.
#[derive(Debug)]
pub struct Context {
    files: Files,
    nats: Option<NatsConfig>,
    _tracing: TracingGuard,
}

impl Context {
    /// Load the runtime config (an optional TOML file plus the environment map) and start logging to stderr,
    /// and exporting spans as `service` (e.g. `plumbline-worker`) when `otlp_endpoint` is configured.
    pub fn load(config: Option<&Path>, env: &HashMap<String, String>, service: &str) -> anyhow::Result<Self> {
        let bytes = match config {
            Some(path) => std::fs::read(path).with_context(|| format!("reading config file {}", path.display()))?,
            None => Vec::new(),
        };
        let config = RuntimeConfig::load(&bytes, env).map_err(|e| {
            let origin = config.map_or_else(|| "environment".to_owned(), |p| p.display().to_string());
            invalid(format!("runtime config ({origin}): {e}"))
        })?;
        let otlp = config.otlp_endpoint.map(|endpoint| OtlpExport { endpoint, service_name: service.to_owned() });
        let tracing =
            plumbline_runtime::init_tracing(&config.log, env.get("RUST_LOG").map(String::as_str), otlp.as_ref())
                .map_err(|e| invalid(format!("logging: {e}")))?;
        Ok(Self { files: Files::new(config.store.s3), nats: config.nats, _tracing: tracing })
    }

    /// The file access the services' libraries take.
    pub fn files(&self) -> &Files {
        &self.files
    }

    /// The `[nats]` section of the runtime config (URL, credentials, TLS), if any.
    pub fn nats(&self) -> Option<&NatsConfig> {
        self.nats.as_ref()
    }

    /// Read a whole file named by path or URL. A missing file is invalid input.
    pub async fn read(&self, url: &str) -> anyhow::Result<Bytes> {
        Ok(self.files.read(url).await?)
    }

    /// Whether the object a path or URL names exists.
    pub async fn exists(&self, url: &str) -> anyhow::Result<bool> {
        Ok(self.files.exists(url).await?)
    }

    /// Write a whole file named by path or URL, replacing it.
    pub async fn write(&self, url: &str, bytes: Vec<u8>) -> anyhow::Result<()> {
        Ok(self.files.write(url, bytes).await?)
    }
}
