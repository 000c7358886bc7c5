//! One grey channel from the bands of an aerial raster window (frames and orthophotos), and the radiometric
//! stretch that brings data deeper than 8 bits to the 0–255 scale the detectors' thresholds assume.
//!
//! Band choice: one band is grey; two bands are grey + alpha (band 1 is used); three or more are red, green,
//! blue and optional further bands (near infrared of 4-band RGBI cameras), of which the first three are
//! weighted as [`crate::decode::luma`] (0.299 R + 0.587 G + 0.114 B) and the rest ignored — street markings,
//! kerbs and manholes show in the visible bands, and vegetation's strong NIR response would only add texture
//! that the street-level panoramas do not see.
//!
//! Stretch: 8-bit data keeps its values. Deeper data (12–16-bit frames in 16-bit containers, float
//! reflectances) is mapped linearly so that the [`LOW_PERCENTILE`] and [`HIGH_PERCENTILE`] of the window's
//! grey values become 0 and 255, clamped: the matching uses normalised correlation, which does not care, but
//! the KAZE detector's threshold expects 8-bit contrast. The stretch is fitted per window, so a frame read for
//! two tiles may be scaled slightly differently in each; each tile's registration is self-consistent.

use crate::error::ImagingError;
use crate::image::GrayImage;

/// Grey value mapped to 0 by the stretch of deep data, as a fraction of the window's pixels below it.
pub const LOW_PERCENTILE: f64 = 0.005;
/// Grey value mapped to 255 by the stretch of deep data, as a fraction of the window's pixels below it.
pub const HIGH_PERCENTILE: f64 = 0.995;
/// At most this many pixels (evenly strided) fit the stretch.
const STRETCH_SAMPLES: usize = 1 << 20;

/// The grey image of a `width` × `height` window from its bands (row-major, one `Vec` per band in band
/// order); `eight_bit` when the raster's pixels are 8-bit (kept as they are), else stretched to 0–255.
/// Values that are not finite (no data in float rasters) become 0.
pub fn gray_from_bands(
    width: usize,
    height: usize,
    bands: &[Vec<f32>],
    eight_bit: bool,
) -> Result<GrayImage, ImagingError> {
    let n = width * height;
    if let Some(band) = bands.iter().find(|b| b.len() != n) {
        return Err(ImagingError::Shape { what: "raster band", width, height, len: band.len() });
    }
    let mut gray: Vec<f32> = match bands {
        [r, g, b, ..] => (0..n).map(|k| 0.299 * r[k] + 0.587 * g[k] + 0.114 * b[k]).collect(),
        [one, ..] => one.clone(),
        [] => return Err(ImagingError::Shape { what: "raster window without bands", width, height, len: 0 }),
    };
    gray.iter_mut().filter(|v| !v.is_finite()).for_each(|v| *v = 0.0);
    if !eight_bit {
        stretch(&mut gray);
    }
    GrayImage::new(width, height, gray)
}

/// Map the [`LOW_PERCENTILE`]–[`HIGH_PERCENTILE`] range of `values` linearly onto 0–255, clamped. A window of
/// one value becomes 0.
pub fn stretch(values: &mut [f32]) {
    let (lo, hi) = percentiles(values);
    let scale = if hi > lo { 255.0 / (hi - lo) } else { 0.0 };
    for v in values.iter_mut() {
        *v = ((*v - lo) * scale).clamp(0.0, 255.0);
    }
}

/// The stretch's two percentiles of `values`, from an evenly strided sample.
fn percentiles(values: &[f32]) -> (f32, f32) {
    if values.is_empty() {
        return (0.0, 0.0);
    }
    let step = values.len().div_ceil(STRETCH_SAMPLES);
    let mut sample: Vec<f64> = values.iter().step_by(step).map(|&v| f64::from(v)).collect();
    sample.sort_by(f64::total_cmp);
    let at = |p: f64| plumbline_geo::metrics::quantile_sorted(&sample, p).unwrap_or(0.0) as f32;
    (at(LOW_PERCENTILE), at(HIGH_PERCENTILE))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb_bands_give_luma_and_eight_bit_data_keeps_its_values() {
        let bands = vec![vec![255.0, 0.0], vec![0.0, 255.0], vec![0.0, 0.0], vec![9999.0, 9999.0]];
        let g = gray_from_bands(2, 1, &bands, true).unwrap();
        // The fourth (NIR) band is ignored.
        assert!((g.get(0, 0) - 0.299 * 255.0).abs() < 1e-3 && (g.get(1, 0) - 0.587 * 255.0).abs() < 1e-3);
        let one = gray_from_bands(2, 1, &[vec![3.0, 200.0]], true).unwrap();
        assert_eq!(one.data(), &[3.0, 200.0]);
    }

    #[test]
    fn deep_data_is_stretched_from_its_percentiles_and_clamped() {
        // 12-bit data in a 16-bit container: values 1000..=3000 with two outliers.
        let mut v: Vec<f32> = (0..1000).map(|k| 1000.0 + 2.0 * k as f32).collect();
        v[0] = 0.0;
        v[999] = 65535.0;
        let g = gray_from_bands(1000, 1, &[v], false).unwrap();
        let d = g.data();
        assert_eq!((d[0], d[999]), (0.0, 255.0));
        // The middle value lies mid-scale; the scale is linear.
        assert!((d[500] - 127.5).abs() < 2.0, "{}", d[500]);
        assert!(d.windows(2).all(|w| w[1] >= w[0]));
        // No data (NaN) becomes 0 and does not disturb the others.
        let g = gray_from_bands(3, 1, &[vec![f32::NAN, 10.0, 20.0]], false).unwrap();
        assert_eq!(g.data()[0], 0.0);
        assert_eq!(g.data()[2], 255.0);
    }

    #[test]
    fn bands_of_the_wrong_length_and_no_bands_are_errors() {
        assert!(gray_from_bands(2, 2, &[vec![0.0; 3]], true).is_err());
        assert!(gray_from_bands(2, 2, &[], true).is_err());
        let flat = gray_from_bands(2, 1, &[vec![7.0, 7.0]], false).unwrap();
        assert_eq!(flat.data(), &[0.0, 0.0]);
    }
}
