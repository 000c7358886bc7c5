//! MM↔aerial registration, the pipeline of paper 000 §3: ortho-projected panoramas registered with each
//! other and with aerial nadir images, producing tie observations for the adjustment.
//!
//! Synchronous and I/O-free; rayon parallelism inside.

pub mod aerial;
pub mod mm;
