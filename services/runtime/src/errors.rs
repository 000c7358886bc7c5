//! The error every service boundary returns, and the exit-code policy every entry point shares.
//!
//! An [`Error`] is a message naming file, record and field, and an [`ErrorKind`] — what callers decide on:
//! the exit code (2 when the input is at fault: `Invalid`, `Missing`, `Forbidden`; 1 otherwise), whether a
//! tile task is retried (`Transient`) or dead-lettered, whether an input is skipped. Context added on the way up ([`Context`]) prefixes
//! the message and keeps the kind; the error it was made from stays reachable for callers that need its
//! own detail ([`Error::find`]).

use std::error::Error as StdError;
use std::fmt;

use crate::store::{StoreError, StoreErrorKind};

/// What a caller should do about an [`Error`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ErrorKind {
    /// The user's input is wrong (a manifest field, a file's content, an option): exit code 2; a task
    /// failing with it is dead-lettered at once.
    Invalid,
    /// Something named does not exist (a file, an object, a campaign).
    Missing,
    /// Not allowed: permissions, credentials, a location outside the caller's prefix.
    Forbidden,
    /// May succeed later (network, server, store or broker failing for now): retry.
    Transient,
    /// A failure retrying will not fix that is not the input's fault.
    Internal,
}

impl ErrorKind {
    /// The kind's name in logs and metrics labels.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Invalid => "invalid",
            Self::Missing => "missing",
            Self::Forbidden => "forbidden",
            Self::Transient => "transient",
            Self::Internal => "internal",
        }
    }
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A service error: its kind and a message naming what failed.
#[derive(Debug)]
pub struct Error {
    kind: ErrorKind,
    message: String,
    cause: Option<Box<dyn StdError + Send + Sync>>,
}

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An error of `kind` saying `message`.
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        Self { kind, message: message.into(), cause: None }
    }

    /// An error of `kind` made from `cause`, whose message it takes.
    pub fn from_cause(kind: ErrorKind, cause: impl StdError + Send + Sync + 'static) -> Self {
        Self { kind, message: cause.to_string(), cause: Some(Box::new(cause)) }
    }

    /// The user's input is wrong.
    pub fn invalid(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Invalid, message)
    }

    /// Something named does not exist.
    pub fn missing(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Missing, message)
    }

    /// Not allowed.
    pub fn forbidden(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Forbidden, message)
    }

    /// May succeed later.
    pub fn transient(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Transient, message)
    }

    /// Will not succeed on retry, and not the input's fault.
    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Internal, message)
    }

    /// What the caller should do about it.
    pub fn kind(&self) -> ErrorKind {
        self.kind
    }

    /// Whether the input is at fault — invalid, missing or not allowed (exit code 2) — rather than the
    /// environment or plumbline.
    pub fn is_input(&self) -> bool {
        matches!(self.kind, ErrorKind::Invalid | ErrorKind::Missing | ErrorKind::Forbidden)
    }

    /// Whether a later attempt may succeed.
    pub fn is_transient(&self) -> bool {
        self.kind == ErrorKind::Transient
    }

    /// The same error, its message prefixed with `context` ("context: message").
    pub fn context(mut self, context: impl fmt::Display) -> Self {
        self.message = format!("{context}: {}", self.message);
        self
    }

    /// The error of type `T` this one was made from, if any.
    pub fn find<T: StdError + 'static>(&self) -> Option<&T> {
        self.cause.as_deref().and_then(|c| c.downcast_ref::<T>())
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

// The cause is not exposed as `source()`: the message already holds its text, and chains printed by
// `anyhow` in the binary would repeat it.
impl StdError for Error {}

impl From<StoreError> for Error {
    fn from(e: StoreError) -> Self {
        let kind = match e.kind() {
            StoreErrorKind::NotFound => ErrorKind::Missing,
            StoreErrorKind::Retryable | StoreErrorKind::Conflict => ErrorKind::Transient,
            StoreErrorKind::Permanent => ErrorKind::Forbidden,
            StoreErrorKind::Config => ErrorKind::Invalid,
        };
        Self::from_cause(kind, e)
    }
}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        use std::io::ErrorKind as Io;
        let kind = match e.kind() {
            Io::NotFound => ErrorKind::Missing,
            Io::PermissionDenied => ErrorKind::Forbidden,
            Io::InvalidData | Io::InvalidInput | Io::UnexpectedEof => ErrorKind::Invalid,
            Io::Interrupted | Io::TimedOut | Io::ConnectionReset | Io::ConnectionAborted | Io::WouldBlock => {
                ErrorKind::Transient
            }
            _ => ErrorKind::Internal,
        };
        Self::from_cause(kind, e)
    }
}

impl From<gdal::errors::GdalError> for Error {
    fn from(e: gdal::errors::GdalError) -> Self {
        Self::from_cause(ErrorKind::Internal, e)
    }
}

/// Adds context to a result's error, keeping its kind.
pub trait Context<T> {
    /// Prefix the error's message with `context`.
    fn context(self, context: impl fmt::Display) -> Result<T>;
    /// Prefix the error's message with what `context` returns, computed only on error.
    fn with_context<C: fmt::Display>(self, context: impl FnOnce() -> C) -> Result<T>;
}

impl<T, E: Into<Error>> Context<T> for std::result::Result<T, E> {
    fn context(self, context: impl fmt::Display) -> Result<T> {
        self.map_err(|e| e.into().context(context))
    }

    fn with_context<C: fmt::Display>(self, context: impl FnOnce() -> C) -> Result<T> {
        self.map_err(|e| e.into().context(context()))
    }
}

/// Marks a result's error as the user's input, with the source's message.
pub trait OrInvalid<T> {
    /// Convert the error into an [`ErrorKind::Invalid`] error, prefixed with `context`.
    fn or_invalid(self, context: &str) -> Result<T>;
}

