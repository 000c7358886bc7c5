//! Reading a tile's files a few at a time and decoding images to gray, off the async runtime. Every failure
//! is a [`SkippedInput`] naming the file; the caller goes on with the rest.

use bytes::Bytes;
use futures::StreamExt as _;
use plumbline_imaging::{GrayImage, Mask};
use plumbline_runtime::{Files, is_invalid};
use plumbline_scheduler::SkippedInput;

/// A skipped item of `stage`.
pub(crate) fn skipped(stage: &str, item: &str, reason: &str, detail: String) -> SkippedInput {
    SkippedInput { stage: stage.to_owned(), item: item.to_owned(), reason: reason.to_owned(), detail }
}

/// Read `urls` with at most `concurrency` reads in flight, in order. A missing or unreadable file becomes a
/// skipped item of `stage` (reason `missing` or `read`).
pub(crate) async fn read_all(
    files: &Files,
    urls: &[String],
    concurrency: usize,
    stage: &str,
) -> Vec<Result<Bytes, SkippedInput>> {
    futures::stream::iter(urls.iter().map(|url| async move {
        files.read(url).await.map_err(|e| {
            let reason = if is_invalid(&e) { "missing" } else { "read" };
            skipped(stage, url, reason, format!("{url}: cannot be read: {e:#}"))
        })
    }))
    .buffered(concurrency.max(1))
    .collect()
    .await
}

/// Luma of an RGB pixel (ITU-R BT.601 weights), the panoramas' and aerial frames' gray value.
fn luma(rgb: &[u8]) -> f32 {
    0.299 * f32::from(rgb[0]) + 0.587 * f32::from(rgb[1]) + 0.114 * f32::from(rgb[2])
}

/// Decode a JPEG/PNG (any colour type) to a gray image; the error names the file.
pub(crate) fn decode_gray(url: &str, bytes: &[u8]) -> Result<GrayImage, String> {
    let decoded = image::load_from_memory(bytes).map_err(|e| format!("{url}: not a readable image: {e}"))?;
    let rgb = decoded.to_rgb8();
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    let raw = rgb.as_raw();
    Ok(GrayImage::from_fn(w, h, |c, r| {
        let k = (r * w + c) * 3;
        luma(&raw[k..k + 3])
    }))
}

/// Decode a vehicle mask (non-zero = vehicle, the manifest's convention) into a [`Mask`] (set = vehicle).
pub(crate) fn decode_mask(url: &str, bytes: &[u8]) -> Result<Mask, String> {
    let decoded = image::load_from_memory(bytes).map_err(|e| format!("{url}: not a readable image: {e}"))?;
    let gray = decoded.to_luma8();
    let (w, h) = (gray.width() as usize, gray.height() as usize);
    let raw = gray.as_raw();
    Ok(Mask::from_fn(w, h, |c, r| raw[r * w + c] != 0))
}

/// Run CPU-bound work on tokio's blocking pool.
pub(crate) async fn blocking<T: Send + 'static>(work: impl FnOnce() -> T + Send + 'static) -> anyhow::Result<T> {
    tokio::task::spawn_blocking(work).await.map_err(|e| anyhow::anyhow!("worker task failed: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png_rgb(w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> Vec<u8> {
        let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb(f(x, y)));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    }

    #[test]
    fn gray_is_the_luma_of_the_pixel_at_the_same_place() {
        let png = png_rgb(6, 4, |x, y| [(10 * x) as u8, (20 * y) as u8, 200]);
        let g = decode_gray("a.png", &png).unwrap();
        assert_eq!((g.width(), g.height()), (6, 4));
        let expect = 0.299 * 50.0 + 0.587 * 60.0 + 0.114 * 200.0;
        assert!((g.get(5, 3) - expect).abs() < 1e-4, "{}", g.get(5, 3));
    }

    #[test]
    fn mask_marks_non_zero_pixels_as_vehicle_and_garbage_names_the_file() {
        let png = png_rgb(4, 2, |x, y| if y == 1 && x >= 2 { [255, 255, 255] } else { [0, 0, 0] });
        let m = decode_mask("mask.png", &png).unwrap();
        assert_eq!(m.count(), 2);
        assert!(m.get(3, 1) && !m.get(0, 0));
        let e = decode_gray("dir/broken.jpg", b"not an image").unwrap_err();
        assert!(e.starts_with("dir/broken.jpg: "), "{e}");
    }
}
