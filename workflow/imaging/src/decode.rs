//! Bounded decoding of PNG and JPEG bytes: the one decoder every reader of images uses (panoramas, aerial
//! frames, vehicle masks, depth images, `plumbline match`).
//!
//! A compressed file says nothing about the memory its pixels need: a 389 KB PNG can claim 20000 × 20000
//! pixels (400 MB of 8-bit grey, 1.6 GB as `f32`). So the header is read first and the image refused —
//! before any pixel buffer exists — when width × height exceeds the caller's [`Bounds::max_pixels`] or
//! differs from the size the caller knows it must have ([`Bounds::expected`]). The decode itself then runs
//! under [`image::Limits`] set to the checked width and height and the buffer the header implies (plus
//! [`DECODER_SLACK_BYTES`] for the decoder's own buffers), a second guard should a decoder allocate more
//! than its header said.
//!
//! Budgets ([`PANORAMA_PIXELS`], [`AERIAL_FRAME_PIXELS`], [`DEPTH_PIXELS`]) admit the largest real sensor
//! of each kind; callers that know an exact size give it as well, so a file of another size is refused
//! even when it fits the budget.

use std::io::Cursor;

use ::image::error::{DecodingError, ImageFormatHint, UnsupportedError, UnsupportedErrorKind};
pub use ::image::{ColorType, ImageFormat};
use ::image::{DynamicImage, ImageDecoder as _, ImageError, ImageReader, Limits};

use crate::image::{GrayImage, ImagePart, Mask};

/// Budget of a panorama and of its vehicle mask: 16384 × 8192 px (134 M px), the largest equirectangular
/// panoramas of survey cameras (e.g. Ladybug6: 12288 × 6144). Its 8-bit RGB decode takes 0.4 GB and the
/// f32 grey image 0.5 GB; the worker holds one of each per rayon thread at a time.
pub const PANORAMA_PIXELS: u64 = 16_384 * 8_192;

/// Budget of an aerial frame: 450 M px, so the largest digital aerial camera in production use
/// (UltraCam Eagle Mark 3 at 26460 × 17004 = 449.9 M px) fits. That is what it costs to admit it: 1.35 GB
/// of 8-bit RGB decode plus 1.8 GB of f32 grey per frame at its peak. A lower default would skip every
/// frame of such a campaign; the frame's size is already pinned to the manifest's interior orientation
/// (`Bounds::expected`), so this budget only stops a manifest (or file) that claims more than any camera
/// delivers.
pub const AERIAL_FRAME_PIXELS: u64 = 450_000_000;

/// Budget of a depth image: 4096 × 4096 px (16.8 M px), above every RGB-D, time-of-flight and stereo depth
/// camera (≤ 4096 × 3072). A depth pixel becomes a point of ~56 bytes, so this bounds a frame's points
/// near 0.9 GB.
pub const DEPTH_PIXELS: u64 = 4_096 * 4_096;

/// Bytes granted to a decoder beyond the pixel buffer its header implies (PNG row buffers and inflate
/// window, JPEG component planes, metadata chunks).
pub const DECODER_SLACK_BYTES: u64 = 64 << 20;

/// What an image must satisfy before its pixels are decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bounds {
    /// Most pixels (width × height) admitted.
    pub max_pixels: u64,
    /// The size (width, height) the caller knows the image has, if it knows one.
    pub expected: Option<(u32, u32)>,
    /// The only format admitted, if the caller requires one (depth images: PNG).
    pub format: Option<ImageFormat>,
}

impl Bounds {
    /// At most `max_pixels` pixels, any size and format.
    pub const fn budget(max_pixels: u64) -> Self {
        Self { max_pixels, expected: None, format: None }
    }

    /// These bounds, and exactly `width` × `height` pixels.
    pub const fn expecting(self, width: u32, height: u32) -> Self {
        Self { expected: Some((width, height)), ..self }
    }

    /// These bounds, and only `format`.
    pub const fn only(self, format: ImageFormat) -> Self {
        Self { format: Some(format), ..self }
    }
}

/// Why bytes were not decoded. Every variant names the image (file or URL) as given by the caller.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    /// The bytes are not an image the decoder reads (format unknown, header or data broken, or the decoder
    /// reached its [`image::Limits`]).
    #[error("{image}: not a readable image: {source}")]
    Unreadable {
        /// The image.
        image: String,
        /// The decoder's error.
        source: ImageError,
    },
    /// The image is in another format than the one required.
    #[error("{image}: a {found} image, expected {expected}")]
    Format {
        /// The image.
        image: String,
        /// The format found, by name ("JPEG").
        found: String,
        /// The format required, by name ("PNG").
        expected: String,
    },
    /// The header claims more pixels than the budget.
    #[error(
        "{image}: {width} × {height} px ({:.1} M px) exceeds the pixel budget of {:.1} M px ({max_pixels} px)",
        megapixels(u64::from(*width) * u64::from(*height)),
        megapixels(*max_pixels)
    )]
    OverBudget {
        /// The image.
        image: String,
        /// Width in the header.
        width: u32,
        /// Height in the header.
        height: u32,
        /// The budget.
        max_pixels: u64,
    },
    /// The header's size differs from the size the caller knows.
    #[error("{image}: {width} × {height} px, expected {expected_width} × {expected_height} px")]
    Size {
        /// The image.
        image: String,
        /// Width in the header.
        width: u32,
        /// Height in the header.
        height: u32,
        /// The width expected.
        expected_width: u32,
        /// The height expected.
        expected_height: u32,
    },
    /// The header claims no pixels (a zero width or height).
    #[error("{image}: {width} × {height} px, an empty image")]
    Empty {
        /// The image.
        image: String,
        /// Width in the header.
        width: u32,
        /// Height in the header.
        height: u32,
    },
}

