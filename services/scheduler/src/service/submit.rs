//! `POST /v1/campaigns`: parse and validate the manifest, keep it under the agency's prefix, store it, load
//! and plan the campaign, write `plan.json`, set the KV state and publish one task per tile.

use axum::http::StatusCode;
use plumbline_campaign::{CampaignId, Manifest, ManifestV1, ParseError, Problem};
use tracing::field::Empty;

use super::Scheduler;
use super::auth::Agency;
use super::error::{ApiError, FieldProblem};
use super::prefix::check_locations;
use crate::bus::unix_now;
use crate::load::load_campaign;
use crate::messages::{CampaignState, CampaignStatus};
use plumbline_campaign::Campaign;

/// What was submitted, parsed and checked.
struct Submission {
    manifest: ManifestV1,
    url: String,
    bytes: Vec<u8>,
}

/// Handle a submission; the status is 201 for a new campaign or run, 200 for a resubmission.
#[tracing::instrument(name = "submit", skip_all, fields(agency = agency.as_str(), campaign = Empty, run = Empty, tiles = Empty))]
pub(super) async fn submit(
    s: &Scheduler,
    agency: &Agency,
    json: bool,
    body: Vec<u8>,
) -> Result<(StatusCode, CampaignState), ApiError> {
    if !s.admit_submission(agency.as_str()) {
        let limit = s.quotas.submissions_per_minute;
        let message =
            format!("agency {} made {limit} submissions in the last minute, the most it may", agency.as_str());
        return Err(ApiError::new(StatusCode::TOO_MANY_REQUESTS, message));
    }
    let sub = parse(s, agency, json, body)?;
    let id = sub.manifest.campaign.id.clone();
    let span = tracing::Span::current();
    span.record("campaign", id.as_str());
    let existing = s.bus.campaigns.get(agency, &id).await.map_err(|e| ApiError::state(&e))?;
    let (run, revision) = match existing {
        Some((state, _)) if !state.status.is_terminal() => return resubmit(s, &sub, state).await,
        Some((state, revision)) => (state.run + 1, Some(revision)),
        None => (1, None),
    };
    span.record("run", run);
    let in_flight = in_flight(s, agency, &id).await?;
    if in_flight.len() >= s.quotas.campaigns_in_flight {
        let message = format!(
            "agency {} has {} campaigns in flight, the most it may; wait for one to finish or cancel one",
            agency.as_str(),
            in_flight.len()
        );
        return Err(ApiError::new(StatusCode::TOO_MANY_REQUESTS, message));
    }
    let prefix = s.layout.agency_prefix(agency);
    let (stored, objects) =
        s.files.prefix_size(&prefix).await.map_err(|e| ApiError::unavailable("store", &format!("{e:#}")))?;
    if stored > s.quotas.bytes_stored {
        let message = format!(
            "agency {} keeps {stored} bytes in {objects} objects under {prefix}, more than its quota of {} bytes; \
             delete what finished campaigns no longer need",
            agency.as_str(),
            s.quotas.bytes_stored
        );
        return Err(ApiError::new(StatusCode::TOO_MANY_REQUESTS, message));
    }
    s.files.write(&sub.url, sub.bytes.clone()).await.map_err(|e| ApiError::unavailable("store", &format!("{e:#}")))?;
    let campaign = load(s, &sub.url).await?;
    let plan_url = format!("{}plan.json", campaign.output);
    s.files.write(&plan_url, campaign.plan.to_json()).await.map_err(|e| ApiError::unavailable("store", &e))?;
    let state = initial_state(agency, run, &sub.url, &campaign);
    span.record("tiles", state.tiles_total);
    let queued: u64 = in_flight.iter().map(|c| c.tiles_total.saturating_sub(c.tiles_handled())).sum();
    if queued + state.tiles_total > s.quotas.tiles_queued {
        let message = format!(
            "agency {} has {queued} tiles queued; {} more would pass its quota of {}",
            agency.as_str(),
            state.tiles_total,
            s.quotas.tiles_queued
        );
        return Err(ApiError::new(StatusCode::TOO_MANY_REQUESTS, message));
    }
    let written = match revision {
        None => s.bus.campaigns.create(&state).await,
        Some(revision) => s.bus.campaigns.update(&state, revision).await,
    }
    .map_err(|e| ApiError::unavailable("campaign state", &e))?;
    if written.is_none() {
        return Err(ApiError::new(StatusCode::CONFLICT, "another submission of this campaign came first; retry"));
    }
    s.remember_plan(&state, campaign.plan.tiles.tiles().iter().map(|t| t.id).collect());
    tracing::info!(campaign = id.as_str(), agency = agency.as_str(), run, tiles = state.tiles_total, "campaign queued");
    Ok((StatusCode::CREATED, dispatch_now(s, state).await?))
}

/// Run a dispatch round so the campaign's first tasks are queued when the answer goes out; the state as it
/// is then. A failed round is 503: the campaign is stored and the dispatcher keeps trying, and submitting
/// the same manifest again answers once it went through.
async fn dispatch_now(s: &Scheduler, state: CampaignState) -> Result<CampaignState, ApiError> {
    s.dispatch().await.map_err(|e| ApiError::unavailable("publishing tasks (the dispatcher retries)", &e))?;
    let now = s.bus.campaigns.get(&state.agency, &state.id).await.map_err(|e| ApiError::state(&e))?;
    Ok(now.map_or(state, |(now, _)| now))
}

