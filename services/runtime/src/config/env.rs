//! `PLUMBLINE_*` environment overrides of the plain (non-secret) config fields, applied to the raw config.

use std::collections::HashMap;
use std::path::PathBuf;

use super::error::ConfigError;
use super::raw::{RawConfig, RawNats};

pub(super) const STORE_URL: &str = "PLUMBLINE_STORE_URL";
pub(super) const S3_ENDPOINT: &str = "PLUMBLINE_S3_ENDPOINT";
pub(super) const S3_REGION: &str = "PLUMBLINE_S3_REGION";
pub(super) const S3_ACCESS_KEY_ID: &str = "PLUMBLINE_S3_ACCESS_KEY_ID";
pub(super) const S3_ALLOW_HTTP: &str = "PLUMBLINE_S3_ALLOW_HTTP";
pub(super) const S3_VIRTUAL_HOSTED_STYLE: &str = "PLUMBLINE_S3_VIRTUAL_HOSTED_STYLE";
pub(super) const S3_SECRET_ACCESS_KEY: &str = "PLUMBLINE_S3_SECRET_ACCESS_KEY";
pub(super) const NATS_URL: &str = "PLUMBLINE_NATS_URL";
pub(super) const NATS_CREDS_FILE: &str = "PLUMBLINE_NATS_CREDS_FILE";
pub(super) const NATS_TOKEN: &str = "PLUMBLINE_NATS_TOKEN";
pub(super) const NATS_USER: &str = "PLUMBLINE_NATS_USER";
pub(super) const NATS_PASSWORD: &str = "PLUMBLINE_NATS_PASSWORD";
pub(super) const NATS_TLS_CA_FILE: &str = "PLUMBLINE_NATS_TLS_CA_FILE";
pub(super) const LOG_FORMAT: &str = "PLUMBLINE_LOG_FORMAT";
pub(super) const LOG_FILTER: &str = "PLUMBLINE_LOG_FILTER";
pub(super) const OTLP_ENDPOINT: &str = "PLUMBLINE_OTLP_ENDPOINT";

/// The value of `var`; an empty value counts as unset (compose files often write `VAR=`).
pub(super) fn lookup<'a>(env: &'a HashMap<String, String>, var: &str) -> Option<&'a str> {
    env.get(var).map(String::as_str).filter(|v| !v.is_empty())
}

/// Overwrites each field whose variable is set.
pub(super) fn apply_overrides(raw: &mut RawConfig, env: &HashMap<String, String>) -> Result<(), ConfigError> {
    set_string(&mut raw.store.url, env, STORE_URL);
    set_string(&mut raw.store.s3.endpoint, env, S3_ENDPOINT);
    set_string(&mut raw.store.s3.region, env, S3_REGION);
    set_string(&mut raw.store.s3.access_key_id, env, S3_ACCESS_KEY_ID);
    set_parsed(&mut raw.store.s3.allow_http, env, S3_ALLOW_HTTP, parse_bool)?;
    set_parsed(&mut raw.store.s3.virtual_hosted_style, env, S3_VIRTUAL_HOSTED_STYLE, parse_bool)?;
    set_parsed(&mut raw.log.format, env, LOG_FORMAT, |v| v.parse())?;
    set_string(&mut raw.log.filter, env, LOG_FILTER);
    set_string(&mut raw.otlp_endpoint, env, OTLP_ENDPOINT);
    apply_nats_overrides(raw, env);
    Ok(())
}

/// A NATS variable creates the `[nats]` section when the file has none.
fn apply_nats_overrides(raw: &mut RawConfig, env: &HashMap<String, String>) {
    let wanted = [
        NATS_URL,
        NATS_CREDS_FILE,
        NATS_TOKEN,
        &format!("{NATS_TOKEN}_FILE"),
        NATS_USER,
        NATS_PASSWORD,
        &format!("{NATS_PASSWORD}_FILE"),
        NATS_TLS_CA_FILE,
    ]
    .iter()
    .any(|var| lookup(env, var).is_some());
    if raw.nats.is_none() && wanted {
        raw.nats = Some(RawNats::default());
    }
    if let Some(nats) = raw.nats.as_mut() {
        set_string(&mut nats.url, env, NATS_URL);
        set_string(&mut nats.user, env, NATS_USER);
        if let Some(path) = lookup(env, NATS_CREDS_FILE) {
            nats.creds_file = Some(PathBuf::from(path));
        }
        if let Some(path) = lookup(env, NATS_TLS_CA_FILE) {
            nats.tls_ca_file = Some(PathBuf::from(path));
        }
    }
}

fn set_string(field: &mut Option<String>, env: &HashMap<String, String>, var: &str) {
    if let Some(value) = lookup(env, var) {
        *field = Some(value.to_owned());
    }
}

fn set_parsed<T>(
    field: &mut Option<T>,
    env: &HashMap<String, String>,
    var: &str,
    parse: impl Fn(&str) -> Result<T, String>,
) -> Result<(), ConfigError> {
    if let Some(value) = lookup(env, var) {
        *field = Some(parse(value).map_err(|reason| ConfigError::Env { var: var.to_owned(), reason })?);
    }
    Ok(())
}

fn parse_bool(value: &str) -> Result<bool, String> {
    match value.to_ascii_lowercase().as_str() {
        "1" | "true" | "yes" | "on" => Ok(true),
        "0" | "false" | "no" | "off" => Ok(false),
        _ => Err(format!("`{value}` is not a boolean (true/false)")),
    }
}
