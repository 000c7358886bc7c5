//! Synthetic city campaigns with ground truth: a procedural world, drives through it with GNSS/INS errors
//! shaped by urban canyons, and the sensor data (panoramas, depth images, aerial images, cadastres) a real
//! campaign would deliver. Synchronous and I/O-free: everything is produced as values and bytes.
//!
//! ```text
//! World::generate(&WorldConfig) → World (streets, buildings, poles, trees, cars, relief; seeded)
//! route + motion → Drive (the true trajectory) → motion::imu / motion::gnss / motion::dg → IMU increments,
//!     GNSS fixes and the DG solution with urban-canyon errors
//! sensors::shots → panoramas and depth frames along the drive; render::render_panorama / render_depth /
//!     render_aerial / ortho::render_orthophoto → the pixels (realism: tone, seams, blur, shadows)
//! aerial::block, cadastre::cadastre, mls::scan_profiles → the aerial block, the pole cadastre, the roof
//!     scanner's points — each beside its truth
//! ```

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
