//! Row-slice stencils shared by KAZE and AKAZE: Scharr-type derivatives at a spacing s, the Perona–Malik
//! conductance and the scale-normalised Hessian determinant, written as loops over equal-length row slices
//! so that the compiler drops the bounds checks and vectorises the interior of every row, and fused so that
//! no intermediate image is allocated.

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

/// Rows r − s, r, r + s of `img`, clamped into the image.
pub(crate) fn neighbours(img: &GrayImage, r: usize, s: usize) -> (&[f32], &[f32], &[f32]) {
    let h = img.height();
    (img.row(r.saturating_sub(s)), img.row(r), img.row((r + s).min(h - 1)))
}

/// A 3×3 neighbourhood at spacing s: `n[dy][dx]` is the sample at (c + (dx − 1)s, r + (dy − 1)s).
pub(crate) type Neighbourhood = [[f32; 3]; 3];

/// `out[c] = f(neighbourhood of (c, r) at spacing s)` along row r, indices clamped into the image. The
/// interior columns read nine shifted row slices of equal length, a loop the compiler vectorises.
pub(crate) fn stencil_row(img: &GrayImage, r: usize, s: usize, out: &mut [f32], f: impl Fn(&Neighbourhood) -> f32) {
    let w = img.width();
    let (up, mid, down) = neighbours(img, r, s);
    let lines = [up, mid, down];
    let at = |c: usize| -> Neighbourhood { lines.map(|l| [l[c.saturating_sub(s)], l[c], l[(c + s).min(w - 1)]]) };
    if w <= 2 * s {
        (0..w).for_each(|c| out[c] = f(&at(c)));
        return;
    }
    let n = w - 2 * s;
    let [a, b, c] = lines.map(|l| (&l[..n], &l[s..s + n], &l[2 * s..2 * s + n]));
    for (i, o) in out[s..s + n].iter_mut().enumerate() {
        *o = f(&[[a.0[i], a.1[i], a.2[i]], [b.0[i], b.1[i], b.2[i]], [c.0[i], c.1[i], c.2[i]]]);
    }
    for c in (0..s).chain(w - s..w) {
        out[c] = f(&at(c));
    }
}

/// The Scharr-type smoothing (3, 10, 3)/16 across the derivative direction.
fn smooth(a: f32, b: f32, c: f32) -> f32 {
    (3.0 * (a + c) + 10.0 * b) * (1.0 / 16.0)
}

/// Scharr-type ∂/∂x of a neighbourhood: central difference across 2s (`inv` = 1/2s), smoothed across.
fn scharr_x(n: &Neighbourhood, inv: f32) -> f32 {
    smooth(n[0][2] - n[0][0], n[1][2] - n[1][0], n[2][2] - n[2][0]) * inv
}

/// Scharr-type ∂/∂y of a neighbourhood.
fn scharr_y(n: &Neighbourhood, inv: f32) -> f32 {
    smooth(n[2][0] - n[0][0], n[2][1] - n[0][1], n[2][2] - n[0][2]) * inv
}

/// Scharr-type first derivatives (Lx, Ly) at spacing `s` (Alcantarilla et al. 2013 §4.2; the authors'
/// kernels dilated to spacing s): central difference across 2s, smoothed with weights 3/16, 10/16, 3/16
/// across; borders replicated.
pub(crate) fn scharr_pair(img: &GrayImage, s: usize) -> (GrayImage, GrayImage) {
    let s = s.max(1);
    let inv = 1.0 / (2.0 * s as f32);
    let (w, h) = (img.width(), img.height());
    rayon::join(
        || rows(w, h, |r, out| stencil_row(img, r, s, out, |n| scharr_x(n, inv))),
        || rows(w, h, |r, out| stencil_row(img, r, s, out, |n| scharr_y(n, inv))),
    )
}

/// Perona–Malik g2 conductance 1 / (1 + |∇L_σ|²/k²) of an already smoothed image, with the gradient by
/// the 3×3 Scharr-type operator (Alcantarilla et al. 2013 eq. (2)), in one pass.
pub(crate) fn conductance_of(smoothed: &GrayImage, k: f32) -> GrayImage {
    let inv_k2 = 1.0 / (k * k);
    rows(smoothed.width(), smoothed.height(), |r, out| {
        stencil_row(smoothed, r, 1, out, |n| {
            let (lx, ly) = (scharr_x(n, 0.5), scharr_y(n, 0.5));
            1.0 / (1.0 + (lx * lx + ly * ly) * inv_k2) // Alcantarilla et al. 2013 eq. (2), g2
        });
    })
}

/// The scale-normalised Hessian determinant s⁴ (Lxx Lyy − Lxy²) from first derivatives `lx`, `ly` (not yet
/// normalised) at spacing `s` (Alcantarilla et al. 2013 eq. (6); Alcantarilla et al. 2012 §4.1): Lxx and
/// Lxy from `lx`, Lyy from `ly`, row by row through two scratch rows.
pub(crate) fn hessian_det(lx: &GrayImage, ly: &GrayImage, s: usize) -> GrayImage {
    let s = s.max(1);
    let inv = 1.0 / (2.0 * s as f32);
    let s4 = (s * s * s * s) as f32;
    let w = lx.width();
    let mut out = GrayImage::filled(w, lx.height(), 0.0);
    if w == 0 {
        return out;
    }
    out.data_mut().par_chunks_mut(w).enumerate().for_each_init(
        || vec![0.0f32; 2 * w],
        |scratch, (r, o)| {
            let (lxx, lxy) = scratch.split_at_mut(w);
            stencil_row(lx, r, s, lxx, |n| scharr_x(n, inv));
            stencil_row(lx, r, s, lxy, |n| scharr_y(n, inv));
            stencil_row(ly, r, s, o, |n| scharr_y(n, inv));
            for ((o, &xx), &xy) in o.iter_mut().zip(lxx.iter()).zip(lxy.iter()) {
                *o = (xx * *o - xy * xy) * s4; // Alcantarilla et al. 2013 eq. (6)
            }
        },
    );
    out
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
