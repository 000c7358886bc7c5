//! OTLP/HTTP span export against a real HTTP listener: a tiny collector on a free loopback port accepts
//! `POST /v1/traces` (protobuf), and the spans decoded from what arrived must carry the names, fields,
//! parent links and service name the code under test gave them.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::time::Duration;

use opentelemetry_proto::tonic::collector::trace::v1::ExportTraceServiceRequest;
use opentelemetry_proto::tonic::common::v1::{AnyValue, KeyValue, any_value::Value};
use opentelemetry_proto::tonic::trace::v1::Span;
use plumbline_runtime::{LogConfig, LogFormat, OtlpExport, RuntimeConfig, Telemetry, init_tracing};
use prost::Message as _;
use tracing_subscriber::layer::SubscriberExt as _;

/// One request as the collector saw it.
struct Received {
    method: String,
    path: String,
    content_type: String,
    body: Vec<u8>,
}

/// Starts the collector: every request is answered `200` and handed to the returned channel.
fn start_collector() -> (String, Receiver<Received>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let endpoint = format!("http://{}", listener.local_addr().unwrap());
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for stream in listener.incoming().flatten() {
            let tx = tx.clone();
            std::thread::spawn(move || serve_connection(stream, &tx));
        }
    });
    (endpoint, rx)
}

/// Serves HTTP/1.1 requests on one (keep-alive) connection until the client closes it.
fn serve_connection(stream: TcpStream, tx: &Sender<Received>) {
    let mut writer = stream.try_clone().unwrap();
    let mut reader = BufReader::new(stream);
    loop {
        let mut request_line = String::new();
        if reader.read_line(&mut request_line).unwrap_or(0) == 0 {
            return;
        }
        let mut parts = request_line.split_whitespace();
        let (method, path) = (parts.next().unwrap_or("").to_owned(), parts.next().unwrap_or("").to_owned());
        let mut headers = HashMap::new();
        loop {
            let mut line = String::new();
            reader.read_line(&mut line).unwrap();
            let line = line.trim_end();
            if line.is_empty() {
                break;
            }
            let (name, value) = line.split_once(':').unwrap();
            headers.insert(name.trim().to_ascii_lowercase(), value.trim().to_owned());
        }
        let length: usize = headers.get("content-length").map_or(0, |v| v.parse().unwrap());
        let mut body = vec![0; length];
        reader.read_exact(&mut body).unwrap();
        let content_type = headers.get("content-type").cloned().unwrap_or_default();
        writer
            .write_all(b"HTTP/1.1 200 OK\r\ncontent-type: application/x-protobuf\r\ncontent-length: 0\r\n\r\n")
            .unwrap();
        let _ = tx.send(Received { method, path, content_type, body });
    }
}

/// Every span of every request received so far, with the service name of its resource.
fn drain_spans(rx: &Receiver<Received>) -> Vec<(String, Span)> {
    let mut spans = Vec::new();
    while let Ok(request) = rx.recv_timeout(Duration::from_millis(500)) {
        assert_eq!((request.method.as_str(), request.path.as_str()), ("POST", "/v1/traces"));
        assert_eq!(request.content_type, "application/x-protobuf");
        let export = ExportTraceServiceRequest::decode(request.body.as_slice()).expect("an OTLP protobuf body");
        for resource_spans in export.resource_spans {
            let resource = resource_spans.resource.unwrap_or_default();
            let service = string_attribute(&resource.attributes, "service.name").unwrap_or_default();
            for scope in resource_spans.scope_spans {
                spans.extend(scope.spans.into_iter().map(|s| (service.clone(), s)));
            }
        }
    }
    spans
}

fn attribute<'a>(attributes: &'a [KeyValue], key: &str) -> Option<&'a Value> {
    attributes.iter().find(|kv| kv.key == key)?.value.as_ref().and_then(|v: &AnyValue| v.value.as_ref())
}

fn string_attribute(attributes: &[KeyValue], key: &str) -> Option<String> {
    match attribute(attributes, key)? {
        Value::StringValue(s) => Some(s.clone()),
        _ => None,
    }
}

/// An integer field: `i64` fields arrive as OTLP ints; tracing-opentelemetry 0.34 records `u64`/`usize`
/// fields through their `Debug` form, so those arrive as decimal strings.
fn int_attribute(attributes: &[KeyValue], key: &str) -> Option<i64> {
    match attribute(attributes, key)? {
        Value::IntValue(i) => Some(*i),
        Value::StringValue(s) => s.parse().ok(),
        _ => None,
    }
}

fn find<'a>(spans: &'a [(String, Span)], name: &str) -> &'a Span {
    let names: Vec<&str> = spans.iter().map(|(_, s)| s.name.as_str()).collect();
    &spans.iter().find(|(_, s)| s.name == name).unwrap_or_else(|| panic!("no span `{name}` among {names:?}")).1
}

/// Emits a campaign → tile → stage tree like the services do, plus a filtered-out exporter-crate span.
fn emit_campaign_spans() {
    let campaign = tracing::info_span!("campaign", campaign = "c-42", tiles = 2_u64);
    let _campaign = campaign.enter();
    for tile in ["3_4", "3_5"] {
        let tile_span = tracing::info_span!("tile", campaign = "c-42", tile, attempt = 1_i64);
        let _tile = tile_span.enter();
        let stage = tracing::info_span!("stage", stage = "registration", panoramas = 17_u64);
        stage.in_scope(|| tracing::info!(matched = 12_u64, "registered"));
    }
    tracing::info_span!(target: "reqwest::connect", "exporter internals").in_scope(|| {});
}

