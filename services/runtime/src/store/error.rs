//! `StoreError` and its kind, which tells a caller whether to give up, retry or treat a key as absent.

/// What a caller should do about a [`StoreError`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoreErrorKind {
    /// The object does not exist: a missing input, or "not written yet".
    NotFound,
    /// A precondition failed (the object exists already, or changed): re-read and decide.
    Conflict,
    /// Possibly transient (network, server, I/O): retry the task later.
    Retryable,
    /// Will fail again as it is (bad credentials, permissions, invalid key, unsupported operation).
    Permanent,
    /// The URL or store options are wrong: fix the configuration.
    Config,
}

/// An object-store failure, naming the URL or key involved.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct StoreError {
    kind: StoreErrorKind,
    message: String,
    #[source]
    source: Option<object_store::Error>,
}

impl StoreError {
    pub(crate) fn new(kind: StoreErrorKind, message: impl Into<String>) -> Self {
        Self { kind, message: message.into(), source: None }
    }

    /// Wraps an object-store error from an operation on `what` (a key or URL).
    pub(crate) fn from_store(operation: &str, what: &str, source: object_store::Error) -> Self {
        let kind = classify(&source);
        Self { kind, message: format!("{operation} `{what}`: {source}"), source: Some(source) }
    }

    /// What the caller should do about it.
    pub fn kind(&self) -> StoreErrorKind {
        self.kind
    }

    /// Whether retrying the same operation later may succeed.
    pub fn is_retryable(&self) -> bool {
        self.kind == StoreErrorKind::Retryable
    }
}

/// `Generic` errors are what HTTP and I/O failures surface as (after object_store's own retries),
/// so they count as retryable; a task's bounded redelivery caps the cost of being wrong.
fn classify(error: &object_store::Error) -> StoreErrorKind {
    use object_store::Error as E;
    match error {
        E::NotFound { .. } => StoreErrorKind::NotFound,
        E::AlreadyExists { .. } | E::Precondition { .. } | E::NotModified { .. } => StoreErrorKind::Conflict,
        E::Generic { .. } | E::JoinError { .. } => StoreErrorKind::Retryable,
        E::UnknownConfigurationKey { .. } => StoreErrorKind::Config,
        _ => StoreErrorKind::Permanent,
    }
}
