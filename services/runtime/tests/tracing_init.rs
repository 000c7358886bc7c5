//! `init_tracing` installs a global subscriber once; its own test binary, since the subscriber is process-wide.

use plumbline_runtime::{LogConfig, LogFormat, TracingError, init_tracing};

#[test]
fn second_init_is_an_error_not_a_panic() {
    let config = LogConfig { format: LogFormat::Json, filter: "info".to_owned() };
    let bad = init_tracing(&config, Some("info,[[")).expect_err("invalid RUST_LOG");
    assert!(matches!(bad, TracingError::Filter { .. }), "{bad}");
    init_tracing(&config, Some("debug")).expect("first init");
    tracing::info!(answer = 42, "tracing initialised");
    let again = init_tracing(&config, None).expect_err("second init");
    assert!(matches!(again, TracingError::AlreadyInitialised(_)), "{again}");
}
