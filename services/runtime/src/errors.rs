//! The exit-code policy every entry point shares: errors marked [`InvalidInput`] are the user's input
//! (exit code 2); every other error is a failure while working (exit code 1).

/// Marks an error as caused by the user's input rather than by the environment.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InvalidInput(pub String);

/// Build an invalid-input error.
pub fn invalid(message: impl Into<String>) -> anyhow::Error {
    InvalidInput(message.into()).into()
}

/// Whether any error in the chain is [`InvalidInput`].
pub fn is_invalid(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.is::<InvalidInput>())
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
