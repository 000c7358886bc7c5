//! Pole-like objects from cadastres as control (paper 002): detection in depth images and point clouds,
//! matching to the cadastre, and coordinate updates (CUPTs) for the adjustment.
//!
//! Synchronous and I/O-free; rayon parallelism inside.
