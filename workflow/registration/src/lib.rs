//! MM↔aerial registration, the pipeline of Jende et al. 2017 §3: ortho-projected panoramas registered with each
//! other and with aerial nadir images, producing tie observations for the adjustment.
//!
//! ```text
//! prepare_panorama(panorama, rig, &MmConfig) → PreparedPanorama   step 1: the ground-plane ortho patch and
//!                                                                  its KAZE features (once per panorama)
//! register_tile(tile, &[PreparedPanorama], &TileRun) → TileResult  per owned panorama and its neighbour:
//!   mm::    steps 2–4  MM↔MM transformation, corner matching, triangulation → corners with DG coordinates
//!   aerial::register_patch  steps 5–8  initial transformation (KAZE + RANSAC), NCC + LSM correspondences,
//!           multi-image triangulation (or orthophoto + terrain) → aerial-derived coordinates with σ
//!   pipeline::crosscheck  the offsets of neighbouring panoramas compared; outliers discarded
//!   → tie points (ray + aerial coordinate) and one diagnostic per image, for the adjustment
//! ```
//!
//! Synchronous and I/O-free; rayon parallelism inside.

pub mod aerial;
pub mod mm;
pub mod output;
pub mod pipeline;

pub use output::{TileResult, TileResultV1};
pub use pipeline::{PipelineConfig, StageTimings, TileRun, register_tile};