impl<T, E: fmt::Display> OrInvalid<T> for std::result::Result<T, E> {
    fn or_invalid(self, context: &str) -> Result<T> {
        self.map_err(|e| if context.is_empty() { invalid(e.to_string()) } else { invalid(format!("{context}: {e}")) })
    }
}

/// An invalid-input error.
pub fn invalid(message: impl Into<String>) -> Error {
    Error::invalid(message)
}

/// The first [`Error`] in `e`'s chain of sources, starting with `e` itself.
pub fn find_error<'a>(e: &'a (dyn StdError + 'static)) -> Option<&'a Error> {
    let mut next = Some(e);
    while let Some(err) = next {
        if let Some(found) = err.downcast_ref::<Error>() {
            return Some(found);
        }
        next = err.source();
    }
    None
}

/// Whether the input is at fault in `e` (its first [`Error`] says so): the binary's exit-code rule.
pub fn is_invalid(e: &(dyn StdError + 'static)) -> bool {
    find_error(e).is_some_and(Error::is_input)
}

/// A CRS that PROJ does not know or cannot transform: the campaign's or an input's EPSG code.
impl From<crate::crs::CrsError> for Error {
    fn from(e: crate::crs::CrsError) -> Self {
        Self::from_cause(ErrorKind::Invalid, e)
    }
}

/// A record that cannot be moved into the CRS asked for.
impl<E: StdError + Send + Sync + 'static> From<plumbline_geo::formats::ProjectionError<E>> for Error {
    fn from(e: plumbline_geo::formats::ProjectionError<E>) -> Self {
        Self::from_cause(ErrorKind::Invalid, e)
    }
}

/// A trajectory that does not validate (times, positions, attitudes, σ).
impl From<plumbline_geo::TrajectoryError> for Error {
    fn from(e: plumbline_geo::TrajectoryError) -> Self {
        Self::from_cause(ErrorKind::Invalid, e)
    }
}

/// A manifest or index-row location that does not resolve below where it must (the agency's input).
impl From<plumbline_campaign::LocationError> for Error {
    fn from(e: plumbline_campaign::LocationError) -> Self {
        Self::from_cause(ErrorKind::Invalid, e)
    }
}

/// A raster GDAL cannot read or cut as asked: the input's bytes.
impl From<crate::raster_common::GdalReadError> for Error {
    fn from(e: crate::raster_common::GdalReadError) -> Self {
        Self::from_cause(ErrorKind::Invalid, e)
    }
}

/// Serialising plumbline's own outputs (reading an input's JSON says which input instead).
impl From<serde_json::Error> for Error {
    fn from(e: serde_json::Error) -> Self {
        Self::from_cause(ErrorKind::Internal, e)
    }
}

/// A blocking or spawned task that panicked or was cancelled.
impl From<tokio::task::JoinError> for Error {
    fn from(e: tokio::task::JoinError) -> Self {
        Self::new(ErrorKind::Internal, format!("worker task failed: {e}"))
    }
}

/// GDAL failing to write plumbline's own outputs.
impl From<crate::gdal_write::GdalWriteError> for Error {
    fn from(e: crate::gdal_write::GdalWriteError) -> Self {
        Self::from_cause(ErrorKind::Internal, e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wrapper that names its cause as `source()`, like the binary's context layers do.
    #[derive(Debug)]
    struct Layer(Error);

    impl fmt::Display for Layer {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("while running")
        }
    }

    impl StdError for Layer {
        fn source(&self) -> Option<&(dyn StdError + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn context_prefixes_the_message_and_keeps_the_kind() {
        let e: Result<()> = Err(Error::missing("poles.gpkg: not found"));
        let e = e.context("cadastre").unwrap_err();
        assert_eq!((e.kind(), e.to_string().as_str()), (ErrorKind::Missing, "cadastre: poles.gpkg: not found"));
        let io = std::io::Error::new(std::io::ErrorKind::TimedOut, "reset");
        let e = Err::<(), _>(io).with_context(|| "reading s3://b/k").unwrap_err();
        assert_eq!((e.kind(), e.to_string().as_str()), (ErrorKind::Transient, "reading s3://b/k: reset"));
    }

    #[test]
    fn the_input_is_at_fault_when_invalid_missing_or_forbidden_through_any_wrapper() {
        let cases = [
            (ErrorKind::Invalid, true),
            (ErrorKind::Missing, true),
            (ErrorKind::Forbidden, true),
            (ErrorKind::Transient, false),
            (ErrorKind::Internal, false),
        ];
        for (kind, input) in cases {
            let wrapped = Layer(Error::new(kind, "x"));
            assert_eq!(is_invalid(&wrapped), input, "{kind}");
            assert_eq!(find_error(&wrapped).map(Error::kind), Some(kind));
        }
        assert!(!is_invalid(&std::io::Error::other("no service error inside")));
    }

    #[test]
    fn store_failures_keep_their_cause_and_map_to_what_callers_do() {
        let missing = Error::from(StoreError::new(StoreErrorKind::NotFound, "get `k`: not found"));
        assert_eq!(missing.kind(), ErrorKind::Missing);
        assert_eq!(missing.find::<StoreError>().map(StoreError::kind), Some(StoreErrorKind::NotFound));
        let kinds = [
            (StoreErrorKind::Retryable, ErrorKind::Transient),
            (StoreErrorKind::Conflict, ErrorKind::Transient),
            (StoreErrorKind::Permanent, ErrorKind::Forbidden),
            (StoreErrorKind::Config, ErrorKind::Invalid),
        ];
        for (store, kind) in kinds {
            assert_eq!(Error::from(StoreError::new(store, "m")).kind(), kind, "{store:?}");
        }
    }
}
