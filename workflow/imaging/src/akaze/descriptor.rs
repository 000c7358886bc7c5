//! The upright and oriented M-LDB binary descriptor of AKAZE (BMVC 2013 §4.3): means of intensity and of
//! both derivatives over 2×2, 3×3 and 4×4 grids, compared pairwise (6 + 36 + 120 pairs × 3 channels = 486 bits).

use super::detector::Derivatives;
use super::scale_space::Level;

/// A 486-bit M-LDB descriptor stored in 512 bits.
pub type Descriptor = [u64; 8];

/// Half-size of the sampled pattern in units of the keypoint scale (the authors' code: 10).
const PATTERN: i64 = 10;

/// Means of (L, Lx, Ly) over every cell of a `g`×`g` grid covering the pattern, sampled at the level's
/// pixels and rotated by `angle` (0 for the upright variant).
fn cell_means(lv: &Level, d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64, g: i64) -> Vec<[f32; 3]> {
    let (s, c) = angle.sin_cos();
    let step = (2 * PATTERN + g - 1) / g; // cells of ⌈2·PATTERN/g⌉ samples
    let mut out = Vec::with_capacity((g * g) as usize);
    for gy in 0..g {
        for gx in 0..g {
            let mut acc = [0.0f32; 3];
            let mut n = 0.0f32;
            for j in 0..step {
                for i in 0..step {
                    let (px, py) = ((-PATTERN + gx * step + i) as f64, (-PATTERN + gy * step + j) as f64);
                    let (rx, ry) = (c * px - s * py, s * px + c * py);
                    let (col, row) = ((x + rx * scale).floor() as isize, (y + ry * scale).floor() as isize);
                    let (lx, ly) = (d.lx.get_clamped(col, row), d.ly.get_clamped(col, row));
                    let (sf, cf) = (s as f32, c as f32);
                    // Derivatives in the keypoint's frame.
                    acc[0] += lv.image.get_clamped(col, row);
                    acc[1] += cf * lx + sf * ly;
                    acc[2] += -sf * lx + cf * ly;
                    n += 1.0;
                }
            }
            out.push(acc.map(|a| a / n));
        }
    }
    out
}

/// The M-LDB descriptor of a point at level pixel (x, y) with scale `scale` (level pixels) and `angle`.
pub(crate) fn describe(lv: &Level, d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> Descriptor {
    let mut desc = [0u64; 8];
    let mut bit = 0usize;
    for g in [2, 3, 4] {
        let cells = cell_means(lv, d, x, y, scale, angle, g);
        for i in 0..cells.len() {
            for j in i + 1..cells.len() {
                for (x, y) in cells[i].iter().zip(&cells[j]) {
                    if x > y {
                        desc[bit / 64] |= 1 << (bit % 64);
                    }
                    bit += 1;
                }
            }
        }
    }
    desc
}

/// Dominant orientation: the sliding π/3 window with the largest summed Gaussian-weighted gradient over
/// a disc of radius 6·scale (SURF's scheme, as KAZE and AKAZE use it).
pub(crate) fn orientation(d: &Derivatives, x: f64, y: f64, scale: f64) -> f64 {
    let mut samples = Vec::new();
    for j in -6i64..=6 {
        for i in -6i64..=6 {
            if i * i + j * j >= 36 {
                continue;
            }
            let w = (-((i * i + j * j) as f64) / (2.0 * 2.5 * 2.5)).exp();
            let (col, row) = ((x + i as f64 * scale).floor() as isize, (y + j as f64 * scale).floor() as isize);
            let (gx, gy) = (f64::from(d.lx.get_clamped(col, row)) * w, f64::from(d.ly.get_clamped(col, row)) * w);
            samples.push((gy.atan2(gx), gx, gy));
        }
    }
    let mut best = (0.0, 0.0);
    let mut a = 0.0;
    while a < std::f64::consts::TAU {
        let (mut sx, mut sy) = (0.0, 0.0);
        for &(ang, gx, gy) in &samples {
            // ang ∈ (−π, π], a ∈ [0, 2π): two conditional wraps replace a (slow) floating-point modulo.
            let mut diff = ang - a;
            if diff < 0.0 {
                diff += std::f64::consts::TAU;
            }
            if diff < 0.0 {
                diff += std::f64::consts::TAU;
            }
            if diff < std::f64::consts::FRAC_PI_3 {
                sx += gx;
                sy += gy;
            }
        }
        if sx * sx + sy * sy > best.0 {
            best = (sx * sx + sy * sy, sy.atan2(sx));
        }
        a += 0.15;
    }
    best.1
}