impl DecodeError {
    /// Whether the image was refused for its size (budget, expected size, empty) rather than for its bytes.
    pub fn is_size(&self) -> bool {
        matches!(self, Self::OverBudget { .. } | Self::Size { .. } | Self::Empty { .. })
    }
}

fn megapixels(pixels: u64) -> f64 {
    pixels as f64 / 1e6
}

/// What the header of an image says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// The format, guessed from the bytes.
    pub format: ImageFormat,
    /// Bytes of the decoder's output buffer.
    pub buffer_bytes: u64,
    /// Channels and bits of the pixels (`L16` for a 16-bit gray depth image).
    pub color: ColorType,
}

/// Read the header of `bytes` (named `image` in errors) and check it against `bounds`; no pixel is decoded.
pub fn header(image: &str, bytes: &[u8], bounds: &Bounds) -> Result<Header, DecodeError> {
    let unreadable = |source| DecodeError::Unreadable { image: image.to_owned(), source };
    let reader = ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| unreadable(e.into()))?;
    let Some(format) = reader.format() else {
        let unknown = ImageFormatHint::Unknown;
        let kind = UnsupportedErrorKind::Format(ImageFormatHint::Unknown);
        return Err(unreadable(ImageError::Unsupported(UnsupportedError::from_format_and_kind(unknown, kind))));
    };
    if let Some(expected) = bounds.format
        && format != expected
    {
        let (found, expected) = (format_name(format), format_name(expected));
        return Err(DecodeError::Format { image: image.to_owned(), found, expected });
    }
    // Constructing the decoder reads the header (PNG: up to the first IDAT; JPEG: the frame header); it
    // allocates no pixel buffer.
    let decoder = reader.into_decoder().map_err(unreadable)?;
    let (width, height) = decoder.dimensions();
    let (buffer_bytes, color) = (decoder.total_bytes(), decoder.color_type());
    check(image, width, height, bounds)?;
    Ok(Header { width, height, format, buffer_bytes, color })
}

/// Refuse `width` × `height` when it is empty, over budget or not the expected size.
fn check(image: &str, width: u32, height: u32, bounds: &Bounds) -> Result<(), DecodeError> {
    if width == 0 || height == 0 {
        return Err(DecodeError::Empty { image: image.to_owned(), width, height });
    }
    if u64::from(width) * u64::from(height) > bounds.max_pixels {
        return Err(DecodeError::OverBudget { image: image.to_owned(), width, height, max_pixels: bounds.max_pixels });
    }
    if let Some((expected_width, expected_height)) = bounds.expected
        && (width, height) != (expected_width, expected_height)
    {
        return Err(DecodeError::Size { image: image.to_owned(), width, height, expected_width, expected_height });
    }
    Ok(())
}

/// The format's name for messages: "PNG", "JPEG".
fn format_name(format: ImageFormat) -> String {
    format!("{format:?}").to_uppercase()
}

/// Decode `bytes` (named `image` in errors) within `bounds`: the header is checked first ([`header`]), then
/// the pixels are decoded under [`image::Limits`] of the checked size and buffer.
pub fn decode(image: &str, bytes: &[u8], bounds: &Bounds) -> Result<DynamicImage, DecodeError> {
    let header = header(image, bytes, bounds)?;
    decode_checked(image, bytes, &header)
}

/// The decoder's limits for an image whose header was checked: its width and height, and its output buffer
/// plus [`DECODER_SLACK_BYTES`].
fn limits(header: &Header) -> Limits {
    let mut limits = Limits::default();
    limits.max_image_width = Some(header.width);
    limits.max_image_height = Some(header.height);
    limits.max_alloc = Some(header.buffer_bytes.saturating_add(DECODER_SLACK_BYTES));
    limits
}

/// Decode `bytes` as `header` says, under [`limits`] of it.
fn decode_checked(image: &str, bytes: &[u8], header: &Header) -> Result<DynamicImage, DecodeError> {
    let mut reader = ImageReader::with_format(Cursor::new(bytes), header.format);
    reader.limits(limits(header));
    reader.decode().map_err(|source| DecodeError::Unreadable { image: image.to_owned(), source })
}

