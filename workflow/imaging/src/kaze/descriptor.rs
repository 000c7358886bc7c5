//! The 64-float M-SURF descriptor of KAZE (Agrawal et al. 2008, as Alcantarilla et al. 2012 §4.3 uses it): 4×4
//! overlapping subregions of 9×9 samples at spacing `scale` over a 24·scale window. The 24×24 rotated
//! derivative samples are read once and shared by the overlapping subregions; both Gaussian weightings
//! depend only on sample indices (the scale cancels), so they are tables.

use std::sync::LazyLock;

use crate::akaze::descriptor::pixel;
use crate::akaze::detector::Derivatives;

/// A 64-float M-SURF descriptor (unit length).
pub type SurfDescriptor = [f32; 64];

/// Samples per side of the window: offsets −12..12 in units of the scale.
const SIDE: usize = 24;

/// Gaussian weight of sample (k, l) inside its 9×9 subregion, σ = 2.5 samples (Alcantarilla et al. 2012 §4.3).
static INNER: LazyLock<[[f32; 9]; 9]> = LazyLock::new(|| {
    let mut w = [[0.0f32; 9]; 9];
    for (k, row) in w.iter_mut().enumerate() {
        for (l, v) in row.iter_mut().enumerate() {
            let d2 = (k as f64 - 4.0).powi(2) + (l as f64 - 4.0).powi(2);
            *v = (-d2 / (2.0 * 2.5 * 2.5)).exp() as f32;
        }
    }
    w
});

/// Gaussian weight of subregion (cy, cx), σ = 1.5 subregions about the window centre.
fn outer(cy: usize, cx: usize) -> f32 {
    let d2 = (cx as f64 - 1.5).powi(2) + (cy as f64 - 1.5).powi(2);
    (-d2 / (2.0 * 1.5 * 1.5)).exp() as f32
}

/// The 24×24 samples of (u, v), the derivatives in the keypoint's frame.
type Grid = [[(f32, f32); SIDE]; SIDE];

/// The derivatives rotated into the keypoint's frame at the 24×24 samples (x + scale·(l − 12) rotated by
/// `angle`, read at the pixel containing the point, clamped into the image), as (u, v) pairs.
fn samples(d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> Grid {
    let (sn, cs) = angle.sin_cos();
    let (sf, cf) = (sn as f32, cs as f32);
    let (w, h) = (d.lx.width() as isize, d.lx.height() as isize);
    let (lx, ly) = (d.lx.data(), d.ly.data());
    std::array::from_fn(|k| {
        let py = (k as f64 - 12.0) * scale;
        std::array::from_fn(|l| {
            let px = (l as f64 - 12.0) * scale;
            let (col, row) = (pixel(x + cs * px - sn * py, w), pixel(y + sn * px + cs * py, h));
            let i = (row * w + col) as usize;
            let (gx, gy) = (lx[i], ly[i]);
            (cf * gx + sf * gy, -sf * gx + cf * gy)
        })
    })
}

/// The M-SURF descriptor of a point at (x, y) pixels with `scale` (pixels) and `angle`: per subregion
/// Σu, Σv, Σ|u|, Σ|v| Gaussian weighted, normalised to unit length (Alcantarilla et al. 2012 §4.3).
pub(crate) fn msurf(d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> SurfDescriptor {
    let grid = samples(d, x, y, scale, angle);
    let inner = &*INNER;
    let mut desc = [0.0f32; 64];
    for cy in 0..4 {
        for cx in 0..4 {
            let mut acc = [0.0f32; 4];
            for (k, wrow) in inner.iter().enumerate() {
                let line = &grid[5 * cy + k][5 * cx..5 * cx + 9];
                for (&(u, v), &w) in line.iter().zip(wrow) {
                    let (u, v) = (u * w, v * w);
                    acc[0] += u;
                    acc[1] += v;
                    acc[2] += u.abs();
                    acc[3] += v.abs();
                }
            }
            let w2 = outer(cy, cx);
            let base = 4 * (cy * 4 + cx);
            for (n, a) in acc.iter().enumerate() {
                desc[base + n] = a * w2;
            }
        }
    }
    let norm = desc.iter().map(|v| v * v).sum::<f32>().sqrt();
    if norm > 0.0 {
        desc.iter_mut().for_each(|v| *v /= norm);
    }
    desc
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::GrayImage;

    #[test]
    fn a_uniform_gradient_gives_the_known_descriptor_in_any_orientation() {
        // A gradient of unit length along the keypoint's own x axis: u = 1 and v = 0 at every sample, so
        // subregion (cy, cx) holds (S, 0, S, 0)·outer(cy, cx) with S the sum of the inner weights.
        let want: Vec<f32> = (0..16).flat_map(|i| [outer(i / 4, i % 4), 0.0, outer(i / 4, i % 4), 0.0]).collect();
        let norm = want.iter().map(|v| v * v).sum::<f32>().sqrt();
        for angle in [0.0f64, 0.7, -2.0, 3.0] {
            let (gx, gy) = (angle.cos() as f32, angle.sin() as f32);
            let d = Derivatives {
                lx: GrayImage::filled(80, 80, gx),
                ly: GrayImage::filled(80, 80, gy),
                det: GrayImage::filled(80, 80, 0.0),
                step: 1,
            };
            let desc = msurf(&d, 40.3, 39.8, 2.0, angle);
            let worst = desc.iter().zip(&want).map(|(a, b)| (a - b / norm).abs()).fold(0.0f32, f32::max);
            assert!(worst < 1e-5, "angle {angle}: {worst}");
        }
    }
}
