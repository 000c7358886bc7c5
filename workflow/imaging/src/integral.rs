//! Integral images of values and squared values (f64), for O(1) window sums, means and variances.

use crate::image::GrayImage;

/// Summed-area tables of an image and of its squares, each (W + 1) × (H + 1).
#[derive(Clone, Debug)]
pub struct IntegralImage {
    width: usize,
    height: usize,
    sum: Vec<f64>,
    sum_sq: Vec<f64>,
}

/// Statistics of a rectangular window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowStats {
    /// Number of pixels.
    pub n: usize,
    /// Sum of the values.
    pub sum: f64,
    /// Sum of the squared values.
    pub sum_sq: f64,
}

impl WindowStats {
    /// Mean value.
    pub fn mean(&self) -> f64 {
        self.sum / self.n as f64
    }

    /// Sum of squared deviations from the mean, clamped at zero against round-off.
    pub fn centred_sum_sq(&self) -> f64 {
        (self.sum_sq - self.sum * self.sum / self.n as f64).max(0.0)
    }

    /// Population standard deviation.
    pub fn std(&self) -> f64 {
        (self.centred_sum_sq() / self.n as f64).sqrt()
    }
}

impl IntegralImage {
    /// Build both tables in one pass.
    pub fn new(img: &GrayImage) -> Self {
        let (w, h) = (img.width(), img.height());
        let stride = w + 1;
        let mut sum = vec![0.0; stride * (h + 1)];
        let mut sum_sq = vec![0.0; stride * (h + 1)];
        for r in 0..h {
            let (mut acc, mut acc_sq) = (0.0, 0.0);
            for (c, &x) in img.row(r).iter().enumerate() {
                let x = f64::from(x);
                acc += x;
                acc_sq += x * x;
                let i = (r + 1) * stride + c + 1;
                sum[i] = sum[i - stride] + acc;
                sum_sq[i] = sum_sq[i - stride] + acc_sq;
            }
        }
        Self { width: w, height: h, sum, sum_sq }
    }

    /// Width of the source image.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height of the source image.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Statistics of columns `x0..x1` and rows `y0..y1` (exclusive ends), clipped to the image.
    pub fn window(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> WindowStats {
        let (x1, y1) = (x1.min(self.width), y1.min(self.height));
        let (x0, y0) = (x0.min(x1), y0.min(y1));
        let s = self.width + 1;
        let rect = |t: &[f64]| t[y1 * s + x1] - t[y0 * s + x1] - t[y1 * s + x0] + t[y0 * s + x0];
        WindowStats { n: (x1 - x0) * (y1 - y0), sum: rect(&self.sum), sum_sq: rect(&self.sum_sq) }
    }

    /// Statistics of the window of half-size `half` centred on pixel (col, row), clipped to the image.
    pub fn centred(&self, col: usize, row: usize, half: usize) -> WindowStats {
        self.window(col.saturating_sub(half), row.saturating_sub(half), col + half + 1, row + half + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn window_sums_equal_brute_force_sums() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let img = GrayImage::from_fn(37, 23, |c, r| ((c * 31 + r * 17) % 13) as f32 - 6.0);
        let ii = IntegralImage::new(&img);
        for _ in 0..200 {
            let (x0, y0) = (rng.random_range(0..37), rng.random_range(0..23));
            let (x1, y1) = (rng.random_range(x0..=37), rng.random_range(y0..=23));
            let st = ii.window(x0, y0, x1, y1);
            let vals: Vec<f64> =
                (y0..y1).flat_map(|r| (x0..x1).map(move |c| (c, r))).map(|(c, r)| f64::from(img.get(c, r))).collect();
            assert_eq!(st.n, vals.len());
            assert!((st.sum - vals.iter().sum::<f64>()).abs() < 1e-9);
            assert!((st.sum_sq - vals.iter().map(|v| v * v).sum::<f64>()).abs() < 1e-9);
        }
        // Clipping at the border counts only the pixels inside.
        assert_eq!(ii.centred(0, 0, 2).n, 9);
    }
}
