//! Image primitives: bounded decoding of PNG/JPEG bytes, ortho-projection, filters, KAZE/AKAZE, corners, NCC,
//! least-squares matching, RANSAC.
//!
//! ```text
//! decode (bounded, checked sizes) → GrayImage → ortho / warp (resampling onto a ground grid)
//!   → radiometry (Wallis, stretch), seams (exposure steps of a panorama levelled)
//!   → kaze / akaze (FED scale space, keypoints, descriptors) → models + ransac (transformations)
//!   → corners (Förstner) → ncc (coarse correspondence) → lsm (least-squares matching, sub-pixel)
//! ```
//!
//! Synchronous and I/O-free; rayon parallelism inside. Pixel coordinates follow ARCHITECTURE.md.

pub mod akaze;
pub mod corners;
pub mod decode;
pub mod error;
pub mod filter;
pub mod image;
pub mod integral;
pub mod kaze;
pub mod lsm;
pub mod models;
pub mod ncc;
mod nearest;
pub mod ortho;
pub mod radiometry;
pub mod ransac;
pub mod seams;
mod stencil;
pub mod warp;

pub use self::image::{GrayImage, ImagePart, Mask};
pub use error::ImagingError;