/// The agency's campaigns in flight (neither done, failed nor cancelled), `id`'s own earlier run left out.
async fn in_flight(s: &Scheduler, agency: &Agency, id: &CampaignId) -> Result<Vec<CampaignState>, ApiError> {
    let all = s.bus.campaigns.list().await.map_err(|e| ApiError::unavailable("campaign state", &e))?;
    Ok(all.into_iter().filter(|c| c.agency == *agency && c.id != *id && !c.status.is_terminal()).collect())
}

/// Parse, validate and check the prefixes of a submitted manifest.
fn parse(s: &Scheduler, agency: &Agency, json: bool, bytes: Vec<u8>) -> Result<Submission, ApiError> {
    let unprocessable =
        |message: &str, problems| ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, message).with_problems(problems);
    let text =
        std::str::from_utf8(&bytes).map_err(|e| unprocessable(&format!("manifest is not UTF-8: {e}"), vec![]))?;
    let parsed = if json { Manifest::from_json_str(text) } else { Manifest::from_toml_str(text) };
    let manifest = parsed.map_err(|e| unprocessable("manifest cannot be read", vec![parse_problem(&e)]))?;
    if let Err(problems) = manifest.validate() {
        let list = problems.iter().map(problem).collect();
        return Err(unprocessable(&format!("manifest has {} problem(s)", problems.len()), list));
    }
    let manifest = manifest.into_latest();
    let url = s.layout.manifest_url(agency, &manifest.campaign.id, json);
    let outside = check_locations(&manifest, &url, &s.layout.agency_prefix(agency));
    if !outside.is_empty() {
        let list = outside.into_iter().map(|p| FieldProblem { field: p.field, found: p.found, expected: p.expected });
        return Err(ApiError::new(StatusCode::FORBIDDEN, "manifest names locations outside the agency's prefix")
            .with_problems(list.collect()));
    }
    Ok(Submission { manifest, url, bytes })
}

fn parse_problem(e: &ParseError) -> FieldProblem {
    FieldProblem {
        field: e.path().unwrap_or_default().to_owned(),
        found: e.to_string(),
        expected: "a campaign manifest v1 (schemas/manifest.v1.schema.json)".into(),
    }
}

fn problem(p: &Problem) -> FieldProblem {
    FieldProblem { field: p.path.as_str().to_owned(), found: p.found.clone(), expected: p.expected.clone() }
}

/// Load and plan the stored manifest; unusable inputs are the client's problem (422).
#[tracing::instrument(name = "load campaign", skip_all, fields(stage = "load", manifest = url, tiles = Empty, panoramas = Empty))]
async fn load(s: &Scheduler, url: &str) -> Result<Campaign, ApiError> {
    let campaign = load_campaign(&s.files, url).await.map_err(|e| {
        let message = format!("{e:#}");
        if plumbline_runtime::is_invalid(&e) {
            let problems = message
                .lines()
                .map(|l| FieldProblem {
                    field: String::new(),
                    found: l.trim().to_owned(),
                    expected: "inputs that exist under the agency's prefix and can be read".into(),
                })
                .collect();
            ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "campaign inputs cannot be used").with_problems(problems)
        } else {
            ApiError::unavailable("loading the campaign", &message)
        }
    })?;
    let span = tracing::Span::current();
    span.record("tiles", campaign.plan.tiles.tiles().len());
    span.record("panoramas", campaign.plan.panoramas.len());
    Ok(campaign)
}

fn initial_state(agency: &Agency, run: u32, manifest: &str, campaign: &Campaign) -> CampaignState {
    let now = unix_now();
    CampaignState {
        id: campaign.manifest.campaign.id.clone(),
        agency: agency.clone(),
        run,
        manifest: manifest.to_owned(),
        output: campaign.output.clone(),
        status: CampaignStatus::Queued,
        tiles_total: campaign.plan.tiles.tiles().len() as u64,
        dispatched: 0,
        tiles_done: 0,
        tiles_failed: 0,
        dead_lettered: Vec::new(),
        panoramas: campaign.plan.panoramas.len() as u64,
        skipped: campaign.skipped.len() as u64,
        created: now,
        updated: now,
        report: None,
        error: None,
    }
}

/// The same manifest again while the campaign is active: publish its dispatched tasks again (the stream
/// drops the duplicates, restoring any lost) and run a dispatch round. A different manifest is refused.
async fn resubmit(
    s: &Scheduler,
    sub: &Submission,
    state: CampaignState,
) -> Result<(StatusCode, CampaignState), ApiError> {
    let stored = s.files.read(&state.manifest).await.map_err(|e| ApiError::unavailable("store", &e))?;
    if stored[..] != sub.bytes[..] || state.manifest != sub.url {
        return Err(ApiError::new(
            StatusCode::CONFLICT,
            format!(
                "campaign {:?} is {} with a different manifest; cancel it first",
                state.id.as_str(),
                state.status.as_str()
            ),
        ));
    }
    s.republish(&state).await.map_err(|e| ApiError::unavailable("publishing tasks", &e))?;
    Ok((StatusCode::OK, dispatch_now(s, state).await?))
}
