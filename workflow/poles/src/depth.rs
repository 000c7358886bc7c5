//! Depth images (16-bit PNG, the RGB-D set-up of Meyer et al. 2023) into mapping-frame points: pixel + depth → camera
//! frame → map through the DG pose and the depth camera's mount (Grejner-Brzezinska and Toth 2000 eq. (1)).

use image::{DynamicImage, ImageFormat};
use nalgebra::Vector3;
use plumbline_campaign::manifest::DepthIntrinsics;
use plumbline_geo::dg::CameraMount;
use plumbline_geo::{Camera, MapFromBody, Vec3};
use plumbline_imaging::decode::{Bounds, DEPTH_PIXELS, DecodeError, decode};
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
    /// The bytes are an image, but not a PNG.
    #[error("depth image {image}: a {found} image, not a PNG")]
    Format {
        /// The image.
        image: String,
        /// The format found, by name.
        found: String,
    },
    /// The header claims more pixels than [`DEPTH_PIXELS`]: refused before decoding.
    #[error("depth image {image}: {width} × {height} px, beyond the pixel budget of {max_pixels} px")]
    Budget {
        /// The image.
        image: String,
        /// Width in the header.
        width: u32,
        /// Height in the header.
        height: u32,
        /// The budget.
        max_pixels: u64,
    },
    /// The PNG is not 16-bit grey.
    #[error("depth image {image}: pixel format {found} (expected 16-bit grey)")]
    PixelFormat {
        /// The image.
        image: String,
        /// The format found.
        found: String,
    },
    /// The size differs from the intrinsics (checked on the header, before decoding).
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

/// Decode a 16-bit PNG depth image with the manifest's intrinsics (scale and range limits). The header is
/// checked before any pixel is decoded: PNG, at most [`DEPTH_PIXELS`], and the intrinsics' size.
pub fn decode_depth_png(image: &str, bytes: &[u8], k: &DepthIntrinsics) -> Result<DepthImage, DepthError> {
    check_intrinsics(image, k)?;
    let bounds = Bounds::budget(DEPTH_PIXELS).expecting(k.width_px, k.height_px).only(ImageFormat::Png);
    let decoded = decode(image, bytes, &bounds).map_err(|e| refused(image, e, k))?;
    let DynamicImage::ImageLuma16(gray) = decoded else {
        return Err(DepthError::PixelFormat { image: image.to_owned(), found: format!("{:?}", decoded.color()) });
    };
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

/// The depth error of an image the bounded decoder refused (`k`: the intrinsics it was checked against).
fn refused(image: &str, e: DecodeError, k: &DepthIntrinsics) -> DepthError {
    let image = image.to_owned();
    match e {
        DecodeError::Unreadable { source, .. } => DepthError::Decode { image, source },
        DecodeError::Format { found, .. } => DepthError::Format { image, found },
        DecodeError::Size { width, height, expected_width, expected_height, .. } => {
            DepthError::Size { image, width, height, expected_width, expected_height }
        }
        DecodeError::OverBudget { width, height, max_pixels, .. } => {
            DepthError::Budget { image, width, height, max_pixels }
        }
        DecodeError::Empty { width, height, .. } => {
            DepthError::Size { image, width, height, expected_width: k.width_px, expected_height: k.height_px }
        }
    }
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
/// × depth, Meyer et al. 2023 §3.1.2) as a displacement along its ray.
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
                // Grejner-Brzezinska and Toth 2000 eq. (1): r_M = r_INS + R_B^M (s R_C^B r_C + b), with r_C at unit
                // depth and s = z.
                let position = mount.georeference(body, &ray, z).p;
                let direction: Vector3<f64> = body.rotation.apply(&mount.boresight.apply(&ray)).v;
                // Meyer et al. 2023 §3.1.2: σ_depth = share · depth, along the pixel's ray.
                FramePoint { position, error: direction * (range_error_share * z), row: Some(row as u32) }
            })
        })
        .collect();
    // The range cut-off truncates a depth's error distribution within 3σ of max_range_m.
    let reliable_range_m = k.max_range_m / (1.0 + 3.0 * range_error_share);
    FramePoints { origin, angular_step: 1.0 / k.fx.max(k.fy), reliable_range_m, points }
}

#[cfg(test)]
mod tests {
    use plumbline_testkit::images::{png_bomb, png_claiming};

    use super::*;

    fn intrinsics(width_px: u32, height_px: u32) -> DepthIntrinsics {
        let (w, h) = (f64::from(width_px), f64::from(height_px));
        DepthIntrinsics {
            fx: w,
            fy: w,
            cx: w / 2.0,
            cy: h / 2.0,
            width_px,
            height_px,
            depth_scale_m: 0.001,
            min_range_m: 0.4,
            max_range_m: 10.0,
        }
    }

    /// A depth image whose header claims 20000² px, or a real 12000² bomb, is refused on its header
    /// (before decoding) whatever the intrinsics say, naming the image and the size.
    #[test]
    fn a_depth_image_over_the_budget_is_refused_before_decoding() {
        let forged = png_claiming(20_000, 20_000);
        for k in [intrinsics(640, 480), intrinsics(16_384, 16_384)] {
            let e = decode_depth_png("depth/d7.png", &forged, &k).unwrap_err();
            assert!(matches!(e, DepthError::Budget { width: 20_000, height: 20_000, max_pixels: DEPTH_PIXELS, .. }));
            assert_eq!(
                e.to_string(),
                "depth image depth/d7.png: 20000 × 20000 px, beyond the pixel budget of 16777216 px"
            );
        }
        let e = decode_depth_png("d8", &png_bomb(12_000, 12_000), &intrinsics(12_000, 12_000)).unwrap_err();
        assert!(matches!(e, DepthError::Budget { width: 12_000, height: 12_000, .. }), "{e}");
    }

    #[test]
    fn a_depth_image_of_another_size_or_format_is_refused_on_its_header() {
        // Within the budget but not the intrinsics' size: refused before decoding (the data is not there).
        let e = decode_depth_png("d9", &png_claiming(1_280, 720), &intrinsics(640, 480)).unwrap_err();
        assert!(matches!(e, DepthError::Size { width: 1_280, height: 720, expected_width: 640, .. }), "{e}");
        let img = image::GrayImage::from_pixel(4, 3, image::Luma([9]));
        let mut jpeg = std::io::Cursor::new(Vec::new());
        img.write_to(&mut jpeg, ImageFormat::Jpeg).unwrap();
        let e = decode_depth_png("d10", jpeg.get_ref(), &intrinsics(4, 3)).unwrap_err();
        assert_eq!(e.to_string(), "depth image d10: a JPEG image, not a PNG");
    }
}