/// Luma of an RGB pixel (ITU-R BT.601 weights): the grey value of panoramas, aerial frames and `match`.
pub fn luma(rgb: [u8; 3]) -> f32 {
    0.299 * f32::from(rgb[0]) + 0.587 * f32::from(rgb[1]) + 0.114 * f32::from(rgb[2])
}

/// Decode a PNG or JPEG of any colour type within `bounds` to a grey image ([`luma`] of its 8-bit RGB;
/// grey input gives the luma of (g, g, g)). 8-bit grey and RGB are converted without an RGB copy.
pub fn decode_gray(image: &str, bytes: &[u8], bounds: &Bounds) -> Result<GrayImage, DecodeError> {
    let decoded = decode(image, bytes, bounds)?;
    let (w, h) = (decoded.width() as usize, decoded.height() as usize);
    Ok(match decoded {
        DynamicImage::ImageLuma8(gray) => {
            let raw = gray.as_raw();
            GrayImage::from_fn(w, h, |c, r| {
                let g = raw[r * w + c];
                luma([g, g, g])
            })
        }
        other => {
            let rgb = other.into_rgb8();
            let raw = rgb.as_raw();
            GrayImage::from_fn(w, h, |c, r| {
                let k = (r * w + c) * 3;
                luma([raw[k], raw[k + 1], raw[k + 2]])
            })
        }
    })
}

/// Decode `part` of a PNG or JPEG (named `image` in errors) to grey ([`ImagePart::extract`]); the image
/// must have the part's full size and fit `bounds`. A YCbCr or grey JPEG is decoded straight to its luma
/// channel (the JFIF Y is [`luma`] of the RGB it encodes): no chroma, no RGB buffer, so a 16384 × 8192
/// panorama peaks at its 134 MB of 8-bit luma plus the part as `f32`. Anything else goes through
/// [`decode_gray`] first.
pub fn decode_gray_part(
    image: &str,
    bytes: &[u8],
    bounds: &Bounds,
    part: &ImagePart,
) -> Result<GrayImage, DecodeError> {
    let (width, height) = part.full();
    let bounds = bounds.expecting(width, height);
    let header = header(image, bytes, &bounds)?;
    let unreadable = |source| DecodeError::Unreadable { image: image.to_owned(), source };
    if header.format == ImageFormat::Jpeg
        && let Some(luma) = jpeg_luma(bytes, &header).map_err(unreadable)?
    {
        return part.extract(&luma).ok_or_else(|| unreadable(short_output(&header)));
    }
    let gray = decode_gray(image, bytes, &bounds)?;
    if part.is_whole() {
        return Ok(gray);
    }
    part.extract(gray.data()).ok_or_else(|| unreadable(short_output(&header)))
}

/// The luma plane of a YCbCr or grey JPEG whose header was checked; `None` for other colour spaces (CMYK,
/// RGB JPEGs), which need the full decoder.
fn jpeg_luma(bytes: &[u8], header: &Header) -> Result<Option<Vec<u8>>, ImageError> {
    use zune_core::colorspace::ColorSpace;
    use zune_core::options::DecoderOptions;
    let failed = |e: zune_jpeg::errors::DecodeErrors| {
        ImageError::Decoding(DecodingError::new(ImageFormatHint::Exact(ImageFormat::Jpeg), e.to_string()))
    };
    let options = DecoderOptions::default()
        .set_max_width(header.width as usize)
        .set_max_height(header.height as usize)
        .jpeg_set_out_colorspace(ColorSpace::Luma);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(Cursor::new(bytes), options);
    decoder.decode_headers().map_err(failed)?;
    if !matches!(decoder.input_colorspace(), Some(ColorSpace::YCbCr | ColorSpace::Luma)) {
        return Ok(None);
    }
    let luma = decoder.decode().map_err(failed)?;
    Ok(Some(luma))
}

/// The error for a decoder whose output is not the size its header said.
fn short_output(header: &Header) -> ImageError {
    let hint = ImageFormatHint::Exact(header.format);
    ImageError::Decoding(DecodingError::new(hint, format!("output is not {} × {} px", header.width, header.height)))
}

/// Decode a mask within `bounds`: a pixel is set where its 8-bit luma is non-zero (the manifest's vehicle
/// mask convention: non-zero = vehicle).
pub fn decode_mask(image: &str, bytes: &[u8], bounds: &Bounds) -> Result<Mask, DecodeError> {
    let gray = match decode(image, bytes, bounds)? {
        DynamicImage::ImageLuma8(gray) => gray,
        other => other.to_luma8(),
    };
    let (w, h) = (gray.width() as usize, gray.height() as usize);
    let raw = gray.as_raw();
    Ok(Mask::from_fn(w, h, |c, r| raw[r * w + c] != 0))
}

#[cfg(test)]
mod tests;
