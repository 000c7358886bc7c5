//! `ConfigError`: why a runtime config was rejected, naming the key, variable or file at fault.

use std::path::PathBuf;

/// A rejected runtime config. Every variant names what to fix; none is worth retrying.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("config is not UTF-8: {0}")]
    NotUtf8(#[from] std::str::Utf8Error),
    /// Syntax errors, wrong types and unknown keys (the message names the key).
    #[error("config: {0}")]
    Toml(#[from] toml::de::Error),
    #[error("environment variable {var}: {reason}")]
    Env { var: String, reason: String },
    #[error("cannot read secret `{name}` from file {}: {source}", path.display())]
    SecretFile {
        name: String,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("secret `{name}` from file {}: the file is empty", path.display())]
    EmptySecretFile { name: String, path: PathBuf },
    /// Two sources for one value in the same place (a value and its `*_file`, or both env variables).
    #[error("conflicting settings: {0}")]
    Conflict(String),
    #[error("config `{field}`: {reason}")]
    Invalid { field: String, reason: String },
}

impl ConfigError {
    pub(crate) fn invalid(field: &str, reason: impl Into<String>) -> Self {
        Self::Invalid { field: field.to_owned(), reason: reason.into() }
    }
}
