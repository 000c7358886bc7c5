//! OpenTelemetry trace export: `tracing` spans to an OTLP collector over HTTP/protobuf, batched.
//!
//! The configured endpoint is the collector's base URL (`http://otel-collector:4318`); `/v1/traces` is
//! appended unless the path already ends with it. Only OTLP/HTTP is built in (reqwest's blocking client
//! on the batch processor's own thread, no gRPC stack): a `grpc://` endpoint is refused with an error
//! naming the HTTP port instead. The OpenTelemetry SDK itself still honours the standard
//! `OTEL_EXPORTER_OTLP_TRACES_{HEADERS,TIMEOUT,COMPRESSION}` variables (the endpoint is always ours).

use opentelemetry::KeyValue;
use opentelemetry::trace::TracerProvider as _;
use opentelemetry_otlp::{Protocol, WithExportConfig as _};
use opentelemetry_sdk::Resource;
use opentelemetry_sdk::trace::{SdkTracer, SdkTracerProvider};
use std::time::Duration;
use tracing::Subscriber;
use tracing_opentelemetry::OpenTelemetryLayer;
use tracing_subscriber::Layer;
use tracing_subscriber::filter::{FilterFn, Filtered};
use tracing_subscriber::registry::LookupSpan;
use url::Url;

/// Path of the OTLP/HTTP traces signal under the collector's base URL.
pub const TRACES_PATH: &str = "/v1/traces";
/// How long [`Telemetry::shutdown`] (and dropping the guard) waits for the last batch to be sent.
pub const SHUTDOWN_TIMEOUT: Duration = Duration::from_secs(5);
/// Crates whose own spans and events never go to the exporter: the exporter's HTTP stack and the
/// OpenTelemetry SDK itself (its internal log events would otherwise feed back into the export).
const EXPORTER_TARGETS: &[&str] = &[
    "opentelemetry",
    "opentelemetry_sdk",
    "opentelemetry_otlp",
    "opentelemetry_http",
    "reqwest",
    "hyper",
    "hyper_util",
    "h2",
    "tower",
];

/// Where and as whom to export spans.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OtlpExport {
    /// The collector's base URL, `http://` or `https://` (the runtime config's `otlp_endpoint`).
    pub endpoint: String,
    /// The OpenTelemetry `service.name` resource attribute, e.g. `plumbline-worker`.
    pub service_name: String,
}

/// Why trace export could not start or finish.
#[derive(Debug, thiserror::Error)]
pub enum TelemetryError {
    #[error("otlp_endpoint `{endpoint}` is not a URL: {source}")]
    Endpoint {
        endpoint: String,
        #[source]
        source: url::ParseError,
    },
    #[error(
        "otlp_endpoint `{endpoint}`: scheme `{scheme}` is not supported; this build exports OTLP over HTTP \
         (protobuf): use http:// or https:// and the collector's HTTP port (4318 by default)"
    )]
    Scheme { endpoint: String, scheme: String },
    #[error("otlp_endpoint `{endpoint}`: cannot build the OTLP/HTTP span exporter: {reason}")]
    Exporter { endpoint: String, reason: String },
    #[error("flushing or shutting down the OTLP span exporter: {0}")]
    Flush(String),
}

/// The full traces URL for a collector base URL: `/v1/traces` appended unless already there.
pub fn traces_url(endpoint: &str) -> Result<Url, TelemetryError> {
    let mut url =
        Url::parse(endpoint).map_err(|source| TelemetryError::Endpoint { endpoint: endpoint.to_owned(), source })?;
    if !matches!(url.scheme(), "http" | "https") {
        return Err(TelemetryError::Scheme { endpoint: endpoint.to_owned(), scheme: url.scheme().to_owned() });
    }
    let path = url.path().trim_end_matches('/');
    if !path.ends_with(TRACES_PATH) {
        let joined = format!("{path}{TRACES_PATH}");
        url.set_path(&joined);
    }
    Ok(url)
}

/// A running span exporter: the tracer provider with its batch processor (a thread of its own). Hand its
/// [`layer`](Self::layer) to a subscriber; dropping it (or [`shutdown`](Self::shutdown)) sends what is
/// still queued, waiting at most [`SHUTDOWN_TIMEOUT`].
#[derive(Debug)]
pub struct Telemetry {
    provider: SdkTracerProvider,
    traces_url: Url,
    shut_down: bool,
}

