//! Tests of `RuntimeConfig::load`: defaults, unknown keys, env overrides, secret sources, validation.

use std::collections::HashMap;
use std::io::Write;

use plumbline_runtime::config::{DEFAULT_LOG_FILTER, DEFAULT_STORE_URL};
use plumbline_runtime::{ConfigError, LogFormat, RuntimeConfig, Secret};

fn env(pairs: &[(&str, &str)]) -> HashMap<String, String> {
    pairs.iter().map(|(k, v)| ((*k).to_owned(), (*v).to_owned())).collect()
}

fn load(toml: &str, pairs: &[(&str, &str)]) -> Result<RuntimeConfig, ConfigError> {
    RuntimeConfig::load(toml.as_bytes(), &env(pairs))
}

fn load_ok(toml: &str, pairs: &[(&str, &str)]) -> RuntimeConfig {
    load(toml, pairs).unwrap_or_else(|e| panic!("config should load: {e}"))
}

/// Loads, expects an error, and checks its message contains each of `needles`.
fn check_err(toml: &str, pairs: &[(&str, &str)], needles: &[&str]) {
    let message = load(toml, pairs).expect_err("config should be rejected").to_string();
    for needle in needles {
        assert!(message.contains(needle), "`{needle}` not in: {message}");
    }
}

fn secret_file(contents: &str) -> tempfile::NamedTempFile {
    let mut file = tempfile::NamedTempFile::new().expect("temp file");
    file.write_all(contents.as_bytes()).expect("write secret");
    file
}

const FULL: &str = r#"
otlp_endpoint = "http://otel:4317"
[store]
url = "s3://bucket/campaigns"
[store.s3]
endpoint = "http://minio:9000"
region = "eu-central-1"
access_key_id = "AKIA"
secret_access_key = "from-config"
allow_http = true
[nats]
url = "nats://nats:4222"
token = "nats-from-config"
[log]
format = "json"
filter = "warn,plumbline=debug"
"#;

#[test]
fn empty_bytes_give_defaults() {
    let config = load_ok("", &[]);
    assert_eq!(config, RuntimeConfig::default());
    assert_eq!(config.store.url, DEFAULT_STORE_URL);
    assert_eq!(config.log.filter, DEFAULT_LOG_FILTER);
    assert_eq!(config.log.format, LogFormat::Pretty);
    assert!(config.nats.is_none() && config.otlp_endpoint.is_none());
}

#[test]
fn full_config_is_read() {
    let config = load_ok(FULL, &[]);
    assert_eq!(config.store.url, "s3://bucket/campaigns");
    assert_eq!(config.store.s3.endpoint.as_deref(), Some("http://minio:9000"));
    assert_eq!(config.store.s3.region.as_deref(), Some("eu-central-1"));
    assert_eq!(config.store.s3.secret_access_key, Some(Secret::new("from-config")));
    assert!(config.store.s3.allow_http);
    let nats = config.nats.expect("nats section");
    assert_eq!(nats.url, "nats://nats:4222");
    assert_eq!(nats.token, Some(Secret::new("nats-from-config")));
    assert_eq!(config.log.format, LogFormat::Json);
    assert_eq!(config.otlp_endpoint.as_deref(), Some("http://otel:4317"));
}

#[test]
fn unknown_keys_are_named() {
    check_err("colour = 1", &[], &["colour"]);
    check_err("[store]\nurll = \"x\"", &[], &["urll"]);
    check_err("[store.s3]\nsecret = \"x\"", &[], &["secret"]);
    check_err("[log]\nformat = \"xml\"", &[], &["xml"]);
}

#[test]
fn env_overrides_main_fields() {
    let config = load_ok(
        FULL,
        &[
            ("PLUMBLINE_STORE_URL", "file:///srv/plumbline"),
            ("PLUMBLINE_NATS_URL", "nats://other:4222"),
            ("PLUMBLINE_LOG_FORMAT", "pretty"),
            ("PLUMBLINE_LOG_FILTER", "debug"),
            ("PLUMBLINE_S3_ENDPOINT", "https://s3.example"),
            ("PLUMBLINE_S3_ALLOW_HTTP", "false"),
            ("PLUMBLINE_OTLP_ENDPOINT", ""),
        ],
    );
    assert_eq!(config.store.url, "file:///srv/plumbline");
    assert_eq!(config.nats.map(|n| n.url).as_deref(), Some("nats://other:4222"));
    assert_eq!(config.log.format, LogFormat::Pretty);
    assert_eq!(config.log.filter, "debug");
    assert_eq!(config.store.s3.endpoint.as_deref(), Some("https://s3.example"));
    assert!(!config.store.s3.allow_http);
    assert_eq!(config.otlp_endpoint.as_deref(), Some("http://otel:4317"), "empty env value counts as unset");
}

#[test]
fn env_nats_url_creates_the_nats_section() {
    let config = load_ok("", &[("PLUMBLINE_NATS_URL", "nats://127.0.0.1:4222")]);
    assert_eq!(config.nats.map(|n| n.url).as_deref(), Some("nats://127.0.0.1:4222"));
}

#[test]
fn bad_env_values_name_the_variable() {
    check_err("", &[("PLUMBLINE_LOG_FORMAT", "xml")], &["PLUMBLINE_LOG_FORMAT", "xml"]);
    check_err("", &[("PLUMBLINE_S3_ALLOW_HTTP", "maybe")], &["PLUMBLINE_S3_ALLOW_HTTP", "maybe"]);
}

