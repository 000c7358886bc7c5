//! Separable Gaussian blur and the Wallis filter (Jende et al. 2017 §3.6–3.7).

use rayon::prelude::*;

use crate::error::{ImagingError, require};
use crate::image::GrayImage;
use crate::integral::IntegralImage;

/// A normalised 1-D Gaussian kernel of radius ⌈3σ⌉.
pub fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let radius = (3.0 * sigma).ceil().max(1.0) as i64;
    let k: Vec<f64> = (-radius..=radius).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp()).collect();
    let total: f64 = k.iter().sum();
    k.iter().map(|&x| (x / total) as f32).collect()
}

/// Gaussian blur with standard deviation `sigma` pixels (separable, edges replicated, row-parallel).
/// Jende et al. 2017 §3.6: blurring the MM ortho-image simulates the aerial camera's optical transfer function.
pub fn gaussian_blur(img: &GrayImage, sigma: f64) -> Result<GrayImage, ImagingError> {
    require(sigma.is_finite() && sigma >= 0.0, "sigma", sigma, "must be a finite, non-negative pixel count")?;
    if sigma < 1e-3 {
        return Ok(img.clone());
    }
    let k = gaussian_kernel(sigma);
    Ok(convolve_columns(&convolve_rows(img, &k), &k))
}

/// Convolve every row with an odd kernel (correlation: out[c] = Σ k[i] · src[c + i − radius]), replicating
/// the edges.
pub(crate) fn convolve_rows(img: &GrayImage, k: &[f32]) -> GrayImage {
    let w = img.width();
    let mut out = GrayImage::filled(w, img.height(), 0.0);
    if w > 0 {
        out.data_mut().par_chunks_mut(w).enumerate().for_each(|(r, line)| convolve_row(img.row(r), k, line));
    }
    out
}

/// One row of `convolve_rows`: in the interior every tap is accumulated across the row (a loop the compiler
/// vectorises, unlike a dot product per pixel); the ends use clamped indices.
fn convolve_row(src: &[f32], k: &[f32], line: &mut [f32]) {
    let (w, radius) = (src.len(), k.len() / 2);
    let clamped = |c: usize| -> f32 {
        k.iter().enumerate().map(|(i, &kv)| kv * src[(c + i).saturating_sub(radius).min(w - 1)]).sum()
    };
    if w <= 2 * radius {
        line.iter_mut().enumerate().for_each(|(c, o)| *o = clamped(c));
        return;
    }
    let n = w - 2 * radius;
    let inner = &mut line[radius..radius + n];
    for (i, &kv) in k.iter().enumerate() {
        inner.iter_mut().zip(&src[i..i + n]).for_each(|(o, &s)| *o += kv * s);
    }
    for c in (0..radius).chain(w - radius..w) {
        line[c] = clamped(c);
    }
}

/// Convolve every column with a symmetric odd kernel, replicating the edges.
pub(crate) fn convolve_columns(img: &GrayImage, k: &[f32]) -> GrayImage {
    let (w, h, radius) = (img.width(), img.height(), (k.len() / 2) as isize);
    let mut out = GrayImage::filled(w, h, 0.0);
    out.data_mut().par_chunks_mut(w).enumerate().for_each(|(r, line)| {
        for (i, &kv) in k.iter().enumerate() {
            let src = img.row((r as isize + i as isize - radius).clamp(0, h as isize - 1) as usize);
            line.iter_mut().zip(src).for_each(|(o, &s)| *o += kv * s);
        }
    });
    out
}

/// Parameters of the Wallis filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wallis {
    /// Half-size of the square window for the local mean and standard deviation, pixels.
    pub half_window: usize,
    /// Target mean m_f.
    pub target_mean: f64,
    /// Target standard deviation s_f.
    pub target_std: f64,
    /// Contrast expansion constant c ∈ (0, 1]: 1 forces the target contrast fully.
    pub contrast: f64,
    /// Brightness forcing constant b ∈ [0, 1]: 1 forces the target mean fully.
    pub brightness: f64,
}

