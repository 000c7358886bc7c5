//! The services' runtime config: one loader from TOML bytes plus an environment map, validated once.
//!
//! ```toml
//! otlp_endpoint = "http://otel-collector:4318"   # optional: OTLP/HTTP traces
//!
//! [store]
//! url = "s3://plumbline/campaigns"               # default "./plumbline-data" (a local directory)
//! [store.s3]
//! endpoint = "http://minio:9000"
//! region = "us-east-1"
//! access_key_id = "plumbline"
//! secret_access_key_file = "/run/secrets/s3"     # or secret_access_key = "…"
//! allow_http = true
//! virtual_hosted_style = false
//!
//! [nats]                                         # optional: absent means the in-process queue
//! url = "nats://nats:4222"
//! user = "worker"                                # one role's user (deploy/nats.conf gives each role
//! password_file = "/run/secrets/nats-worker"     #   its subject permissions); or token / token_file,
//!                                                #   or creds_file = "/path/user.creds" (JWT + nkey)
//! tls_ca_file = "/run/secrets/nats-ca.pem"       # optional: require TLS, trusting this CA
//!
//! [log]
//! format = "json"                                # "pretty" (default) or "json"
//! filter = "info,plumbline=debug"                # default "info"
//! ```
//!
//! Environment overrides (an empty value counts as unset): `PLUMBLINE_STORE_URL`,
//! `PLUMBLINE_S3_ENDPOINT`, `PLUMBLINE_S3_REGION`, `PLUMBLINE_S3_ACCESS_KEY_ID`,
//! `PLUMBLINE_S3_ALLOW_HTTP`, `PLUMBLINE_S3_VIRTUAL_HOSTED_STYLE`, `PLUMBLINE_NATS_URL`,
//! `PLUMBLINE_NATS_CREDS_FILE`, `PLUMBLINE_NATS_USER`, `PLUMBLINE_NATS_TLS_CA_FILE`, `PLUMBLINE_LOG_FORMAT`,
//! `PLUMBLINE_LOG_FILTER`, `PLUMBLINE_OTLP_ENDPOINT`. Secrets: `PLUMBLINE_S3_SECRET_ACCESS_KEY`,
//! `PLUMBLINE_NATS_TOKEN` and `PLUMBLINE_NATS_PASSWORD`, each also as `…_FILE` naming a file; precedence env
//! value, env file, config value, config file.

mod env;
mod error;
mod raw;
mod secrets;
mod validate;

use std::collections::HashMap;
use std::path::PathBuf;
use std::str::FromStr;

use serde::Deserialize;

pub use error::ConfigError;
use raw::{RawConfig, RawNats, RawS3};
use secrets::SecretSources;

use crate::secret::Secret;
use crate::store::S3Options;

/// Store used when neither the config nor `PLUMBLINE_STORE_URL` names one: a directory
/// `plumbline-data` under the working directory, so a first `plumbline run` needs nothing set up.
pub const DEFAULT_STORE_URL: &str = "./plumbline-data";
/// Log filter used when the config names none.
pub const DEFAULT_LOG_FILTER: &str = "info";

/// Validated runtime config of a plumbline process; `Default` is what empty bytes and no env give.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RuntimeConfig {
    pub store: StoreConfig,
    /// `None`: no NATS configured (the embedded, in-process queue).
    pub nats: Option<NatsConfig>,
    pub log: LogConfig,
    /// OpenTelemetry collector endpoint for traces, if any.
    pub otlp_endpoint: Option<String>,
}

/// Where campaign data lives: a store URL for [`crate::open_store`] and its S3 options.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StoreConfig {
    pub url: String,
    pub s3: S3Options,
}

/// How to reach NATS. At most one way of authenticating is set: `token`, `creds_file`, or `user` with
/// `password`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NatsConfig {
    pub url: String,
    pub token: Option<Secret>,
    /// A NATS `.creds` file (JWT + nkey seed), handed to the client, which reads it.
    pub creds_file: Option<PathBuf>,
    /// A user of the server's `authorization { users = [...] }`, with its `password`.
    pub user: Option<String>,
    pub password: Option<Secret>,
    /// When set, the connection must use TLS and the server's certificate must chain to this CA (PEM).
    pub tls_ca_file: Option<PathBuf>,
}

