//! The routes of the job API and the request counting around them.

use std::collections::BTreeMap;
use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, MatchedPath, Path, Request, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::{Json, Router};
use plumbline_campaign::CampaignId;
use tracing::Instrument as _;

use super::auth::Agency;
use super::error::ApiError;
use super::prefix::{StoredOutputError, stored_output};
use super::{MAX_MANIFEST_BYTES, Scheduler, submit};
use crate::api::{CampaignList, CampaignView};
use crate::messages::{CampaignState, CampaignStatus};

type Shared = State<Arc<Scheduler>>;

pub(super) fn router(scheduler: Arc<Scheduler>) -> Router {
    Router::new()
        .route("/v1/campaigns", get(list).post(create))
        .route("/v1/campaigns/{id}", get(show).delete(cancel))
        .route("/v1/campaigns/{id}/report", get(report))
        .route("/v1/openapi.json", get(|| async { Json(super::openapi()) }))
        .route("/healthz", get(|| async { "ok\n" }))
        .route("/readyz", get(ready))
        .route("/metrics", get(metrics))
        .layer(middleware::from_fn_with_state(scheduler.clone(), count))
        .layer(DefaultBodyLimit::max(MAX_MANIFEST_BYTES))
        .with_state(scheduler)
}

/// Count every answer by route template and status, each request in a span (`info` for the job API,
/// `debug` for the probes and scrapes, so that they do not flood the traces).
async fn count(State(s): Shared, request: Request, next: Next) -> Response {
    let route = request.extensions().get::<MatchedPath>().map_or("unmatched", MatchedPath::as_str).to_owned();
    let method = request.method().clone();
    let span = if route.starts_with("/v1/") {
        tracing::info_span!("request", %method, route = route.as_str(), status = tracing::field::Empty)
    } else {
        tracing::debug_span!("request", %method, route = route.as_str(), status = tracing::field::Empty)
    };
    let response = next.run(request).instrument(span.clone()).await;
    span.record("status", response.status().as_u16());
    s.metrics.request(&route, response.status().as_u16());
    response
}

fn agency(s: &Scheduler, headers: &HeaderMap) -> Result<Agency, ApiError> {
    let value = headers.get(header::AUTHORIZATION).and_then(|v| v.to_str().ok());
    s.tokens.authorize(value).ok_or_else(ApiError::unauthorized)
}

/// The agency's own campaign, or 404 (ids are per agency: another agency's campaign of the same id is a
/// different campaign).
async fn owned(s: &Scheduler, agency: &Agency, id: &str) -> Result<CampaignState, ApiError> {
    let Ok(campaign) = id.parse::<CampaignId>() else { return Err(ApiError::not_found(id)) };
    match s.bus.campaigns.get(agency, &campaign).await.map_err(|e| ApiError::state(&e))? {
        Some((state, _)) => Ok(state),
        None => Err(ApiError::not_found(id)),
    }
}

async fn create(State(s): Shared, headers: HeaderMap, body: Bytes) -> Result<Response, ApiError> {
    let agency = agency(&s, &headers)?;
    if s.client.connection_state() != async_nats::connection::State::Connected {
        // Fail fast rather than after the request timeouts: nothing can be queued now.
        return Err(ApiError::unavailable("NATS", &"not connected; retry shortly"));
    }
    let json = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.trim_start().to_ascii_lowercase().starts_with("application/json"));
    let (status, state) = submit::submit(&s, &agency, json, body.to_vec()).await?;
    let location = format!("/v1/campaigns/{}", state.id.as_str());
    Ok((status, [(header::LOCATION, location)], Json(CampaignView::of(state))).into_response())
}

async fn list(State(s): Shared, headers: HeaderMap) -> Result<Json<CampaignList>, ApiError> {
    let agency = agency(&s, &headers)?;
    let all = s.bus.campaigns.list().await.map_err(|e| ApiError::unavailable("campaign state", &e))?;
    let mut campaigns: Vec<CampaignState> = all.into_iter().filter(|c| c.agency == agency).collect();
    campaigns.sort_by(|a, b| b.created.cmp(&a.created).then_with(|| a.id.cmp(&b.id)));
    Ok(Json(CampaignList { campaigns }))
}

