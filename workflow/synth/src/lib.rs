//! Synthetic city campaigns with ground truth: a procedural world, drives through it with GNSS/INS errors
//! shaped by urban canyons, and the sensor data (panoramas, depth images, aerial images, cadastres) a real
//! campaign would deliver. Synchronous and I/O-free: everything is produced as values and bytes.

pub mod motion;
pub mod render;
pub mod route;
pub mod texture;
pub mod world;
