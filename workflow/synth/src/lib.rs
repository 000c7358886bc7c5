//! Synthetic city campaigns with ground truth: a procedural world, drives through it with GNSS/INS errors
//! shaped by urban canyons, and the sensor data (panoramas, depth images, aerial images, cadastres) a real
//! campaign would deliver. Synchronous and I/O-free: everything is produced as values and bytes.

pub mod aerial;
pub mod cadastre;
pub mod city_aerial;
pub mod map;
pub mod mls;
pub mod motion;
pub mod observations;
pub mod ortho;
pub mod render;
pub mod route;
pub mod scan;
pub mod sensors;
pub mod texture;
pub mod world;
