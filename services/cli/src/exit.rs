//! Exit-code policy: errors marked [`InvalidInput`](plumbline_runtime::InvalidInput) exit with 2, every other error with 1.

pub use plumbline_runtime::errors::{OrInvalid, invalid};

/// Exit code for invalid input.
pub const INVALID: u8 = 2;

/// Exit code of `status --watch` for a campaign that finished without some of its tiles (dead-lettered).
pub const PARTIAL: u8 = 3;

/// Exit code of `run --strict` when a named input gave no control (the outputs are still written).
pub const NO_CONTROL: u8 = 4;
