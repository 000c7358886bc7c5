//! The upright and oriented M-LDB binary descriptor of AKAZE (Alcantarilla et al. 2013 §4.3): means of intensity and of
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

/// ⌊v⌋ clamped into 0..len, without a libm call: truncation differs from ⌊v⌋ only for negative
/// non-integers, which the clamp sends to 0 either way.
pub(crate) fn pixel(v: f64, len: isize) -> isize {
    (v as isize).clamp(0, len - 1)
}

/// An approximation of atan2(y, x) in (−π, π], error below 10⁻⁵ rad (an odd degree-11 polynomial for atan
/// on [0, 1], 2·10⁻⁶ rad, plus f32 rounding); orientation only uses it to put samples into windows 0.15 rad
/// apart.
fn fast_atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ax < ay { (ax, ay) } else { (ay, ax) };
    if hi == 0.0 {
        return 0.0;
    }
    let a = lo / hi;
    let s = a * a;
    let p = ((((-0.011_721_2 * s + 0.052_653_32) * s - 0.116_432_87) * s + 0.193_543_46) * s - 0.332_623_47) * s;
    let mut r = a * (p + 0.999_977_26);
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 { -r } else { r }
}

/// The 21×21 pattern samples of (L, Lx, Ly).
type Grid = [[[f32; 3]; SIDE]; SIDE];

/// Pixel index of each pattern offset −PATTERN..=PATTERN along one axis for an axis-aligned pattern:
/// ⌊centre + offset·scale⌋ clamped into 0..len.
fn axis(centre: f64, scale: f64, len: isize) -> [isize; SIDE] {
    std::array::from_fn(|k| pixel(centre + (k as i64 - PATTERN) as f64 * scale, len))
}

/// (L, Lx, Ly) at the 21×21 pattern samples, derivatives rotated into the keypoint's frame: sample (i, j)
/// sits at offset (j − 10, i − 10)·scale rotated by `angle`, read at the level pixel containing it
/// (clamped into the level). Upright, rows and columns of the pattern are rows and columns of the level.
fn sample_grid(lv: &Level, d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> Grid {
    let (w, h) = (lv.image.width() as isize, lv.image.height() as isize);
    let (l, lx, ly) = (lv.image.data(), d.lx.data(), d.ly.data());
    if angle == 0.0 {
        let (cols, rows) = (axis(x, scale, w), axis(y, scale, h));
        return std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let k = (rows[i] * w + cols[j]) as usize;
                [l[k], lx[k], ly[k]]
            })
        });
    }
    let (s, c) = angle.sin_cos();
    let (sf, cf) = (s as f32, c as f32);
    std::array::from_fn(|i| {
        let py = (i as i64 - PATTERN) as f64 * scale;
        std::array::from_fn(|j| {
            let px = (j as i64 - PATTERN) as f64 * scale;
            let (col, row) = (pixel(x + c * px - s * py, w), pixel(y + s * px + c * py, h));
            let k = (row * w + col) as usize;
            let (gx, gy) = (lx[k], ly[k]);
            [l[k], cf * gx + sf * gy, -sf * gx + cf * gy]
        })
    })
}

/// Sums of (L, Lx, Ly) over the cells of the `G`×`G` grid of ⌈2·PATTERN/G⌉-sample cells, row-major. All
/// cells have the same sample count, so sums compare as the means do.
fn cell_sums<const G: usize, const N: usize>(grid: &Grid) -> [[f32; 3]; N] {
    let step = (2 * PATTERN as usize).div_ceil(G);
    let mut out = [[0.0f32; 3]; N];
    for (i, line) in grid.iter().enumerate().take(G * step) {
        for (q, cell) in line[..G * step].chunks_exact(step).enumerate() {
            let acc = &mut out[(i / step) * G + q];
            for v in cell {
                acc[0] += v[0];
                acc[1] += v[1];
                acc[2] += v[2];
            }
        }
    }
    out
}

