//! Exit-code policy: an error whose first [`plumbline_runtime::Error`] says the input is at fault (invalid,
//! missing, forbidden) exits with 2, every other error with 1. The binary's errors are `anyhow`; these
//! helpers make the invalid-input ones.

/// An invalid-input error (exit code 2).
pub fn invalid(message: impl Into<String>) -> anyhow::Error {
    plumbline_runtime::invalid(message).into()
}

/// Marks a result's error as invalid input, with the source's message.
pub trait OrInvalid<T> {
    /// Convert the error into an invalid-input error, prefixed with `context`.
    fn or_invalid(self, context: &str) -> anyhow::Result<T>;
}

impl<T, E: std::fmt::Display> OrInvalid<T> for Result<T, E> {
    fn or_invalid(self, context: &str) -> anyhow::Result<T> {
        plumbline_runtime::OrInvalid::or_invalid(self, context).map_err(Into::into)
    }
}

/// Whether `e` is the input's fault: exit code 2.
pub fn is_invalid(e: &anyhow::Error) -> bool {
    plumbline_runtime::is_invalid(e.as_ref())
}

/// Exit code for invalid input.
pub const INVALID: u8 = 2;

/// Exit code of `status --watch` for a campaign that finished without some of its tiles (dead-lettered).
pub const PARTIAL: u8 = 3;

/// Exit code of `run --strict` when a named input gave no control (the outputs are still written).
pub const NO_CONTROL: u8 = 4;
