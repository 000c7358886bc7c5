//! Installing the process-wide `tracing` subscriber: pretty or JSON lines on stderr, filtered by `EnvFilter`,
//! plus OTLP span export when an endpoint is configured (see [`crate::telemetry`]).

use tracing_subscriber::EnvFilter;
use tracing_subscriber::Layer as _;
use tracing_subscriber::layer::SubscriberExt as _;
use tracing_subscriber::util::SubscriberInitExt as _;

use crate::config::{LogConfig, LogFormat};
use crate::telemetry::{OtlpExport, Telemetry, TelemetryError};

/// The port collectors conventionally serve OTLP/gRPC on, which this (HTTP-only) exporter cannot talk to.
const OTLP_GRPC_PORT: u16 = 4317;

/// Why the subscriber was not installed.
#[derive(Debug, thiserror::Error)]
pub enum TracingError {
    #[error("invalid log filter `{filter}`: {source}")]
    Filter {
        filter: String,
        #[source]
        source: tracing_subscriber::filter::ParseError,
    },
    /// A global subscriber (or `log` logger) is already installed, e.g. by an earlier call.
    #[error("tracing is already initialised: {0}")]
    AlreadyInitialised(String),
    #[error(transparent)]
    Telemetry(#[from] TelemetryError),
}

/// Keeps the span exporter (if any) alive; dropping it flushes the spans still queued. Hold it until the
/// process is about to exit.
#[must_use = "dropping the guard stops trace export"]
#[derive(Debug, Default)]
pub struct TracingGuard {
    telemetry: Option<Telemetry>,
}

impl TracingGuard {
    /// The collector's traces URL when spans are exported.
    pub fn exporting_to(&self) -> Option<&url::Url> {
        self.telemetry.as_ref().map(Telemetry::traces_url)
    }

    /// Flushes the exporter and stops it, reporting a failure instead of printing it.
    pub fn shutdown(self) -> Result<(), TelemetryError> {
        self.telemetry.map_or(Ok(()), Telemetry::shutdown)
    }
}

/// The filter directives in force: `rust_log` (the caller passes `RUST_LOG`'s value) when set and
/// non-empty, else the config's filter.
pub fn effective_filter<'a>(config: &'a LogConfig, rust_log: Option<&'a str>) -> &'a str {
    rust_log.map(str::trim).filter(|s| !s.is_empty()).unwrap_or(&config.filter)
}

/// Installs the global subscriber writing to stderr and, when `otlp` is given, exporting spans to that
/// collector. A second call returns [`TracingError::AlreadyInitialised`] instead of panicking.
pub fn init_tracing(
    config: &LogConfig,
    rust_log: Option<&str>,
    otlp: Option<&OtlpExport>,
) -> Result<TracingGuard, TracingError> {
    let directives = effective_filter(config, rust_log);
    let filter = EnvFilter::try_new(directives)
        .map_err(|source| TracingError::Filter { filter: directives.to_owned(), source })?;
    let telemetry = otlp.map(Telemetry::start).transpose()?;
    let ansi = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let fmt = tracing_subscriber::fmt::layer().with_writer(std::io::stderr).with_ansi(ansi);
    let fmt = match config.format {
        LogFormat::Pretty => fmt.pretty().boxed(),
        LogFormat::Json => fmt.json().boxed(),
    };
    let otel = telemetry.as_ref().map(Telemetry::layer);
    tracing_subscriber::registry()
        .with(filter)
        .with(fmt)
        .with(otel)
        .try_init()
        .map_err(|e| TracingError::AlreadyInitialised(e.to_string()))?;
    if let Some(url) = telemetry.as_ref().map(Telemetry::traces_url) {
        tracing::info!(%url, "exporting spans over OTLP/HTTP");
        if url.port_or_known_default() == Some(OTLP_GRPC_PORT) {
            tracing::warn!(%url, "port 4317 is the OTLP/gRPC port by convention; this exporter speaks OTLP/HTTP (4318)");
        }
    }
    Ok(TracingGuard { telemetry })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(config_filter: &str, rust_log: Option<&str>, expect: &str) {
        let config = LogConfig { format: LogFormat::Json, filter: config_filter.to_owned() };
        assert_eq!(effective_filter(&config, rust_log), expect);
    }

    #[test]
    fn rust_log_overrides_the_config_filter_unless_empty() {
        check("info", None, "info");
        check("info", Some("debug,h2=warn"), "debug,h2=warn");
        check("info", Some(""), "info");
        check("warn", Some("  "), "warn");
    }
}