/// Set one bit per channel for every pair of cells (i < j): cell i's value above cell j's.
fn compare(cells: &[[f32; 3]], desc: &mut Descriptor, bit: &mut usize) {
    for i in 0..cells.len() {
        for j in i + 1..cells.len() {
            for (x, y) in cells[i].iter().zip(&cells[j]) {
                desc[*bit / 64] |= u64::from(x > y) << (*bit % 64);
                *bit += 1;
            }
        }
    }
}

/// The M-LDB descriptor of a point at level pixel (x, y) with scale `scale` (level pixels) and `angle`.
pub(crate) fn describe(lv: &Level, d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> Descriptor {
    let grid = sample_grid(lv, d, x, y, scale, angle);
    let mut desc = [0u64; 8];
    let mut bit = 0usize;
    compare(&cell_sums::<2, 4>(&grid), &mut desc, &mut bit);
    compare(&cell_sums::<3, 9>(&grid), &mut desc, &mut bit);
    compare(&cell_sums::<4, 16>(&grid), &mut desc, &mut bit);
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
        let mut k = ((t / 0.15) as isize + 1).clamp(0, m as isize) as usize;
        while k > 0 && starts[k - 1] > t {
            k -= 1;
        }
        while k < m && starts[k] <= t {
            k += 1;
        }
        k
    };
    let mut diff = [(0.0f64, 0.0f64); 64];
    let (w, h) = (d.lx.width() as isize, d.lx.height() as isize);
    let (lx, ly) = (d.lx.data(), d.ly.data());
    for &(i, j, weight) in DISC.iter() {
        let k = (pixel(y + j * scale, h) * w + pixel(x + i * scale, w)) as usize;
        let (gx, gy) = (f64::from(lx[k]) * weight, f64::from(ly[k]) * weight);
        let a = f64::from(fast_atan2(gy as f32, gx as f32)); // only decides window membership
        let theta = if a < 0.0 { a + TAU } else { a };
        // Windows k with θ − π/3 < start_k ≤ θ, and the same for θ + 2π (windows that wrap past 2π, which
        // only angles below last start + π/3 − 2π can reach).
        let wraps = theta + TAU - FRAC_PI_3 < starts[m - 1];
        let turns = [theta, theta + TAU];
        for &t in &turns[..if wraps { 2 } else { 1 }] {
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
    fn the_sliding_window_by_difference_array_equals_the_direct_sum() {
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
                    let (col, row) = ((x + i * scale).floor() as isize, (y + j * scale).floor() as isize);
                    let (gx, gy) =
                        (f64::from(d.lx.get_clamped(col, row)) * w, f64::from(d.ly.get_clamped(col, row)) * w);
                    // The same angle function as the fast form: this test is about the windows.
                    (f64::from(fast_atan2(gy as f32, gx as f32)), gx, gy)
                })
                .collect();
            let (fast, direct) = (orientation(&d, x, y, scale), orientation_direct(&samples));
            assert!((fast - direct).abs() < 1e-9, "seed {seed}: {fast} vs {direct}");
        }
    }

    #[test]
    fn fast_atan2_is_within_its_bound_all_round_the_circle() {
        let worst = (0..3600)
            .map(|k| {
                let a = f64::from(k) * std::f64::consts::TAU / 3600.0 - std::f64::consts::PI + 1e-4;
                let (y, x) = ((3.0 * a.sin()) as f32, (3.0 * a.cos()) as f32);
                (f64::from(fast_atan2(y, x)) - f64::from(y).atan2(f64::from(x))).abs()
            })
            .fold(0.0, f64::max);
        assert!(worst < 1e-5, "{worst}");
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    }

    #[test]
    fn pixel_is_the_clamped_floor() {
        for v in [-3.5, -3.0, -0.2, 0.0, 0.7, 2.0, 9.999, 10.0, 12.5] {
            assert_eq!(pixel(v, 10), (v.floor() as isize).clamp(0, 9), "{v}");
        }
    }
}