#[test]
fn secret_from_env_beats_config() {
    let config = load_ok(FULL, &[("PLUMBLINE_S3_SECRET_ACCESS_KEY", "from-env"), ("PLUMBLINE_NATS_TOKEN", "t-env")]);
    assert_eq!(config.store.s3.secret_access_key, Some(Secret::new("from-env")));
    assert_eq!(config.nats.and_then(|n| n.token), Some(Secret::new("t-env")));
}

#[test]
fn secret_from_env_file_trims_trailing_newline() {
    let file = secret_file("from-file\r\n");
    let path = file.path().to_str().expect("utf-8 temp path");
    let config = load_ok(FULL, &[("PLUMBLINE_S3_SECRET_ACCESS_KEY_FILE", path)]);
    assert_eq!(config.store.s3.secret_access_key, Some(Secret::new("from-file")));
}

#[test]
fn secret_from_config_file_key() {
    let file = secret_file("s3cret\n");
    let toml = format!(
        "[store.s3]\naccess_key_id = \"AKIA\"\nsecret_access_key_file = {:?}\n[nats]\nurl = \"nats://n:4222\"\ntoken_file = {:?}\n",
        file.path(),
        file.path()
    );
    let config = load_ok(&toml, &[]);
    assert_eq!(config.store.s3.secret_access_key, Some(Secret::new("s3cret")));
    assert_eq!(config.nats.and_then(|n| n.token), Some(Secret::new("s3cret")));
}

#[test]
fn secret_file_problems_are_reported() {
    let missing = "/nonexistent/plumbline-secret";
    check_err("", &[("PLUMBLINE_S3_SECRET_ACCESS_KEY_FILE", missing)], &[missing, "store.s3.secret_access_key"]);
    let empty = secret_file("\n");
    let path = empty.path().to_str().expect("utf-8 temp path");
    check_err("", &[("PLUMBLINE_S3_SECRET_ACCESS_KEY_FILE", path)], &["empty"]);
}

#[test]
fn two_sources_at_one_level_conflict() {
    let file = secret_file("x");
    let path = file.path().to_str().expect("utf-8 temp path");
    check_err(
        "",
        &[("PLUMBLINE_S3_SECRET_ACCESS_KEY", "a"), ("PLUMBLINE_S3_SECRET_ACCESS_KEY_FILE", path)],
        &["PLUMBLINE_S3_SECRET_ACCESS_KEY_FILE"],
    );
    let toml = format!("[store.s3]\nsecret_access_key = \"a\"\nsecret_access_key_file = {path:?}\n");
    check_err(&toml, &[], &["secret_access_key_file"]);
}

#[test]
fn secrets_do_not_show_in_debug() {
    let debug = format!("{:?}", load_ok(FULL, &[]));
    assert!(!debug.contains("from-config") && !debug.contains("nats-from-config"), "{debug}");
    assert!(debug.contains("***"), "{debug}");
}

#[test]
fn a_role_user_and_its_password_come_from_the_environment() {
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("nats-worker");
    std::fs::write(&secret, "pw-from-file\n").unwrap();
    let env = [
        ("PLUMBLINE_NATS_URL", "nats://nats:4222"),
        ("PLUMBLINE_NATS_USER", "worker"),
        ("PLUMBLINE_NATS_PASSWORD_FILE", secret.to_str().unwrap()),
        ("PLUMBLINE_NATS_TLS_CA_FILE", "/etc/ca.pem"),
    ];
    let nats = load_ok("", &env).nats.expect("the environment creates the nats section");
    assert_eq!(nats.user.as_deref(), Some("worker"));
    assert_eq!(nats.password, Some(Secret::new("pw-from-file")));
    assert_eq!(nats.tls_ca_file.as_deref(), Some(std::path::Path::new("/etc/ca.pem")));
    assert!(nats.has_credentials() && nats.token.is_none());
    assert!(!format!("{nats:?}").contains("pw-from-file"));
}

#[test]
fn invalid_values_are_named() {
    check_err("[store]\nurl = \"gs://bucket\"", &[], &["store.url", "gs"]);
    check_err("[store]\nurl = \"s3:///x\"", &[], &["missing bucket"]);
    check_err("[store.s3]\nendpoint = \"http://minio:9000\"", &[], &["allow_http"]);
    check_err("[store.s3]\naccess_key_id = \"AKIA\"", &[], &["secret_access_key"]);
    check_err("[nats]\nurl = \"http://nats:4222\"", &[], &["nats.url"]);
    check_err("[nats]\ntoken = \"t\"", &[], &["nats.url", "missing"]);
    check_err("[nats]\nurl = \"nats://n:4222\"\ntoken = \"t\"\ncreds_file = \"/c.creds\"", &[], &["choose one"]);
    check_err(
        "[nats]\nurl = \"nats://n:4222\"\ntoken = \"t\"\nuser = \"worker\"\npassword = \"p\"",
        &[],
        &["choose one"],
    );
    check_err("[nats]\nurl = \"nats://n:4222\"\nuser = \"worker\"", &[], &["nats.password", "missing"]);
    check_err("[nats]\nurl = \"nats://n:4222\"\npassword = \"p\"", &[], &["nats.user", "missing"]);
    check_err("[log]\nfilter = \"info,[[\"", &[], &["log.filter"]);
    check_err("otlp_endpoint = \"not a url\"", &[], &["otlp_endpoint"]);
    check_err("", &[("PLUMBLINE_STORE_URL", "ftp://x")], &["ftp"]);
}

#[test]
fn non_utf8_is_rejected() {
    let err = RuntimeConfig::load(&[0xff, 0xfe], &HashMap::new()).expect_err("not utf-8");
    assert!(matches!(err, ConfigError::NotUtf8(_)), "{err}");
}
