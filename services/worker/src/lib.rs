//! The worker's logic, shared by `plumbline run` (in-process queue) and the worker service (NATS): process
//! one tile of a planned campaign — read its panoramas, vehicle mask, aerial frames or orthophoto windows,
//! depth images and cadastre objects; register the panoramas (Jende et al. 2017) and match the poles
//! (Meyer et al. 2023); write the versioned [`TileOutput`] under `{output}tiles/`.
//!
//! ```text
//! process_tile(&files, &campaign, &tile, &config) → TileOutputV1
//!   aerial frames: the windows of the block the tile can reach (or orthophoto + terrain windows)
//!   panoramas a few at a time: read, decode, prepare (ortho patch, features), register, drop the pixels
//!   depth images and point clouds in batches → poles detected, matched to the cadastre → pole updates
//!   → tie points, pole updates, image motions, per-image diagnostics, skipped inputs
//! run_tile(…) → the same, resumed from or written to {output}tiles/{col}_{row}.json (fingerprinted)
//! service::serve → the NATS worker loop around run_tile
//! ```
//!
//! One broken input (a corrupt panorama, a missing depth image, a bad cadastre feature) is skipped, counted
//! and listed in the tile's output; the tile goes on.

mod aerial;
mod clouds;
mod config;
mod fetch;
mod fingerprint;
mod output;
mod panoramas;
mod poles;
mod prepare;
mod raster;
pub mod service;
mod stages;
mod tile;

pub use aerial::{frame_camera, frame_pose};
pub use config::{DEFAULT_CONCURRENCY, WorkerConfig};
pub use fingerprint::fingerprint;
pub use output::{TileOutput, TileOutputV1, tile_key};
pub use tile::{process_tile, process_tile_reporting, run_tile, run_tile_reporting, tile_camera_height};
