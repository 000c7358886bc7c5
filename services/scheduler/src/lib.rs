//! The scheduler's logic, shared by `plumbline run` (all in one process) and the scheduler service:
//! read and validate a campaign manifest, load its trajectory and image indexes, and plan its tiles.
//!
//! Everything a campaign cannot work without is checked here, before any tile is processed: a campaign
//! whose inputs are unusable as a whole (no trajectory, a CRS PROJ does not know, no panorama index) stops
//! with an invalid-input [`plumbline_runtime::Error`] naming the file and field. Single bad rows are skipped
//! and listed in [`plumbline_campaign::Campaign::skipped`].
//!
//! ```text
//! load_campaign(&files, manifest_url) → plumbline_campaign::Campaign (manifest validated, CRS checked,
//!     trajectory in the campaign CRS, index and orientation tables, tile plan, skipped rows)
//! check_inputs(&files, manifest_url, &manifest) → InputCheck: `plumbline validate`'s look at every named input, without processing
//! service: POST /v1/campaigns → load → one task per tile on JetStream (fair across agencies) → state in KV
//! ```
//!
//! The distributed path: [`messages`] (versioned task, result and state messages), [`bus`] (the JetStream
//! streams, consumers and KV bucket), [`service`] (the job API of `plumbline serve scheduler`), [`api`] and
//! [`client`] (its bodies and the client `plumbline submit`/`status` use).

pub mod api;
pub mod bus;
pub mod check;
pub mod client;
mod load;
pub mod messages;
pub mod service;

pub use check::{InputCheck, check_inputs};
pub use load::{load_campaign, manifest_base, parse_manifest};