async fn show(State(s): Shared, headers: HeaderMap, Path(id): Path<String>) -> Result<Json<CampaignView>, ApiError> {
    let agency = agency(&s, &headers)?;
    Ok(Json(CampaignView::of(owned(&s, &agency, &id).await?)))
}

async fn report(State(s): Shared, headers: HeaderMap, Path(id): Path<String>) -> Result<Response, ApiError> {
    let agency = agency(&s, &headers)?;
    let state = owned(&s, &agency, &id).await?;
    if state.status != CampaignStatus::Done {
        let message = format!("campaign {id:?} is {}: the report exists once it is done", state.status.as_str());
        return Err(ApiError::new(StatusCode::CONFLICT, message));
    }
    let url = report_url(&s, &agency, &state).await?;
    let bytes = s.files.read(&url).await.map_err(|e| ApiError::unavailable("store", &format!("{e:#}")))?;
    Ok(([(header::CONTENT_TYPE, "application/json")], bytes).into_response())
}

/// Where a campaign's report is, derived from the agency and the campaign id, never taken from the state
/// (whose `report` and `manifest` fields anyone who can write the bus could point anywhere): the manifest
/// stored under the agency's prefix for this id, its `output` resolved and checked to stay under that prefix,
/// then `report.json`.
async fn report_url(s: &Scheduler, agency: &Agency, state: &CampaignState) -> Result<String, ApiError> {
    match stored_output(&s.files, &s.layout, agency, state).await {
        Ok((_, output)) => Ok(format!("{output}report.json")),
        Err(StoredOutputError::Store(e)) => Err(ApiError::unavailable("store", &e)),
        Err(StoredOutputError::Tampered(what)) => {
            tracing::error!(
                campaign = state.id.as_str(),
                agency = agency.as_str(),
                what,
                "campaign state tampered with"
            );
            Err(ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, format!("campaign {:?}: {what}", state.id.as_str())))
        }
    }
}

async fn cancel(State(s): Shared, headers: HeaderMap, Path(id): Path<String>) -> Result<Json<CampaignView>, ApiError> {
    let agency = agency(&s, &headers)?;
    let state = owned(&s, &agency, &id).await?;
    let mut changed = false;
    let cancelled = s
        .bus
        .campaigns
        .modify(&agency, &state.id, |c| {
            changed = !c.status.is_terminal();
            if changed {
                c.status = CampaignStatus::Cancelled;
                c.error = Some("cancelled by its agency".into());
            }
            changed
        })
        .await
        .map_err(|e| ApiError::unavailable("campaign state", &e))?
        .ok_or_else(|| ApiError::not_found(&id))?;
    if !changed {
        let message = format!("campaign {id:?} is already {}", cancelled.status.as_str());
        return Err(ApiError::new(StatusCode::CONFLICT, message));
    }
    tracing::info!(campaign = id, agency = agency.as_str(), "campaign cancelled");
    Ok(Json(CampaignView::of(cancelled)))
}

async fn ready(State(s): Shared) -> Response {
    let probe = format!("{}.readyz", s.layout.root());
    let (nats, store) = plumbline_runtime::ops::ready(&s.client, &s.files, Some(&probe)).await;
    let status = if nats && store { StatusCode::OK } else { StatusCode::SERVICE_UNAVAILABLE };
    (status, Json(serde_json::json!({ "nats": nats, "store": store }))).into_response()
}

async fn metrics(State(s): Shared) -> Response {
    let campaigns = s.bus.campaigns.list().await.ok().map(|all| {
        let mut by_status = BTreeMap::new();
        for c in all {
            *by_status.entry(c.status).or_insert(0) += 1;
        }
        by_status
    });
    let queued = s.bus.queued_tasks().await.ok();
    let text = s.metrics.render(campaigns.as_ref(), queued);
    ([(header::CONTENT_TYPE, "text/plain; version=0.0.4")], text).into_response()
}
