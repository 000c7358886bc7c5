//! The benchmark scene, defined so that `benches/opencv_akaze.py` renders the identical 8-bit images:
//! Gaussian blobs with parameters from SplitMix64, stamped within ±4σ, rounded with floor(x + 0.5).

use nalgebra::Matrix3;
use plumbline_imaging::GrayImage;

/// SplitMix64, the same sequence as the Python script's.
#[derive(Debug)]
pub struct SplitMix(pub u64);

impl SplitMix {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn uniform(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Blob parameters [x, y, σ, amplitude] for a `size`² image.
pub fn blobs(seed: u64, n: usize, size: f64) -> Vec<[f64; 4]> {
    let mut rng = SplitMix(seed);
    (0..n)
        .map(|_| {
            let (x, y, s, a) =
                (rng.uniform(0.0, size), rng.uniform(0.0, size), rng.uniform(1.5, 8.0), rng.uniform(40.0, 90.0));
            let sign = if rng.next_u64() & 1 == 1 { 1.0 } else { -1.0 };
            [x, y, s, a * sign]
        })
        .collect()
}

/// The similarity of the pair: 0.2 rad, scale 0.8 about the centre, shift (10, −6).
pub fn truth(size: f64) -> Matrix3<f64> {
    let (s, c) = (0.8 * 0.2f64.sin(), 0.8 * 0.2f64.cos());
    let m = size / 2.0;
    Matrix3::new(c, -s, m - c * m + s * m + 10.0, s, c, m - s * m - c * m - 6.0, 0.0, 0.0, 1.0)
}

/// Render blobs on `background`, 8-bit quantised; `t` moves centres (and scales σ by `scale`).
pub fn render(size: usize, blobs: &[[f64; 4]], t: &Matrix3<f64>, scale: f64, gain: f64, background: f64) -> GrayImage {
    let mut acc = vec![background; size * size];
    for b in blobs {
        let (x, y) = (t[(0, 0)] * b[0] + t[(0, 1)] * b[1] + t[(0, 2)], t[(1, 0)] * b[0] + t[(1, 1)] * b[1] + t[(1, 2)]);
        let (s, a) = (b[2] * scale, b[3] * gain);
        let (c0, c1) = (((x - 4.0 * s).floor().max(0.0)) as usize, ((x + 4.0 * s).ceil().min(size as f64)) as usize);
        let (r0, r1) = (((y - 4.0 * s).floor().max(0.0)) as usize, ((y + 4.0 * s).ceil().min(size as f64)) as usize);
        for r in r0..r1 {
            for c in c0..c1 {
                let d2 = (c as f64 + 0.5 - x).powi(2) + (r as f64 + 0.5 - y).powi(2);
                acc[r * size + c] += a * (-d2 / (2.0 * s * s)).exp();
            }
        }
    }
    let data = acc.iter().map(|v| (v.clamp(0.0, 255.0) + 0.5).floor() as f32).collect();
    GrayImage::new(size, size, data).unwrap_or_else(|_| GrayImage::filled(size, size, 0.0))
}
