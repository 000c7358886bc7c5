//! Depth images (16-bit PNG, paper 002's RGB-D set-up) into mapping-frame points: pixel + depth → camera
//! frame → map through the DG pose and the depth camera's mount (paper 003 eq. (1)).

use image::{DynamicImage, ImageFormat};
use nalgebra::Vector3;
use plumbline_campaign::manifest::DepthIntrinsics;
use plumbline_geo::dg::CameraMount;
use plumbline_geo::{Camera, MapFromBody, Vec3};
use rayon::prelude::*;

use crate::points::{FramePoint, FramePoints};

/// Why a depth image could not be used.
#[derive(Debug, thiserror::Error)]
pub enum DepthError {
    /// The bytes are not a PNG the decoder reads.
    #[error("depth image {image}: not a readable PNG: {source}")]
    Decode {
        /// The image.
        image: String,
        /// The decoder's error.
        source: image::ImageError,
    },
    /// The PNG is not 16-bit grey.
    #[error("depth image {image}: pixel format {found} (expected 16-bit grey)")]
    PixelFormat {
        /// The image.
        image: String,
        /// The format found.
        found: String,
    },
    /// The size differs from the intrinsics.
    #[error("depth image {image}: {width} × {height} px, the intrinsics say {expected_width} × {expected_height}")]
    Size {
        /// The image.
        image: String,
        /// Width found.
        width: u32,
        /// Height found.
        height: u32,
        /// Width of the intrinsics.
        expected_width: u32,
        /// Height of the intrinsics.
        expected_height: u32,
    },
    /// A parameter is out of its domain.
    #[error("depth image {image}: {field} = {value}: {expected}")]
    Parameter {
        /// The image.
        image: String,
        /// The parameter.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What is expected.
        expected: &'static str,
    },
}

/// A decoded depth image: camera-frame z per pixel in metres, row-major; 0 where nothing was measured or the
/// value lies outside the intrinsics' range.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Depth per pixel, metres (0 = none).
    pub depth_m: Vec<f32>,
}

/// Decode a 16-bit PNG depth image with the manifest's intrinsics (scale and range limits).
pub fn decode_depth_png(image: &str, bytes: &[u8], k: &DepthIntrinsics) -> Result<DepthImage, DepthError> {
    check_intrinsics(image, k)?;
    let decoded = image::load_from_memory_with_format(bytes, ImageFormat::Png)
        .map_err(|source| DepthError::Decode { image: image.to_owned(), source })?;
    let DynamicImage::ImageLuma16(gray) = decoded else {
        return Err(DepthError::PixelFormat { image: image.to_owned(), found: format!("{:?}", decoded.color()) });
    };
    if (gray.width(), gray.height()) != (k.width_px, k.height_px) {
        return Err(DepthError::Size {
            image: image.to_owned(),
            width: gray.width(),
            height: gray.height(),
            expected_width: k.width_px,
            expected_height: k.height_px,
        });
    }
    let depth_m = gray
        .as_raw()
        .par_iter()
        .map(|&raw| {
            let z = f64::from(raw) * k.depth_scale_m;
            if raw > 0 && (k.min_range_m..=k.max_range_m).contains(&z) { z as f32 } else { 0.0 }
        })
        .collect();
    Ok(DepthImage { width: k.width_px, height: k.height_px, depth_m })
}

fn check_intrinsics(image: &str, k: &DepthIntrinsics) -> Result<(), DepthError> {
    let bad = |field, value, expected| DepthError::Parameter { image: image.to_owned(), field, value, expected };
    for (field, value) in [("fx", k.fx), ("fy", k.fy), ("depth_scale_m", k.depth_scale_m)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(bad(field, value, "must be positive and finite"));
        }
    }
    if !(k.min_range_m >= 0.0 && k.max_range_m > k.min_range_m && k.max_range_m.is_finite()) {
        return Err(bad("max_range_m", k.max_range_m, "must be finite and above min_range_m"));
    }
    Ok(())
}

/// The pixels of a depth image as mapping-frame points, georeferenced with the vehicle pose `body` (the DG
/// pose when processing) and the camera's `mount`; each carries its range error (σ = `range_error_share`
/// × depth, paper 002 §3.1.2) as a displacement along its ray.
pub fn depth_points(
    depth: &DepthImage,
    k: &DepthIntrinsics,
    range_error_share: f64,
    mount: &CameraMount,
    body: &MapFromBody,
) -> FramePoints {
    let origin = mount.camera_pose(body).translation.p;
    let width = depth.width as usize;
    let points: Vec<FramePoint> = depth
        .depth_m
        .par_chunks(width.max(1))
        .enumerate()
        .flat_map_iter(|(row, line)| {
            let y = (row as f64 + 0.5 - k.cy) / k.fy;
            line.iter().enumerate().filter(|(_, z)| **z > 0.0).map(move |(col, &z)| {
                let x = (col as f64 + 0.5 - k.cx) / k.fx;
                let ray = Vec3::<Camera>::new(x, y, 1.0);
                let z = f64::from(z);
                // paper 003 eq. (1): r_M = r_INS + R_B^M (s R_C^B r_C + b), with r_C at unit depth and s = z.
                let position = mount.georeference(body, &ray, z).p;
                let direction: Vector3<f64> = body.rotation.apply(&mount.boresight.apply(&ray)).v;
                // paper 002 §3.1.2: σ_depth = share · depth, along the pixel's ray.
                FramePoint { position, error: direction * (range_error_share * z), row: Some(row as u32) }
            })
        })
        .collect();
    // The range cut-off truncates a depth's error distribution within 3σ of max_range_m.
    let reliable_range_m = k.max_range_m / (1.0 + 3.0 * range_error_share);
    FramePoints { origin, angular_step: 1.0 / k.fx.max(k.fy), reliable_range_m, points }
}