impl NatsConfig {
    /// Whether any credentials are configured.
    pub fn has_credentials(&self) -> bool {
        self.token.is_some() || self.creds_file.is_some() || self.user.is_some()
    }
}

/// Log output: format and an `EnvFilter` directive string.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogConfig {
    pub format: LogFormat,
    pub filter: String,
}

/// Human-readable multi-line output, or one JSON object per event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LogFormat {
    #[default]
    Pretty,
    Json,
}

impl FromStr for LogFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "pretty" => Ok(Self::Pretty),
            "json" => Ok(Self::Json),
            other => Err(format!("unknown log format `{other}` (expected pretty or json)")),
        }
    }
}

impl Default for LogConfig {
    fn default() -> Self {
        Self { format: LogFormat::default(), filter: DEFAULT_LOG_FILTER.to_owned() }
    }
}

impl Default for StoreConfig {
    fn default() -> Self {
        Self { url: DEFAULT_STORE_URL.to_owned(), s3: S3Options::default() }
    }
}

impl RuntimeConfig {
    /// Parses TOML `bytes` (empty means all defaults), applies `PLUMBLINE_*` overrides from `env`,
    /// resolves secrets (reading any `*_file`) and validates. `env` is usually `std::env::vars().collect()`.
    pub fn load(bytes: &[u8], env: &HashMap<String, String>) -> Result<Self, ConfigError> {
        let mut raw: RawConfig = toml::from_str(std::str::from_utf8(bytes)?)?;
        env::apply_overrides(&mut raw, env)?;
        let config = Self {
            store: StoreConfig {
                url: raw.store.url.unwrap_or_else(|| DEFAULT_STORE_URL.to_owned()),
                s3: resolve_s3(raw.store.s3, env)?,
            },
            nats: raw.nats.map(|nats| resolve_nats(nats, env)).transpose()?,
            log: LogConfig {
                format: raw.log.format.unwrap_or_default(),
                filter: raw.log.filter.unwrap_or_else(|| DEFAULT_LOG_FILTER.to_owned()),
            },
            otlp_endpoint: raw.otlp_endpoint,
        };
        validate::validate(&config)?;
        Ok(config)
    }
}

fn resolve_s3(raw: RawS3, env: &HashMap<String, String>) -> Result<S3Options, ConfigError> {
    let sources = SecretSources {
        name: "store.s3.secret_access_key",
        env_var: env::S3_SECRET_ACCESS_KEY,
        config_value: raw.secret_access_key,
        config_file: raw.secret_access_key_file,
    };
    Ok(S3Options {
        endpoint: raw.endpoint,
        region: raw.region,
        access_key_id: raw.access_key_id,
        secret_access_key: secrets::resolve(sources, env)?,
        allow_http: raw.allow_http.unwrap_or(false),
        virtual_hosted_style: raw.virtual_hosted_style.unwrap_or(false),
    })
}

fn resolve_nats(raw: RawNats, env: &HashMap<String, String>) -> Result<NatsConfig, ConfigError> {
    let sources = SecretSources {
        name: "nats.token",
        env_var: env::NATS_TOKEN,
        config_value: raw.token,
        config_file: raw.token_file,
    };
    let url =
        raw.url.ok_or_else(|| ConfigError::invalid("nats.url", format!("missing (set it or {})", env::NATS_URL)))?;
    let token = secrets::resolve(sources, env)?;
    let sources = SecretSources {
        name: "nats.password",
        env_var: env::NATS_PASSWORD,
        config_value: raw.password,
        config_file: raw.password_file,
    };
    let password = secrets::resolve(sources, env)?;
    Ok(NatsConfig { url, token, creds_file: raw.creds_file, user: raw.user, password, tls_ca_file: raw.tls_ca_file })
}
