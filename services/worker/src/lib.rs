//! The worker's logic, shared by `plumbline run` (in-process queue) and the worker service (NATS): process
//! one tile of a planned campaign and write the versioned [`TileOutput`] under `{output}tiles/`.

mod output;

pub use output::{TileOutput, TileOutputV1, tile_key};
