//! Separable Gaussian blur of interleaved RGB rows: the optical point spread of a camera.

use rayon::prelude::*;

/// Normalised Gaussian taps for standard deviation `sigma` (radius 3σ).
fn kernel(sigma: f64) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as i64;
    let taps: Vec<f64> = (-r..=r).map(|i| (-(i as f64).powi(2) / (2.0 * sigma * sigma)).exp()).collect();
    let sum: f64 = taps.iter().sum();
    taps.iter().map(|t| (t / sum) as f32).collect()
}

/// Blur an interleaved RGB image of `w` × `h` pixels; borders clamp. `sigma` ≤ 0 returns a copy.
pub fn gaussian_rgb(src: &[f32], w: usize, h: usize, sigma: f64) -> Vec<f32> {
    if sigma <= 0.0 || w == 0 || h == 0 {
        return src.to_vec();
    }
    let k = kernel(sigma);
    let r = (k.len() / 2) as i64;
    let mut tmp = vec![0f32; src.len()];
    tmp.par_chunks_mut(w * 3).enumerate().for_each(|(y, out)| {
        for x in 0..w {
            for c in 0..3 {
                out[x * 3 + c] = k
                    .iter()
                    .enumerate()
                    .map(|(i, t)| {
                        let xx = (x as i64 + i as i64 - r).clamp(0, w as i64 - 1) as usize;
                        t * src[(y * w + xx) * 3 + c]
                    })
                    .sum();
            }
        }
    });
    let mut dst = vec![0f32; src.len()];
    dst.par_chunks_mut(w * 3).enumerate().for_each(|(y, out)| {
        for x in 0..w {
            for c in 0..3 {
                out[x * 3 + c] = k
                    .iter()
                    .enumerate()
                    .map(|(i, t)| {
                        let yy = (y as i64 + i as i64 - r).clamp(0, h as i64 - 1) as usize;
                        t * tmp[(yy * w + x) * 3 + c]
                    })
                    .sum();
            }
        }
    });
    dst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_keeps_the_mean_and_spreads_a_point_with_its_sigma() {
        let (w, h) = (41, 41);
        let mut img = vec![0f32; w * h * 3];
        img[(20 * w + 20) * 3] = 1000.0;
        let out = gaussian_rgb(&img, w, h, 1.5);
        let total: f32 = out.iter().sum();
        assert!((total - 1000.0).abs() < 0.01);
        // Second moment along x of the red channel equals σ².
        let var: f64 =
            (0..w * h).map(|i| f64::from(out[i * 3]) * ((i % w) as f64 - 20.0).powi(2)).sum::<f64>() / 1000.0;
        assert!((var - 2.25).abs() < 0.02, "{var}");
        assert_eq!(gaussian_rgb(&img, w, h, 0.0), img);
    }
}
