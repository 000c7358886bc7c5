//! Checks on a resolved [`RuntimeConfig`] that need more than types: URL syntax, exclusive options, log filter syntax.

use tracing_subscriber::EnvFilter;
use url::Url;

use super::error::ConfigError;
use super::{NatsConfig, RuntimeConfig};
use crate::store::StoreLocation;

pub(super) fn validate(config: &RuntimeConfig) -> Result<(), ConfigError> {
    StoreLocation::parse(&config.store.url).map_err(|e| ConfigError::invalid("store.url", e.to_string()))?;
    config.store.s3.validate().map_err(|reason| ConfigError::invalid("store.s3", reason))?;
    if let Some(nats) = &config.nats {
        validate_nats(nats)?;
    }
    EnvFilter::try_new(&config.log.filter)
        .map_err(|e| ConfigError::invalid("log.filter", format!("`{}`: {e}", config.log.filter)))?;
    if let Some(endpoint) = &config.otlp_endpoint {
        check_url("otlp_endpoint", endpoint, &["http", "https"])?; // OTLP/HTTP only: see crate::telemetry
    }
    Ok(())
}

fn validate_nats(nats: &NatsConfig) -> Result<(), ConfigError> {
    check_url("nats.url", &nats.url, &["nats", "tls", "ws", "wss"])?;
    let ways = [nats.token.is_some(), nats.creds_file.is_some(), nats.user.is_some()];
    if ways.iter().filter(|set| **set).count() > 1 {
        return Err(ConfigError::Conflict(
            "more than one of nats.token, nats.creds_file and nats.user are set; choose one".to_owned(),
        ));
    }
    match (&nats.user, &nats.password) {
        (Some(_), None) => return Err(ConfigError::invalid("nats.password", "missing: nats.user needs a password")),
        (None, Some(_)) => return Err(ConfigError::invalid("nats.user", "missing: nats.password needs a user")),
        _ => {}
    }
    Ok(())
}

fn check_url(field: &str, value: &str, schemes: &[&str]) -> Result<(), ConfigError> {
    let url = Url::parse(value).map_err(|e| ConfigError::invalid(field, format!("`{value}` is not a URL: {e}")))?;
    if !schemes.contains(&url.scheme()) {
        let expected = schemes.join(", ");
        return Err(ConfigError::invalid(field, format!("`{value}`: scheme must be one of {expected}")));
    }
    Ok(())
}