impl Telemetry {
    /// Builds the OTLP/HTTP exporter and the batch processor. No connection is made until the first batch.
    pub fn start(export: &OtlpExport) -> Result<Self, TelemetryError> {
        let traces_url = traces_url(&export.endpoint)?;
        let exporter = opentelemetry_otlp::SpanExporter::builder()
            .with_http()
            .with_protocol(Protocol::HttpBinary)
            .with_endpoint(traces_url.as_str())
            .build()
            .map_err(|e| TelemetryError::Exporter { endpoint: export.endpoint.clone(), reason: e.to_string() })?;
        let resource = Resource::builder_empty()
            .with_service_name(export.service_name.clone())
            .with_attribute(KeyValue::new("service.version", env!("CARGO_PKG_VERSION")))
            .build();
        let provider = SdkTracerProvider::builder().with_batch_exporter(exporter).with_resource(resource).build();
        Ok(Self { provider, traces_url, shut_down: false })
    }

    /// Where the spans go (the collector's traces URL).
    pub fn traces_url(&self) -> &Url {
        &self.traces_url
    }

    /// The layer turning `tracing` spans (with their fields as attributes) into exported spans. The
    /// exporter's own HTTP stack and the SDK's log events are filtered out of it.
    pub fn layer<S>(&self) -> Filtered<OpenTelemetryLayer<S, SdkTracer>, FilterFn, S>
    where
        S: Subscriber + for<'span> LookupSpan<'span>,
    {
        let tracer = self.provider.tracer("plumbline");
        let not_exporter: FilterFn = FilterFn::new(not_from_exporter);
        tracing_opentelemetry::layer().with_tracer(tracer).with_filter(not_exporter)
    }

    /// Sends every finished span now (blocking until the collector answered or the export timed out).
    pub fn flush(&self) -> Result<(), TelemetryError> {
        self.provider.force_flush().map_err(|e| TelemetryError::Flush(e.to_string()))
    }

    /// Flushes and stops the batch processor.
    pub fn shutdown(mut self) -> Result<(), TelemetryError> {
        self.shut_down = true;
        self.provider.shutdown_with_timeout(SHUTDOWN_TIMEOUT).map_err(|e| TelemetryError::Flush(e.to_string()))
    }
}

impl Drop for Telemetry {
    fn drop(&mut self) {
        if !self.shut_down
            && let Err(e) = self.provider.shutdown_with_timeout(SHUTDOWN_TIMEOUT)
        {
            eprintln!("warning: OTLP span export did not finish: {e}");
        }
    }
}

/// The per-layer filter of the export layer: everything but the exporter's own stack.
fn not_from_exporter(meta: &tracing::Metadata<'_>) -> bool {
    !is_exporter_target(meta.target())
}

/// Whether a span or event target belongs to the exporter's own stack.
fn is_exporter_target(target: &str) -> bool {
    EXPORTER_TARGETS.iter().any(|t| target == *t || target.strip_prefix(t).is_some_and(|rest| rest.starts_with("::")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn traces_path_is_appended_once() {
        let url = |e: &str| traces_url(e).map(|u| u.to_string());
        assert_eq!(url("http://otel:4318").unwrap(), "http://otel:4318/v1/traces");
        assert_eq!(url("http://otel:4318/").unwrap(), "http://otel:4318/v1/traces");
        assert_eq!(url("https://otel.example/collector/").unwrap(), "https://otel.example/collector/v1/traces");
        assert_eq!(url("http://otel:4318/v1/traces").unwrap(), "http://otel:4318/v1/traces");
    }

    #[test]
    fn grpc_and_garbage_endpoints_are_refused_by_name() {
        let err = traces_url("grpc://otel:4317").unwrap_err().to_string();
        assert!(err.contains("grpc://otel:4317") && err.contains("4318"), "{err}");
        let err = traces_url("otel:4318").unwrap_err();
        assert!(matches!(err, TelemetryError::Scheme { .. }), "{err}");
        assert!(matches!(traces_url("not a url").unwrap_err(), TelemetryError::Endpoint { .. }));
    }

    #[test]
    fn the_exporters_own_crates_are_filtered_out() {
        assert!(is_exporter_target("reqwest::blocking::client"));
        assert!(is_exporter_target("opentelemetry_sdk"));
        assert!(is_exporter_target("hyper_util::client::legacy"));
        assert!(!is_exporter_target("hyperloop"));
        assert!(!is_exporter_target("plumbline_worker::service"));
    }
}
