//! Row-slice stencils shared by KAZE and AKAZE: Scharr-type derivatives at a spacing s, the Perona–Malik
//! conductance and the scale-normalised Hessian determinant, written as loops over equal-length row slices
//! so that the compiler drops the bounds checks and vectorises the interior of every row.

use rayon::prelude::*;

use crate::image::GrayImage;

/// Run `f(row_index, output_row)` over all rows in parallel.
pub(crate) fn rows(w: usize, h: usize, f: impl Fn(usize, &mut [f32]) + Sync) -> GrayImage {
    let mut out = GrayImage::filled(w, h, 0.0);
    if w > 0 {
        out.data_mut().par_chunks_mut(w).enumerate().for_each(|(r, line)| f(r, line));
    }
    out
}

/// `out[c] = f(src[c − s], src[c], src[c + s])` along one row, indices clamped into the row.
pub(crate) fn along_row(src: &[f32], out: &mut [f32], s: usize, f: impl Fn(f32, f32, f32) -> f32) {
    let w = src.len().min(out.len());
    let clamped = |c: usize| f(src[c.saturating_sub(s)], src[c], src[(c + s).min(w - 1)]);
    if w <= 2 * s {
        (0..w).for_each(|c| out[c] = clamped(c));
        return;
    }
    let n = w - 2 * s;
    let (left, mid, right, o) = (&src[..n], &src[s..s + n], &src[2 * s..2 * s + n], &mut out[s..s + n]);
    for i in 0..n {
        o[i] = f(left[i], mid[i], right[i]);
    }
    for c in (0..s).chain(w - s..w) {
        out[c] = clamped(c);
    }
}

/// `out[c] = f(up[c], mid[c], down[c])` over three rows of equal length.
pub(crate) fn across_rows(up: &[f32], mid: &[f32], down: &[f32], out: &mut [f32], f: impl Fn(f32, f32, f32) -> f32) {
    let n = out.len();
    let (up, mid, down) = (&up[..n], &mid[..n], &down[..n]);
    for i in 0..n {
        out[i] = f(up[i], mid[i], down[i]);
    }
}

/// Rows r − s, r, r + s of `img`, clamped into the image.
pub(crate) fn neighbours(img: &GrayImage, r: usize, s: usize) -> (&[f32], &[f32], &[f32]) {
    let h = img.height();
    (img.row(r.saturating_sub(s)), img.row(r), img.row((r + s).min(h - 1)))
}

/// Apply `f(left, centre, right)` at spacing `s` along every row.
pub(crate) fn horizontal(img: &GrayImage, s: usize, f: impl Fn(f32, f32, f32) -> f32 + Sync) -> GrayImage {
    rows(img.width(), img.height(), |r, out| along_row(img.row(r), out, s, &f))
}

/// Apply `f(up, centre, down)` at spacing `s` down every column.
pub(crate) fn vertical(img: &GrayImage, s: usize, f: impl Fn(f32, f32, f32) -> f32 + Sync) -> GrayImage {
    rows(img.width(), img.height(), |r, out| {
        let (up, mid, down) = neighbours(img, r, s);
        across_rows(up, mid, down, out, &f);
    })
}

/// The Scharr-type smoothing (3, 10, 3)/16 across the derivative direction.
fn smooth(a: f32, b: f32, c: f32) -> f32 {
    (3.0 * (a + c) + 10.0 * b) * (1.0 / 16.0)
}

/// Scharr-type first derivatives (Lx, Ly) at spacing `s` (BMVC 2013 §4.2; the authors' kernels dilated to
/// spacing s): central difference across 2s, smoothed with weights 3/16, 10/16, 3/16 across; borders
/// replicated.
pub(crate) fn scharr_pair(img: &GrayImage, s: usize) -> (GrayImage, GrayImage) {
    let s = s.max(1);
    let inv = 1.0 / (2.0 * s as f32);
    let (dh, sh) = rayon::join(|| horizontal(img, s, |a, _, c| (c - a) * inv), || horizontal(img, s, smooth));
    rayon::join(|| vertical(&dh, s, smooth), || vertical(&sh, s, |a, _, c| (c - a) * inv))
}

/// Perona–Malik g2 conductance 1 / (1 + |∇L_σ|²/k²) of an already smoothed image, with the gradient by
/// the 3×3 Scharr-type operator (BMVC 2013 eq. (2)); the vertical pass is fused with the conductance.
pub(crate) fn conductance_of(smoothed: &GrayImage, k: f32) -> GrayImage {
    let (dh, sh) = rayon::join(|| horizontal(smoothed, 1, |a, _, c| (c - a) * 0.5), || horizontal(smoothed, 1, smooth));
    let inv_k2 = 1.0 / (k * k);
    rows(smoothed.width(), smoothed.height(), |r, out| {
        let n = out.len();
        let (du, dm, dd) = neighbours(&dh, r, 1);
        let (su, _, sd) = neighbours(&sh, r, 1);
        let (du, dm, dd, su, sd) = (&du[..n], &dm[..n], &dd[..n], &su[..n], &sd[..n]);
        for i in 0..n {
            let lx = smooth(du[i], dm[i], dd[i]);
            let ly = (sd[i] - su[i]) * 0.5;
            out[i] = 1.0 / (1.0 + (lx * lx + ly * ly) * inv_k2); // BMVC 2013 eq. (2), g2
        }
    })
}

