//! MM↔aerial registration, the pipeline of Jende et al. 2017 §3: ortho-projected panoramas registered with each
//! other and with aerial nadir images, producing tie observations for the adjustment.
//!
//! Synchronous and I/O-free; rayon parallelism inside.

pub mod aerial;
pub mod mm;
pub mod output;
pub mod pipeline;

pub use output::{TileResult, TileResultV1};
pub use pipeline::{PipelineConfig, StageTimings, TileRun, register_tile};
