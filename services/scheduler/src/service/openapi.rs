//! The OpenAPI 3.1 document of the job API: paths written here, body schemas generated from the types the
//! service answers with, so the two cannot drift. Checked in as `schemas/openapi.json`.

use schemars::generate::SchemaSettings;
use serde_json::{Value, json};

use crate::api::{CampaignList, CampaignView, ErrorBody};

/// The OpenAPI document served at `/v1/openapi.json`.
pub fn openapi() -> Value {
    let mut generator = SchemaSettings::draft2020_12()
        .with(|s| {
            s.definitions_path = "/components/schemas".into();
            s.meta_schema = None;
        })
        .into_generator();
    for schema in [
        generator.subschema_for::<CampaignView>(),
        generator.subschema_for::<CampaignList>(),
        generator.subschema_for::<ErrorBody>(),
    ] {
        debug_assert!(schema.get("$ref").is_some());
    }
    let schemas = Value::Object(generator.take_definitions(true));
    json!({
        "openapi": "3.1.0",
        "info": {
            "title": "plumbline scheduler job API",
            "version": "1",
            "description": "Submit mobile-mapping campaigns, follow their progress, fetch their report. \
                Every /v1/campaigns route needs a bearer token; an agency sees and changes only its own \
                campaigns, and every location its manifests name must lie under its object prefix \
                {store}/agencies/<agency>/."
        },
        "components": {
            "securitySchemes": { "bearer": { "type": "http", "scheme": "bearer" } },
            "schemas": schemas,
            "responses": responses(),
        },
        "security": [{ "bearer": [] }],
        "paths": paths(),
    })
}

fn body(schema: &str) -> Value {
    json!({ "application/json": { "schema": { "$ref": format!("#/components/schemas/{schema}") } } })
}

fn answer(description: &str, schema: &str) -> Value {
    json!({ "description": description, "content": body(schema) })
}

fn error(code: &str) -> Value {
    json!({ "$ref": format!("#/components/responses/{code}") })
}

fn responses() -> Value {
    let e = |d: &str| answer(d, "ErrorBody");
    json!({
        "Unauthorized": e("Missing or unknown bearer token."),
        "NotFound": e("No campaign of this id belongs to the agency."),
        "Unavailable": e("NATS or the object store failed; retry later."),
    })
}

fn id_parameter() -> Value {
    json!([{ "name": "id", "in": "path", "required": true, "schema": { "type": "string" },
             "description": "The campaign id (the manifest's campaign.id)." }])
}

fn paths() -> Value {
    let open = json!([]);
    json!({
        "/v1/campaigns": {
            "post": {
                "summary": "Submit a campaign",
                "description": "The body is the manifest: TOML (application/toml) or JSON (application/json). \
                    It is stored at {store}/agencies/<agency>/campaigns/<id>/manifest.toml (.json), validated, \
                    planned (plan.json beside the outputs) and one task per tile is published. The same \
                    manifest again while the campaign is active publishes its tasks again, de-duplicated; \
                    after done/failed/cancelled it starts a new run.",
                "requestBody": { "required": true, "content": {
                    "application/toml": { "schema": { "type": "string" } },
                    "application/json": { "schema": { "$ref": "manifest.v1.schema.json" } }
                } },
                "responses": {
                    "201": answer("Queued: a new campaign, or a new run of a finished one.", "CampaignView"),
                    "200": answer("Resubmission of an active campaign; its tasks were published again.", "CampaignView"),
                    "401": error("Unauthorized"),
                    "403": answer("A location lies outside the agency's prefix; problems name the fields.", "ErrorBody"),
                    "409": answer("The id belongs to another agency, or the campaign is active with another manifest.", "ErrorBody"),
                    "413": { "description": "The manifest is larger than 1 MiB." },
                    "422": answer("The manifest cannot be parsed, is invalid, or its inputs cannot be read; problems name the fields.", "ErrorBody"),
                    "429": answer("Over one of the agency's quotas: submissions per minute, campaigns in flight, tiles queued.", "ErrorBody"),
                    "503": error("Unavailable"),
                }
            },
            "get": {
                "summary": "The agency's campaigns, newest first",
                "responses": { "200": answer("The campaigns.", "CampaignList"), "401": error("Unauthorized"), "503": error("Unavailable") }
            }
        },
        "/v1/campaigns/{id}": {
            "parameters": id_parameter(),
            "get": {
                "summary": "A campaign's state and per-stage progress",
                "responses": { "200": answer("The campaign.", "CampaignView"), "401": error("Unauthorized"), "404": error("NotFound"), "503": error("Unavailable") }
            },
            "delete": {
                "summary": "Cancel a campaign (workers skip its tasks)",
                "responses": {
                    "200": answer("Cancelled.", "CampaignView"),
                    "401": error("Unauthorized"),
                    "404": error("NotFound"),
                    "409": answer("Already done, failed or cancelled.", "ErrorBody"),
                    "503": error("Unavailable"),
                }
            }
        },
        "/v1/campaigns/{id}/report": {
            "parameters": id_parameter(),
            "get": {
                "summary": "The quality report (report.json, schemas/report.v1.schema.json)",
                "responses": {
                    "200": { "description": "The report.", "content": { "application/json": { "schema": { "type": "object" } } } },
                    "401": error("Unauthorized"),
                    "404": error("NotFound"),
                    "409": answer("Not done yet.", "ErrorBody"),
                    "503": error("Unavailable"),
                }
            }
        },
        "/v1/openapi.json": { "get": { "summary": "This document", "security": open,
            "responses": { "200": { "description": "OpenAPI 3.1", "content": { "application/json": {} } } } } },
        "/healthz": { "get": { "summary": "Liveness", "security": open,
            "responses": { "200": { "description": "The process runs.", "content": { "text/plain": {} } } } } },
        "/readyz": { "get": { "summary": "Readiness: NATS connected and the store reachable", "security": open,
            "responses": {
                "200": { "description": "Ready: {\"nats\": true, \"store\": true}", "content": { "application/json": {} } },
                "503": { "description": "Not ready; the body says which backend is down.", "content": { "application/json": {} } }
            } } },
        "/metrics": { "get": { "summary": "Prometheus metrics", "security": open,
            "responses": { "200": { "description": "Text exposition format 0.0.4", "content": { "text/plain": {} } } } } },
    })
}
