//! Encoding rendered rasters to bytes (JPEG, 8-bit and 16-bit PNG), in memory.

use std::io::Cursor;

use image::codecs::jpeg::JpegEncoder;
use image::{GrayImage, ImageBuffer, ImageFormat, Luma, RgbImage};

/// An image that could not be encoded.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The encoder failed.
    #[error("encoding {what} failed: {source}")]
    Encode {
        /// Which format.
        what: &'static str,
        /// The encoder's error.
        source: image::ImageError,
    },
}

/// JPEG bytes of an RGB image at `quality` (1–100).
pub fn encode_jpeg(image: &RgbImage, quality: u8) -> Result<Vec<u8>, RenderError> {
    let mut out = Vec::new();
    let enc = JpegEncoder::new_with_quality(&mut out, quality.clamp(1, 100));
    image.write_with_encoder(enc).map_err(|source| RenderError::Encode { what: "jpeg", source })?;
    Ok(out)
}

/// PNG bytes of an RGB image.
pub fn encode_png_rgb(image: &RgbImage) -> Result<Vec<u8>, RenderError> {
    let mut out = Cursor::new(Vec::new());
    image.write_to(&mut out, ImageFormat::Png).map_err(|source| RenderError::Encode { what: "png rgb", source })?;
    Ok(out.into_inner())
}

/// PNG bytes of an 8-bit grey image (masks).
pub fn encode_png_gray(image: &GrayImage) -> Result<Vec<u8>, RenderError> {
    let mut out = Cursor::new(Vec::new());
    image.write_to(&mut out, ImageFormat::Png).map_err(|source| RenderError::Encode { what: "png gray", source })?;
    Ok(out.into_inner())
}

/// 16-bit grey PNG bytes (depth images in millimetres).
pub fn encode_png_gray16(image: &ImageBuffer<Luma<u16>, Vec<u16>>) -> Result<Vec<u8>, RenderError> {
    let mut out = Cursor::new(Vec::new());
    image.write_to(&mut out, ImageFormat::Png).map_err(|source| RenderError::Encode { what: "png gray16", source })?;
    Ok(out.into_inner())
}