#[test]
fn spans_with_their_fields_and_parents_arrive_at_an_otlp_http_collector() {
    let (endpoint, rx) = start_collector();
    let export = OtlpExport { endpoint: endpoint.clone(), service_name: "plumbline-worker".to_owned() };
    let telemetry = Telemetry::start(&export).unwrap();
    assert_eq!(telemetry.traces_url().as_str(), format!("{endpoint}/v1/traces"));
    let subscriber = tracing_subscriber::registry().with(telemetry.layer());
    tracing::subscriber::with_default(subscriber, emit_campaign_spans);
    telemetry.shutdown().expect("flush and shut down");

    let spans = drain_spans(&rx);
    assert_eq!(spans.len(), 5, "1 campaign + 2 tiles + 2 stages, the exporter's own span filtered out");
    assert!(spans.iter().all(|(service, _)| service == "plumbline-worker"));
    let campaign = find(&spans, "campaign");
    assert_eq!(string_attribute(&campaign.attributes, "campaign").as_deref(), Some("c-42"));
    assert_eq!(int_attribute(&campaign.attributes, "tiles"), Some(2));
    assert!(campaign.parent_span_id.is_empty(), "the campaign span is a root");

    let tiles: Vec<&Span> = spans.iter().map(|(_, s)| s).filter(|s| s.name == "tile").collect();
    let mut tile_ids: Vec<String> = tiles.iter().filter_map(|s| string_attribute(&s.attributes, "tile")).collect();
    tile_ids.sort();
    assert_eq!(tile_ids, ["3_4", "3_5"]);
    for tile in &tiles {
        assert_eq!(tile.parent_span_id, campaign.span_id, "tiles are children of the campaign");
        assert_eq!(tile.trace_id, campaign.trace_id);
        assert!(matches!(attribute(&tile.attributes, "attempt"), Some(Value::IntValue(1))), "an i64 stays an int");
    }
    let stages: Vec<&Span> = spans.iter().map(|(_, s)| s).filter(|s| s.name == "stage").collect();
    assert_eq!(stages.len(), 2);
    for stage in stages {
        assert!(tiles.iter().any(|t| t.span_id == stage.parent_span_id), "a stage's parent is a tile");
        assert_eq!(string_attribute(&stage.attributes, "stage").as_deref(), Some("registration"));
        assert_eq!(int_attribute(&stage.attributes, "panoramas"), Some(17));
        let event = stage.events.iter().find(|e| e.name == "registered").expect("the log event inside the stage");
        assert_eq!(int_attribute(&event.attributes, "matched"), Some(12));
    }
}

#[test]
fn nothing_listening_is_reported_by_flush_not_a_hang_or_panic() {
    let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let export = OtlpExport { endpoint: format!("http://127.0.0.1:{port}"), service_name: "plumbline-test".to_owned() };
    let telemetry = Telemetry::start(&export).unwrap();
    let subscriber = tracing_subscriber::registry().with(telemetry.layer());
    tracing::subscriber::with_default(subscriber, || tracing::info_span!("lost").in_scope(|| {}));
    let started = std::time::Instant::now();
    let result = telemetry.flush();
    assert!(result.is_err(), "a refused connection must surface as a flush error: {result:?}");
    assert!(started.elapsed() < Duration::from_secs(30), "flush gave up in bounded time");
}

#[test]
fn the_global_subscriber_exports_what_its_filter_lets_through() {
    let (endpoint, rx) = start_collector();
    let config = LogConfig { format: LogFormat::Json, filter: "info".to_owned() };
    let export = OtlpExport { endpoint, service_name: "plumbline-scheduler".to_owned() };
    let guard = init_tracing(&config, None, Some(&export)).expect("first and only global init in this binary");
    assert!(guard.exporting_to().is_some_and(|url| url.path() == "/v1/traces"));
    tracing::info_span!("submit", campaign = "c-7").in_scope(|| {
        tracing::debug_span!("below the filter").in_scope(|| {});
    });
    guard.shutdown().expect("flush and shut down");
    let spans = drain_spans(&rx);
    let names: Vec<&str> = spans.iter().map(|(_, s)| s.name.as_str()).collect();
    assert_eq!(names, ["submit"], "the debug span is filtered out, the info span exported");
    assert_eq!(spans[0].0, "plumbline-scheduler");
}

#[test]
fn the_runtime_config_accepts_only_the_schemes_the_exporter_speaks() {
    let env = HashMap::new();
    let config = RuntimeConfig::load(b"otlp_endpoint = \"http://otel:4318\"", &env).unwrap();
    assert_eq!(config.otlp_endpoint.as_deref(), Some("http://otel:4318"));
    let err = RuntimeConfig::load(b"otlp_endpoint = \"grpc://otel:4317\"", &env).unwrap_err().to_string();
    assert!(err.contains("otlp_endpoint") && err.contains("http, https"), "{err}");
}
