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

/// Cell sums of (L, Lx, Ly) for the 2×2, 3×3 and 4×4 grids, cells in row-major order.
struct Cells {
    g2: [[f32; 3]; 4],
    g3: [[f32; 3]; 9],
    g4: [[f32; 3]; 16],
}

/// For each of the 21 sample offsets along one axis, its cell in the 2-, 3- and 4-cell grids (cells of
/// ⌈20/g⌉ = 10, 7 and 5 samples); `None` where the offset lies past a grid's last cell.
fn axis_cells(i: usize) -> [Option<usize>; 3] {
    [(i < 20).then_some(i / 10), Some(i / 7), (i < 20).then_some(i / 5)]
}

/// Sum (L, Lx, Ly) over every cell of the three grids in one pass over the 21×21 pattern samples: sample
/// (i, j) sits at offset (j − 10, i − 10)·scale rotated by `angle`, read at the level pixel containing it
/// (clamped into the level), with the derivatives rotated into the keypoint's frame. All cells of a grid
/// have the same sample count, so sums compare as the means do.
fn cell_sums(lv: &Level, d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> Cells {
    let (s, c) = angle.sin_cos();
    let (sf, cf) = (s as f32, c as f32);
    let (w, h) = (lv.image.width() as isize, lv.image.height() as isize);
    let (l, lx, ly) = (lv.image.data(), d.lx.data(), d.ly.data());
    let mut cells = Cells { g2: [[0.0; 3]; 4], g3: [[0.0; 3]; 9], g4: [[0.0; 3]; 16] };
    let add = |acc: &mut [f32; 3], v: [f32; 3]| acc.iter_mut().zip(v).for_each(|(a, b)| *a += b);
    for i in 0..SIDE {
        let py = (i as i64 - PATTERN) as f64 * scale;
        let rows = axis_cells(i);
        for j in 0..SIDE {
            let px = (j as i64 - PATTERN) as f64 * scale;
            let col = floor(x + c * px - s * py).clamp(0, w - 1);
            let row = floor(y + s * px + c * py).clamp(0, h - 1);
            let k = (row * w + col) as usize;
            let (gx, gy) = (lx[k], ly[k]);
            let v = [l[k], cf * gx + sf * gy, -sf * gx + cf * gy];
            let cols = axis_cells(j);
            if let (Some(r), Some(q)) = (rows[0], cols[0]) {
                add(&mut cells.g2[2 * r + q], v);
            }
            if let (Some(r), Some(q)) = (rows[1], cols[1]) {
                add(&mut cells.g3[3 * r + q], v);
            }
            if let (Some(r), Some(q)) = (rows[2], cols[2]) {
                add(&mut cells.g4[4 * r + q], v);
            }
        }
    }
    cells
}

/// Set one bit per channel for every pair of cells (i < j): cell i's value above cell j's.
fn compare(cells: &[[f32; 3]], desc: &mut Descriptor, bit: &mut usize) {
    for i in 0..cells.len() {
        for j in i + 1..cells.len() {
            for (x, y) in cells[i].iter().zip(&cells[j]) {
                if x > y {
                    desc[*bit / 64] |= 1 << (*bit % 64);
                }
                *bit += 1;
            }
        }
    }
}

/// The M-LDB descriptor of a point at level pixel (x, y) with scale `scale` (level pixels) and `angle`.
pub(crate) fn describe(lv: &Level, d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> Descriptor {
    let cells = cell_sums(lv, d, x, y, scale, angle);
    let mut desc = [0u64; 8];
    let mut bit = 0usize;
    compare(&cells.g2, &mut desc, &mut bit);
    compare(&cells.g3, &mut desc, &mut bit);
    compare(&cells.g4, &mut desc, &mut bit);
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

/// Start angles of the orientation windows: 0, 0.15, … < 2π, accumulated as the authors' loop does.
static STARTS: LazyLock<Vec<f64>> = LazyLock::new(|| {
    let mut out = Vec::new();
    let mut a = 0.0;
    while a < std::f64::consts::TAU {
        out.push(a);
        a += 0.15;
    }
    out
});

/// Dominant orientation: the sliding π/3 window (start angles 0, 0.15, … < 2π) with the largest summed
/// Gaussian-weighted gradient over a disc of radius 6·scale (SURF's scheme, as KAZE and AKAZE use it).
/// Each sample is added to the contiguous run of windows containing its angle through a difference array,
/// so the cost is linear in samples plus windows.
pub(crate) fn orientation(d: &Derivatives, x: f64, y: f64, scale: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_3, TAU};
    let starts = &*STARTS;
    let m = starts.len();
    // Number of window starts ≤ t: the estimate ⌊t/0.15⌋ + 1 corrected against the accumulated starts.
    let count = |t: f64| {
        let mut k = (floor(t / 0.15) + 1).clamp(0, m as isize) as usize;
        while k > 0 && starts[k - 1] > t {
            k -= 1;
        }
        while k < m && starts[k] <= t {
            k += 1;
        }
        k
    };
    let mut diff = [(0.0f64, 0.0f64); 64];
    for &(i, j, w) in DISC.iter() {
        let (col, row) = (floor(x + i * scale), floor(y + j * scale));
        let (gx, gy) = (f64::from(d.lx.get_clamped(col, row)) * w, f64::from(d.ly.get_clamped(col, row)) * w);
        let a = f64::from((gy as f32).atan2(gx as f32)); // only decides window membership
        let theta = if a < 0.0 { a + TAU } else { a };
        // Windows k with θ − π/3 < start_k ≤ θ, and the same for θ + 2π (windows that wrap past 2π).
        for t in [theta, theta + TAU] {
            let (lo, hi) = (count(t - FRAC_PI_3), count(t));
            if lo < hi {
                diff[lo] = (diff[lo].0 + gx, diff[lo].1 + gy);
                diff[hi] = (diff[hi].0 - gx, diff[hi].1 - gy);
            }
        }
    }
    let (mut best, mut sum) = ((0.0, 0.0), (0.0, 0.0));
    for &(dx, dy) in &diff[..m] {
        sum = (sum.0 + dx, sum.1 + dy);
        let norm = sum.0 * sum.0 + sum.1 * sum.1;
        if norm > best.0 {
            best = (norm, sum.1.atan2(sum.0));
        }
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
