//! `init_tracing` installs a global subscriber once; its own test binary, since the subscriber is process-wide.

use plumbline_runtime::{LogConfig, LogFormat, OtlpExport, TelemetryError, TracingError, init_tracing};

#[test]
fn second_init_is_an_error_not_a_panic() {
    let config = LogConfig { format: LogFormat::Json, filter: "info".to_owned() };
    let bad = init_tracing(&config, Some("info,[["), None).expect_err("invalid RUST_LOG");
    assert!(matches!(bad, TracingError::Filter { .. }), "{bad}");
    let grpc = OtlpExport { endpoint: "grpc://otel:4317".to_owned(), service_name: "plumbline-test".to_owned() };
    let refused = init_tracing(&config, None, Some(&grpc)).expect_err("gRPC is not built in");
    assert!(matches!(refused, TracingError::Telemetry(TelemetryError::Scheme { .. })), "{refused}");
    let guard = init_tracing(&config, Some("debug"), None).expect("first init");
    assert!(guard.exporting_to().is_none());
    tracing::info!(answer = 42, "tracing initialised");
    let again = init_tracing(&config, None, None).expect_err("second init");
    assert!(matches!(again, TracingError::AlreadyInitialised(_)), "{again}");
    guard.shutdown().expect("nothing to flush");
}