impl Default for Wallis {
    fn default() -> Self {
        Self { half_window: 15, target_mean: 127.0, target_std: 50.0, contrast: 0.9, brightness: 0.9 }
    }
}

impl Wallis {
    /// Apply the filter: g' = (g − m)·c·s_f / (c·s + (1 − c)·s_f) + b·m_f + (1 − b)·m, with m, s the local
    /// mean and standard deviation over the window. Jende et al. 2017 §3.7 (Wallis 1976, photogrammetric form).
    pub fn apply(&self, img: &GrayImage) -> Result<GrayImage, ImagingError> {
        require(self.half_window > 0, "half_window", self.half_window as f64, "must be positive")?;
        require(self.target_std > 0.0, "target_std", self.target_std, "must be positive")?;
        require(self.contrast > 0.0 && self.contrast <= 1.0, "contrast", self.contrast, "must be in (0, 1]")?;
        require((0.0..=1.0).contains(&self.brightness), "brightness", self.brightness, "must be in [0, 1]")?;
        let ii = IntegralImage::new(img);
        let (c, b, mf, sf) = (self.contrast, self.brightness, self.target_mean, self.target_std);
        Ok(GrayImage::from_fn(img.width(), img.height(), |col, row| {
            let st = ii.centred(col, row, self.half_window);
            let (m, s) = (st.mean(), st.std());
            let gain = c * sf / (c * s + (1.0 - c) * sf); // Jende et al. 2017 §3.7 (Wallis 1976)
            ((f64::from(img.get(col, row)) - m) * gain + b * mf + (1.0 - b) * m) as f32
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_preserves_the_mean_and_spreads_an_impulse_with_the_right_variance() {
        let mut img = GrayImage::filled(41, 41, 0.0);
        img.set(20, 20, 1000.0);
        let out = gaussian_blur(&img, 2.5).unwrap();
        let total: f64 = out.data().iter().map(|&x| f64::from(x)).sum();
        assert!((total - 1000.0).abs() < 1e-2, "{total}");
        // Second moment along x of the spread impulse is σ².
        let var: f64 = (0..41)
            .flat_map(|r| (0..41).map(move |c| (c, r)))
            .map(|(c, r)| f64::from(out.get(c, r)) * (c as f64 - 20.0).powi(2))
            .sum::<f64>()
            / 1000.0;
        assert!((var - 6.25).abs() < 0.05, "variance {var}");
        assert!(gaussian_blur(&img, -1.0).is_err());
    }

    #[test]
    fn wallis_equalises_two_images_that_differ_in_gain_and_offset_and_hits_its_targets() {
        let texture = |c: usize, r: usize| ((c as f32 * 0.7).sin() * (r as f32 * 0.45).cos()) * 30.0;
        let a = GrayImage::from_fn(80, 60, |c, r| 100.0 + texture(c, r));
        // The second image: darker, lower contrast, with a brightness ramp (an illumination change).
        let b = GrayImage::from_fn(80, 60, |c, r| 40.0 + 0.3 * c as f32 + 0.4 * texture(c, r));
        let w = Wallis { half_window: 7, target_mean: 128.0, target_std: 40.0, contrast: 1.0, brightness: 1.0 };
        let (fa, fb) = (w.apply(&a).unwrap(), w.apply(&b).unwrap());
        let inner = |img: &GrayImage| IntegralImage::new(img).window(10, 10, 70, 50);
        for f in [&fa, &fb] {
            let st = inner(f);
            assert!((st.mean() - 128.0).abs() < 3.0 && (st.std() - 40.0).abs() < 6.0, "{} {}", st.mean(), st.std());
        }
        let worst = (10..50)
            .flat_map(|r| (10..70).map(move |c| (c, r)))
            .map(|(c, r)| (fa.get(c, r) - fb.get(c, r)).abs())
            .fold(0.0f32, f32::max);
        // Before filtering the images differ by tens of grey values everywhere.
        assert!(worst < 4.0, "largest difference after Wallis {worst}");
        assert!(Wallis { contrast: 0.0, ..w }.apply(&a).is_err());
    }
}
