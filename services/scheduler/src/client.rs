//! A client of the job API (`plumbline submit`, `plumbline status`): bearer token from a file, errors that
//! carry the server's problems by field.

use std::time::Duration;

use reqwest::StatusCode;

use crate::api::{CampaignList, CampaignView, ErrorBody};

/// A failed API call.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The server answered with an error.
    #[error("{status}: {}{}", .body.error, problems(.body))]
    Api {
        /// The status.
        status: StatusCode,
        /// The body.
        body: ErrorBody,
    },
    /// The server could not be reached or answered something unreadable.
    #[error("{url}: {detail}")]
    Transport {
        /// The URL called.
        url: String,
        /// What went wrong.
        detail: String,
    },
}

fn problems(body: &ErrorBody) -> String {
    body.problems
        .iter()
        .map(|p| {
            let field = if p.field.is_empty() { String::new() } else { format!("{}: ", p.field) };
            format!("\n  {field}{}; expected {}", p.found, p.expected)
        })
        .collect()
}

impl ClientError {
    /// The HTTP status, for an answer of the server.
    pub fn status(&self) -> Option<StatusCode> {
        match self {
            Self::Api { status, .. } => Some(*status),
            Self::Transport { .. } => None,
        }
    }

    /// Whether asking again later may succeed: no answer, too many requests, or a server-side error (the
    /// server's NATS or store unavailable, a restart). 4xx answers are the request's fault.
    pub fn is_transient(&self) -> bool {
        self.status().is_none_or(|s| s == StatusCode::TOO_MANY_REQUESTS || s.is_server_error())
    }
}

/// The job API of one server, as one agency.
#[derive(Clone, Debug)]
pub struct Client {
    http: reqwest::Client,
    server: String,
    token: plumbline_runtime::Secret,
}

impl Client {
    /// A client of `server` (`http://host:port`) with a bearer token.
    pub fn new(server: &str, token: plumbline_runtime::Secret) -> Result<Self, ClientError> {
        let http = reqwest::Client::builder().timeout(Duration::from_secs(120)).build().map_err(|e| {
            ClientError::Transport { url: server.to_owned(), detail: format!("cannot build the HTTP client: {e}") }
        })?;
        Ok(Self { http, server: server.trim_end_matches('/').to_owned(), token })
    }

    /// Submit a manifest (TOML, or JSON when `json`).
    pub async fn submit(&self, manifest: Vec<u8>, json: bool) -> Result<CampaignView, ClientError> {
        let content_type = if json { "application/json" } else { "application/toml" };
        let request = self.http.post(self.url("/v1/campaigns")).header("content-type", content_type).body(manifest);
        self.send(request).await
    }

    /// A campaign's state and progress.
    pub async fn status(&self, id: &str) -> Result<CampaignView, ClientError> {
        self.send(self.http.get(self.url(&format!("/v1/campaigns/{id}")))).await
    }

    /// The agency's campaigns.
    pub async fn list(&self) -> Result<CampaignList, ClientError> {
        self.send(self.http.get(self.url("/v1/campaigns"))).await
    }

    /// Cancel a campaign.
    pub async fn cancel(&self, id: &str) -> Result<CampaignView, ClientError> {
        self.send(self.http.delete(self.url(&format!("/v1/campaigns/{id}")))).await
    }

    /// The report of a finished campaign.
    pub async fn report(&self, id: &str) -> Result<serde_json::Value, ClientError> {
        self.send(self.http.get(self.url(&format!("/v1/campaigns/{id}/report")))).await
    }

    fn url(&self, path: &str) -> String {
        format!("{}{path}", self.server)
    }

    async fn send<T: serde::de::DeserializeOwned>(&self, request: reqwest::RequestBuilder) -> Result<T, ClientError> {
        let transport = |detail: String| ClientError::Transport { url: self.server.clone(), detail };
        let response =
            request.bearer_auth(self.token.expose()).send().await.map_err(|e| transport(format!("{e:#}")))?;
        let status = response.status();
        let bytes = response.bytes().await.map_err(|e| transport(format!("reading the answer: {e}")))?;
        if status.is_success() {
            return serde_json::from_slice(&bytes).map_err(|e| transport(format!("unreadable answer: {e}")));
        }
        let body = serde_json::from_slice(&bytes).unwrap_or_else(|_| ErrorBody {
            error: String::from_utf8_lossy(&bytes).trim().to_owned(),
            problems: Vec::new(),
        });
        Err(ClientError::Api { status, body })
    }
}
