//! Exit-code policy: errors marked [`InvalidInput`] exit with 2, every other error with 1.

/// Exit code for invalid input.
pub const INVALID: u8 = 2;

/// Marks an error as caused by the user's input (exit code 2) rather than by the environment.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InvalidInput(pub String);

/// Build an invalid-input error.
pub fn invalid(message: impl Into<String>) -> anyhow::Error {
    InvalidInput(message.into()).into()
}

/// Extension to mark a result's error as invalid input, with the source's message.
pub trait OrInvalid<T> {
    /// Convert the error into [`InvalidInput`], prefixed with `context`.
    fn or_invalid(self, context: &str) -> anyhow::Result<T>;
}

impl<T, E: std::fmt::Display> OrInvalid<T> for Result<T, E> {
    fn or_invalid(self, context: &str) -> anyhow::Result<T> {
        self.map_err(|e| if context.is_empty() { invalid(e.to_string()) } else { invalid(format!("{context}: {e}")) })
    }
}
