//! The checked-in schemas of the scheduler's messages and its OpenAPI document are current, and the served
//! document is the checked-in one.
#![allow(clippy::unwrap_used)]

#[allow(dead_code)] // the rest serves the `scheduler` target
mod support;

use plumbline_scheduler::messages;
use plumbline_scheduler::service::openapi;
use plumbline_testkit::schemas::{assert_current, schemas_dir};

#[test]
fn message_schemas_are_current() {
    for (file, schema) in messages::schemas() {
        assert_current(file, &schema, "plumbline-scheduler");
    }
}

#[test]
fn openapi_document_is_current() {
    assert_current("openapi.json", &openapi(), "plumbline-scheduler");
    let doc = openapi();
    assert_eq!(doc["openapi"], "3.1.0");
    for path in ["/v1/campaigns", "/v1/campaigns/{id}", "/v1/campaigns/{id}/report", "/healthz", "/readyz", "/metrics"]
    {
        assert!(doc["paths"].get(path).is_some(), "{path} missing");
    }
    // Every schema reference resolves inside the document (or to a checked-in schema file).
    let text = doc.to_string();
    for reference in text.split("\"$ref\":\"").skip(1).map(|r| &r[..r.find('"').unwrap()]) {
        match reference.strip_prefix("#/") {
            Some(pointer) => assert!(doc.pointer(&format!("/{pointer}")).is_some(), "{reference} dangles"),
            None => assert!(schemas_dir().join(reference).exists(), "{reference} is not in schemas/"),
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_served_document_is_the_checked_in_one() {
    let h = support::Harness::local().await;
    let served: serde_json::Value =
        reqwest::get(format!("{}/v1/openapi.json", h.server)).await.unwrap().json().await.unwrap();
    let checked_in: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(schemas_dir().join("openapi.json")).unwrap()).unwrap();
    assert_eq!(served, checked_in);
    let health = reqwest::get(format!("{}/healthz", h.server)).await.unwrap();
    assert_eq!(health.status(), reqwest::StatusCode::OK);
}
