//! Resolving a secret from env, env `*_FILE`, the config value or the config `*_file`; the loader's only I/O.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::env::lookup;
use super::error::ConfigError;
use crate::secret::Secret;

/// The places one secret may come from.
pub(super) struct SecretSources<'a> {
    /// Config key, for messages, e.g. `store.s3.secret_access_key`.
    pub name: &'a str,
    /// Environment variable; `{env_var}_FILE` names a file holding the value.
    pub env_var: &'a str,
    pub config_value: Option<Secret>,
    pub config_file: Option<PathBuf>,
}

/// First found wins: env value, env file, config value, config file. Two sources at the same
/// level (a value and a file) are a conflict rather than a silent choice.
pub(super) fn resolve(
    sources: SecretSources<'_>,
    env: &HashMap<String, String>,
) -> Result<Option<Secret>, ConfigError> {
    let file_var = format!("{}_FILE", sources.env_var);
    match (lookup(env, sources.env_var), lookup(env, &file_var)) {
        (Some(_), Some(_)) => {
            return Err(ConfigError::Conflict(format!("both {} and {file_var} are set", sources.env_var)));
        }
        (Some(value), None) => return Ok(Some(Secret::new(value))),
        (None, Some(path)) => return read_secret_file(sources.name, Path::new(path)).map(Some),
        (None, None) => {}
    }
    match (sources.config_value, sources.config_file) {
        (Some(_), Some(_)) => Err(ConfigError::Conflict(format!("both `{0}` and `{0}_file` are set", sources.name))),
        (Some(value), None) => Ok(Some(value)),
        (None, Some(path)) => read_secret_file(sources.name, &path).map(Some),
        (None, None) => Ok(None),
    }
}

/// Reads a secret file (Docker/Kubernetes secret style), dropping trailing newlines.
fn read_secret_file(name: &str, path: &Path) -> Result<Secret, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::SecretFile {
        name: name.to_owned(),
        path: path.to_owned(),
        source,
    })?;
    let value = text.trim_end_matches(['\r', '\n']);
    if value.is_empty() {
        return Err(ConfigError::EmptySecretFile { name: name.to_owned(), path: path.to_owned() });
    }
    Ok(Secret::new(value))
}
