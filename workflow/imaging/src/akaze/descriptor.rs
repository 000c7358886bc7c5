//! The upright and oriented M-LDB binary descriptor of AKAZE (BMVC 2013 §4.3): means of intensity and of
//! both derivatives over 2×2, 3×3 and 4×4 grids, compared pairwise (6 + 36 + 120 pairs × 3 channels = 486 bits).
//! The three grids cover the same 21×21 samples, so each sample is read once; and the SURF orientation.

use std::sync::LazyLock;

use super::detector::Derivatives;
use super::scale_space::Level;

/// A 486-bit M-LDB descriptor stored in 512 bits.
pub type Descriptor = [u64; 8];

/// Half-size of the sampled pattern in units of the keypoint scale (the authors' code: 10).
const PATTERN: i64 = 10;

/// Samples per side: offsets −PATTERN..=PATTERN (the 3×3 grid's cells of 7 reach +10).
const SIDE: usize = 2 * PATTERN as usize + 1;

/// ⌊v⌋ as an integer without a libm call (v is a pixel coordinate, far inside the isize range).
fn floor(v: f64) -> isize {
    let i = v as isize;
    if (i as f64) > v { i - 1 } else { i }
}

/// (L, Lx, Ly) at the 21×21 pattern samples, derivatives rotated into the keypoint's frame; sample (i, j)
/// sits at offset (j − 10, i − 10)·scale rotated by `angle`, read at the level pixel containing it.
fn samples(lv: &Level, d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> Box<[[[f32; 3]; SIDE]; SIDE]> {
    let (s, c) = angle.sin_cos();
    let (sf, cf) = (s as f32, c as f32);
    let mut out = Box::new([[[0.0f32; 3]; SIDE]; SIDE]);
    for (i, line) in out.iter_mut().enumerate() {
        let py = (i as i64 - PATTERN) as f64 * scale;
        for (j, v) in line.iter_mut().enumerate() {
            let px = (j as i64 - PATTERN) as f64 * scale;
            let (col, row) = (floor(x + c * px - s * py), floor(y + s * px + c * py));
            let (lx, ly) = (d.lx.get_clamped(col, row), d.ly.get_clamped(col, row));
            *v = [lv.image.get_clamped(col, row), cf * lx + sf * ly, -sf * lx + cf * ly];
        }
    }
    out
}

/// Sums of (L, Lx, Ly) over every cell of a `g`×`g` grid of ⌈2·PATTERN/g⌉-sample cells (all cells of a
/// grid have the same sample count, so sums compare as the means do).
fn cell_sums(grid: &[[[f32; 3]; SIDE]; SIDE], g: usize) -> Vec<[f32; 3]> {
    let step = (2 * PATTERN as usize).div_ceil(g);
    let mut out = Vec::with_capacity(g * g);
    for gy in 0..g {
        for gx in 0..g {
            let mut acc = [0.0f32; 3];
            for line in &grid[gy * step..(gy + 1) * step] {
                for v in &line[gx * step..(gx + 1) * step] {
                    acc[0] += v[0];
                    acc[1] += v[1];
                    acc[2] += v[2];
                }
            }
            out.push(acc);
        }
    }
    out
}

/// The M-LDB descriptor of a point at level pixel (x, y) with scale `scale` (level pixels) and `angle`.
pub(crate) fn describe(lv: &Level, d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> Descriptor {
    let grid = samples(lv, d, x, y, scale, angle);
    let mut desc = [0u64; 8];
    let mut bit = 0usize;
    for g in [2, 3, 4] {
        let cells = cell_sums(&grid, g);
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

/// The 109 orientation samples: offsets (i, j) with i² + j² < 36 and their Gaussian weight, σ = 2.5.
static DISC: LazyLock<Vec<(f64, f64, f64)>> = LazyLock::new(|| {
    let mut out = Vec::new();
    for j in -6i64..=6 {
        for i in -6i64..=6 {
            if i * i + j * j < 36 {
                out.push((i as f64, j as f64, (-((i * i + j * j) as f64) / (2.0 * 2.5 * 2.5)).exp()));
            }
        }
    }
    out
});

/// Dominant orientation: the sliding π/3 window (start angles 0, 0.15, … < 2π) with the largest summed
/// Gaussian-weighted gradient over a disc of radius 6·scale (SURF's scheme, as KAZE and AKAZE use it).
/// The samples are sorted by angle once, so each window's sum is a difference of prefix sums.
pub(crate) fn orientation(d: &Derivatives, x: f64, y: f64, scale: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_3, TAU};
    let mut samples: Vec<(f64, f64, f64)> = DISC
        .iter()
        .map(|&(i, j, w)| {
            let (col, row) = (floor(x + i * scale), floor(y + j * scale));
            let (gx, gy) = (f64::from(d.lx.get_clamped(col, row)) * w, f64::from(d.ly.get_clamped(col, row)) * w);
            let a = gy.atan2(gx);
            (if a < 0.0 { a + TAU } else { a }, gx, gy)
        })
        .collect();
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Angles twice round the circle, with prefix sums, so a window [a, a + π/3) is one contiguous range.
    let n = samples.len();
    let angles: Vec<f64> = (0..2 * n).map(|k| samples[k % n].0 + if k < n { 0.0 } else { TAU }).collect();
    let mut prefix = vec![(0.0f64, 0.0f64); 2 * n + 1];
    for k in 0..2 * n {
        prefix[k + 1] = (prefix[k].0 + samples[k % n].1, prefix[k].1 + samples[k % n].2);
    }
    let mut best = (0.0, 0.0);
    let mut a = 0.0;
    while a < TAU {
        let lo = angles.partition_point(|&t| t < a);
        let hi = angles.partition_point(|&t| t < a + FRAC_PI_3);
        let (sx, sy) = (prefix[hi].0 - prefix[lo].0, prefix[hi].1 - prefix[lo].1);
        if sx * sx + sy * sy > best.0 {
            best = (sx * sx + sy * sy, sy.atan2(sx));
        }
        a += 0.15;
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::GrayImage;

    /// The direct form: every sample tested against every window.
    fn orientation_direct(samples: &[(f64, f64, f64)]) -> f64 {
        let mut best = (0.0, 0.0);
        let mut a = 0.0;
        while a < std::f64::consts::TAU {
            let (mut sx, mut sy) = (0.0, 0.0);
            for &(ang, gx, gy) in samples {
                if (ang - a).rem_euclid(std::f64::consts::TAU) < std::f64::consts::FRAC_PI_3 {
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

    #[test]
    fn the_sliding_window_by_prefix_sums_equals_the_direct_sum() {
        for seed in 0..20u64 {
            let field = |c: usize, r: usize| {
                let t = (seed as f32 + 1.0) * 0.37;
                ((c as f32 * 0.21 + t).sin() * 3.0 + (r as f32 * 0.13 - t).cos() * 2.0) * (1.0 + 0.1 * seed as f32)
            };
            let (lx, ly) = (GrayImage::from_fn(64, 64, field), GrayImage::from_fn(64, 64, |c, r| field(r, c + 3)));
            let d = Derivatives { lx, ly, det: GrayImage::filled(64, 64, 0.0), step: 1 };
            let (x, y, scale) = (30.5, 33.2, 2.0);
            let samples: Vec<(f64, f64, f64)> = DISC
                .iter()
                .map(|&(i, j, w)| {
                    let (col, row) = (floor(x + i * scale), floor(y + j * scale));
                    let (gx, gy) =
                        (f64::from(d.lx.get_clamped(col, row)) * w, f64::from(d.ly.get_clamped(col, row)) * w);
                    (gy.atan2(gx), gx, gy)
                })
                .collect();
            let (fast, direct) = (orientation(&d, x, y, scale), orientation_direct(&samples));
            assert!((fast - direct).abs() < 1e-9, "seed {seed}: {fast} vs {direct}");
        }
    }

    #[test]
    fn floor_matches_the_library_floor() {
        for v in [-3.5, -3.0, -0.2, 0.0, 0.7, 2.0, 1_023.999_999] {
            assert_eq!(floor(v), v.floor() as isize, "{v}");
        }
    }
}