/// The scale-normalised Hessian determinant s⁴ (Lxx Lyy − Lxy²) from first derivatives `lx`, `ly` (not yet
/// normalised) at spacing `s` (BMVC 2013 eq. (6); ECCV 2012 §4.1). Lxx and Lxy from `lx`, Lyy from `ly`,
/// the vertical pass fused with the determinant.
pub(crate) fn hessian_det(lx: &GrayImage, ly: &GrayImage, s: usize) -> GrayImage {
    let s = s.max(1);
    let inv = 1.0 / (2.0 * s as f32);
    let s4 = (s * s * s * s) as f32;
    let dxx = horizontal(lx, s, |a, _, c| (c - a) * inv);
    let (sx, sy) = rayon::join(|| horizontal(lx, s, smooth), || horizontal(ly, s, smooth));
    rows(lx.width(), lx.height(), |r, out| {
        let n = out.len();
        let (xu, xm, xd) = neighbours(&dxx, r, s);
        let (au, _, ad) = neighbours(&sx, r, s);
        let (bu, _, bd) = neighbours(&sy, r, s);
        let (xu, xm, xd, au, ad, bu, bd) = (&xu[..n], &xm[..n], &xd[..n], &au[..n], &ad[..n], &bu[..n], &bd[..n]);
        for i in 0..n {
            let lxx = smooth(xu[i], xm[i], xd[i]);
            let lxy = (ad[i] - au[i]) * inv;
            let lyy = (bd[i] - bu[i]) * inv;
            out[i] = (lxx * lyy - lxy * lxy) * s4; // BMVC 2013 eq. (6)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The slow, obvious Scharr-type derivative at spacing s with clamped indices.
    fn reference(img: &GrayImage, s: isize, dx: bool) -> GrayImage {
        let at = |c: isize, r: isize| img.get_clamped(c, r);
        GrayImage::from_fn(img.width(), img.height(), |c, r| {
            let (c, r) = (c as isize, r as isize);
            let w = [3.0, 10.0, 3.0];
            (-1..=1isize)
                .map(|k| {
                    let d = if dx {
                        at(c + s, r + k * s) - at(c - s, r + k * s)
                    } else {
                        at(c + k * s, r + s) - at(c + k * s, r - s)
                    };
                    w[(k + 1) as usize] * d
                })
                .sum::<f32>()
                / (32.0 * s as f32)
        })
    }

    fn texture(w: usize, h: usize) -> GrayImage {
        GrayImage::from_fn(w, h, |c, r| (c as f32 * 0.37).sin() * (r as f32 * 0.23).cos() + 0.01 * (c * r) as f32)
    }

    #[test]
    fn scharr_pair_equals_the_direct_stencil_including_borders_and_narrow_images() {
        for (w, h, s) in [(23, 17, 1), (23, 17, 3), (5, 40, 4), (40, 3, 2)] {
            let img = texture(w, h);
            let (lx, ly) = scharr_pair(&img, s);
            for (got, want) in [(&lx, reference(&img, s as isize, true)), (&ly, reference(&img, s as isize, false))] {
                let worst = got.data().iter().zip(want.data()).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
                assert!(worst < 1e-5, "{w}×{h} s={s}: {worst}");
            }
        }
    }

    #[test]
    fn the_hessian_determinant_of_a_quadratic_is_known() {
        // L = a x² + b y² + c x y: Lxx = 2a, Lyy = 2b, Lxy = c exactly (central differences are exact on
        // quadratics), so det = s⁴ (4ab − c²) away from the borders.
        let (a, b, c) = (0.003f32, -0.002f32, 0.001f32);
        let img = GrayImage::from_fn(40, 30, |x, y| {
            let (x, y) = (x as f32 - 20.0, y as f32 - 15.0);
            a * x * x + b * y * y + c * x * y
        });
        for s in [1usize, 2, 3] {
            let (lx, ly) = scharr_pair(&img, s);
            let det = hessian_det(&lx, &ly, s);
            let want = (s.pow(4) as f32) * (4.0 * a * b - c * c);
            let got = det.get(20, 15);
            assert!((got - want).abs() < 1e-3 * want.abs(), "s={s}: {got} vs {want}");
        }
    }

    #[test]
    fn conductance_is_one_on_flat_ground_and_small_across_a_strong_edge() {
        let img = GrayImage::from_fn(20, 10, |c, _| if c < 10 { 0.0 } else { 1.0 });
        let g = conductance_of(&img, 0.05);
        assert!((g.get(3, 5) - 1.0).abs() < 1e-6 && g.get(10, 5) < 0.01, "{} {}", g.get(3, 5), g.get(10, 5));
        let (lx, _) = scharr_pair(&img, 1);
        let want = 1.0 / (1.0 + (lx.get(9, 5) / 0.05).powi(2));
        assert!((g.get(9, 5) - want).abs() < 1e-6);
    }
}
