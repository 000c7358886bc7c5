//! API errors: a status code and an [`ErrorBody`]: `{ "error": "…", "problems": [{ "field", "found", "expected" }] }`.

use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};

use crate::api::ErrorBody;

pub use crate::api::ProblemBody as FieldProblem;

/// An error answered to a client.
#[derive(Debug)]
pub struct ApiError {
    /// The HTTP status.
    pub status: StatusCode,
    /// One line for people.
    pub message: String,
    /// Problems by field, when the request body is at fault.
    pub problems: Vec<FieldProblem>,
}

impl ApiError {
    /// An error without field problems.
    pub fn new(status: StatusCode, message: impl Into<String>) -> Self {
        Self { status, message: message.into(), problems: Vec::new() }
    }

    /// 401: no valid bearer token.
    pub fn unauthorized() -> Self {
        Self::new(StatusCode::UNAUTHORIZED, "missing or unknown bearer token")
    }

    /// 404 for a campaign the agency does not own or that does not exist (the two look the same).
    pub fn not_found(id: &str) -> Self {
        Self::new(StatusCode::NOT_FOUND, format!("campaign {id:?} not found"))
    }

    /// 503: a backend (NATS, the store) failed; the client may retry.
    pub fn unavailable(what: &str, e: &dyn std::fmt::Display) -> Self {
        tracing::warn!(backend = what, error = %e, "request failed on a backend");
        Self::new(StatusCode::SERVICE_UNAVAILABLE, format!("{what}: {e}"))
    }

    /// A failure reading a campaign state: 500 for a forged one (it names another agency or id than its
    /// key; not retryable), 503 otherwise.
    pub fn state(e: &crate::bus::BusError) -> Self {
        if matches!(e, crate::bus::BusError::Forged { .. }) {
            tracing::error!(error = %e, "campaign state refused");
            return Self::new(
                StatusCode::INTERNAL_SERVER_ERROR,
                "the campaign's state is inconsistent; ask the operator",
            );
        }
        Self::unavailable("campaign state", e)
    }

    /// With problems by field.
    pub fn with_problems(mut self, problems: Vec<FieldProblem>) -> Self {
        self.problems = problems;
        self
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = ErrorBody { error: self.message, problems: self.problems };
        let mut response = (self.status, axum::Json(body)).into_response();
        if self.status == StatusCode::UNAUTHORIZED {
            response.headers_mut().insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
        }
        response
    }
}
