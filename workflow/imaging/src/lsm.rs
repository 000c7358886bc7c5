//! Least-squares matching: affine geometry plus radiometric gain and offset, to subpixel precision
//! (Jende et al. 2017 §3.4, §3.8; Gruen's adaptive least-squares correlation).

use nalgebra::{SMatrix, SVector};

use crate::error::ImagingError;
use crate::image::GrayImage;

/// Six affine parameters mapping template-local coordinates (x, y), relative to the template centre, to
/// search-image pixels: `u = a[0] + a[1]·x + a[2]·y`, `v = a[3] + a[4]·x + a[5]·y`.
pub type Affine = [f64; 6];

/// The affine of a pure translation to the search-image point (u, v).
pub fn translation(u: f64, v: f64) -> Affine {
    [u, 1.0, 0.0, v, 0.0, 1.0]
}

/// Iteration limits of least-squares matching.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LsmConfig {
    /// Stop after this many Gauss–Newton steps.
    pub max_iterations: usize,
    /// Stop when the centre moves by less than this, pixels.
    pub tolerance: f64,
}

impl Default for LsmConfig {
    fn default() -> Self {
        Self { max_iterations: 40, tolerance: 1e-4 }
    }
}

/// A converged least-squares match.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LsmMatch {
    /// The affine from template-local coordinates to search pixels; `(a[0], a[3])` is the matched centre.
    pub affine: Affine,
    /// Radiometric gain r1 in T = r0 + r1·S.
    pub gain: f64,
    /// Radiometric offset r0.
    pub offset: f64,
    /// Standard deviation of unit weight: RMS grey-value residual.
    pub sigma0: f64,
    /// A-posteriori standard deviation of the matched centre (u, v), pixels.
    pub std: [f64; 2],
    /// Gauss–Newton steps taken.
    pub iterations: usize,
}

type Normal = SMatrix<f64, 8, 8>;
type Rhs = SVector<f64, 8>;

/// Refine `initial` so that `template` ≈ r0 + r1 · search(affine(x, y)) in the least-squares sense.
/// Fails when the template leaves the search image, has no texture, or the iteration does not settle.
pub fn least_squares_match(
    template: &GrayImage,
    search: &GrayImage,
    initial: Affine,
    config: &LsmConfig,
) -> Result<LsmMatch, ImagingError> {
    let mean = template.mean();
    if template.data().iter().all(|&x| (f64::from(x) - mean).abs() < 1e-6) {
        return Err(ImagingError::Degenerate {
            what: "least-squares matching",
            reason: "the template has no contrast",
        });
    }
    let mut a = initial;
    let (mut r0, mut r1) = (0.0, 1.0);
    let mut last_step = f64::INFINITY;
    for iteration in 1..=config.max_iterations {
        let (n, rhs, _, _) = normal_equations(template, search, &a, r0, r1)?;
        let delta = n.cholesky().ok_or(ImagingError::Degenerate {
            what: "least-squares matching",
            reason: "the normal matrix is singular (template without texture in some direction)",
        })?;
        let d = delta.solve(&rhs);
        a.iter_mut().zip(d.iter()).for_each(|(p, dp)| *p += dp);
        r0 += d[6];
        r1 += d[7];
        last_step = d[0].hypot(d[3]);
        if last_step < config.tolerance {
            return finish(template, search, a, r0, r1, iteration);
        }
    }
    Err(ImagingError::NoConvergence { what: "least-squares matching", iterations: config.max_iterations, last_step })
}

/// The normal equations JᵀJ, Jᵀe of the linearised model at the current parameters, with eᵀe and n.
fn normal_equations(
    t: &GrayImage,
    s: &GrayImage,
    a: &Affine,
    r0: f64,
    r1: f64,
) -> Result<(Normal, Rhs, f64, usize), ImagingError> {
    let (mut upper, mut rhs, mut ee) = ([[0.0; 8]; 8], [0.0; 8], 0.0);
    let (cx, cy) = (t.width() as f64 / 2.0, t.height() as f64 / 2.0);
    let interior = Interior::of(s, a, t.width(), t.height());
    for row in 0..t.height() {
        for col in 0..t.width() {
            let (x, y) = (col as f64 + 0.5 - cx, row as f64 + 0.5 - cy);
            let (u, v) = (a[0] + a[1] * x + a[2] * y, a[3] + a[4] * x + a[5] * y);
            let samples = match interior {
                Some(ref inside) => Some(inside.cross(u, v)),
                None => cross_checked(s, u, v),
            };
            let Some([g, gl, gr, gt, gb]) = samples else {
                return Err(s.out_of_bounds("least-squares matching", a[0], a[3], t.width() / 2));
            };
            let (gu, gv) = (0.5 * (gr - gl), 0.5 * (gb - gt));
            // Jende et al. 2017 §3.4 (LSM): ∂/∂(a, r) of r0 + r1·S(u, v) with u, v affine in (x, y)
            let j = [r1 * gu, r1 * gu * x, r1 * gu * y, r1 * gv, r1 * gv * x, r1 * gv * y, 1.0, g];
            let e = f64::from(t.get(col, row)) - r0 - r1 * g;
            for (p, line) in upper.iter_mut().enumerate() {
                for q in p..8 {
                    line[q] += j[p] * j[q];
                }
                rhs[p] += j[p] * e;
            }
            ee += e * e;
        }
    }
    let n = Normal::from_fn(|p, q| if p <= q { upper[p][q] } else { upper[q][p] });
    Ok((n, Rhs::from(rhs), ee, t.width() * t.height()))
}

/// The bilinear samples of `s` at (u, v) and one pixel left, right, up and down, as f64; `None` when one
/// of them lies outside the image ([`GrayImage::sample`]).
fn cross_checked(s: &GrayImage, u: f64, v: f64) -> Option<[f64; 5]> {
    let sample = |du: f64, dv: f64| s.sample(u + du, v + dv).map(f64::from);
    Some([sample(0.0, 0.0)?, sample(-1.0, 0.0)?, sample(1.0, 0.0)?, sample(0.0, -1.0)?, sample(0.0, 1.0)?])
}

/// A search image known to hold the 4 × 4 pixels around every point a template's affine reaches, so the
/// five samples of [`cross_checked`] need neither bounds checks nor edge clamping. They share their
/// bilinear weights; the values are those of [`GrayImage::sample`] to the bit.
struct Interior<'a> {
    data: &'a [f32],
    width: usize,
}

impl<'a> Interior<'a> {
    /// `Some` when every point of the `tw` × `th` template under `a` lies at least 2 px inside `s` (the
    /// affine image of the template's rectangle is the parallelogram of its corners; 1.5 px are needed,
    /// the rest absorbs rounding).
    fn of(s: &'a GrayImage, a: &Affine, tw: usize, th: usize) -> Option<Self> {
        let (hx, hy) = (tw as f64 / 2.0, th as f64 / 2.0);
        let (w, h) = (s.width() as f64, s.height() as f64);
        let inside = [(-hx, -hy), (hx, -hy), (-hx, hy), (hx, hy)].iter().all(|&(x, y)| {
            let (u, v) = (a[0] + a[1] * x + a[2] * y, a[3] + a[4] * x + a[5] * y);
            u >= 2.0 && v >= 2.0 && u < w - 2.0 && v < h - 2.0
        });
        inside.then(|| Self { data: s.data(), width: s.width() })
    }

    /// The five samples of [`cross_checked`] at (u, v), which [`Interior::of`] placed inside.
    fn cross(&self, u: f64, v: f64) -> [f64; 5] {
        let (x, y) = (u - 0.5, v - 0.5);
        // Inside means x, y ≥ 1.5: truncation is the floor (without a library call on baseline x86-64).
        let (c0, r0) = (x as usize, y as usize);
        let (fx, fy) = ((x - c0 as f64) as f32, (y - r0 as f64) as f32);
        let base = r0 * self.width + c0;
        let w = self.width as isize;
        let at = |dc: isize, dr: isize| self.data[(base as isize + dr * w + dc) as usize];
        let bilinear = |dc: isize, dr: isize| {
            let top = at(dc, dr) * (1.0 - fx) + at(dc + 1, dr) * fx;
            let bottom = at(dc, dr + 1) * (1.0 - fx) + at(dc + 1, dr + 1) * fx;
            f64::from(top * (1.0 - fy) + bottom * fy)
        };
        [bilinear(0, 0), bilinear(-1, 0), bilinear(1, 0), bilinear(0, -1), bilinear(0, 1)]
    }
}

/// Precision of the converged match from the final normal equations.
fn finish(
    t: &GrayImage,
    s: &GrayImage,
    a: Affine,
    r0: f64,
    r1: f64,
    iterations: usize,
) -> Result<LsmMatch, ImagingError> {
    let (n, _, ee, count) = normal_equations(t, s, &a, r0, r1)?;
    let sigma0 = (ee / (count.saturating_sub(8).max(1)) as f64).sqrt();
    let inv = n.try_inverse().ok_or(ImagingError::Degenerate {
        what: "least-squares matching",
        reason: "the normal matrix became singular at convergence",
    })?;
    let std = [sigma0 * inv[(0, 0)].sqrt(), sigma0 * inv[(3, 3)].sqrt()];
    Ok(LsmMatch { affine: a, gain: r1, offset: r0, sigma0, std, iterations })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A smooth random texture: a sum of plane waves with wavelengths above 18 pixels.
    fn texture(seed: u64) -> impl Fn(f64, f64) -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let waves: Vec<[f64; 4]> = (0..16)
            .map(|_| {
                let (angle, k) = (rng.random_range(0.0..std::f64::consts::PI), rng.random_range(0.08..0.35));
                [k * angle.cos(), k * angle.sin(), rng.random_range(0.0..6.3), rng.random_range(4.0..12.0)]
            })
            .collect();
        move |u, v| 100.0 + waves.iter().map(|w| w[3] * (w[0] * u + w[1] * v + w[2]).sin()).sum::<f64>()
    }

    /// Match a template of A around (60.5, 60.5) into B, where A's point p is B's point M·(p − c) + c + d.
    fn check(seed: u64, d: [f64; 2], m: [[f64; 2]; 2], gain: f64, offset: f64) {
        let f = texture(seed);
        let c = [60.5, 60.5];
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        // B(q) = gain·A(M⁻¹(q − c − d) + c) + offset, evaluated analytically at B's pixel centres.
        let b = GrayImage::from_fn(121, 121, |col, row| {
            let (qx, qy) = (col as f64 + 0.5 - c[0] - d[0], row as f64 + 0.5 - c[1] - d[1]);
            let (px, py) = ((m[1][1] * qx - m[0][1] * qy) / det + c[0], (-m[1][0] * qx + m[0][0] * qy) / det + c[1]);
            (gain * f(px, py) + offset) as f32
        });
        let a = GrayImage::from_fn(121, 121, |col, row| f(col as f64 + 0.5, row as f64 + 0.5) as f32);
        let template = a.patch(60, 60, 12).unwrap();
        // Start from the nearest whole pixel, as an NCC search would deliver it.
        let start = translation((c[0] + d[0]).round() + 0.5, (c[1] + d[1]).round() + 0.5);
        let r = least_squares_match(&template, &b, start, &LsmConfig::default()).unwrap();
        let (eu, ev) = (r.affine[0] - c[0] - d[0], r.affine[3] - c[1] - d[1]);
        assert!(eu.hypot(ev) < 0.02, "seed {seed}: centre off by ({eu:.4}, {ev:.4}); {r:?}");
        assert!((r.affine[1] - m[0][0]).abs() < 0.01 && (r.affine[2] - m[0][1]).abs() < 0.01, "{r:?}");
        assert!((r.affine[4] - m[1][0]).abs() < 0.01 && (r.affine[5] - m[1][1]).abs() < 0.01, "{r:?}");
        // T = r0 + r1·S inverts the radiometric change.
        assert!((r.gain - 1.0 / gain).abs() < 0.01 * (1.0 / gain), "gain {}", r.gain);
        assert!(r.std[0] < 0.02 && r.std[1] < 0.02, "{r:?}");
    }

    /// The unchecked interior path gives the normal equations of the bounds-checked samples to the bit,
    /// for a window well inside, one touching the 2 px border (checked path) and a sheared affine.
    #[test]
    fn the_interior_path_gives_the_checked_normal_equations_to_the_bit() {
        let f = texture(7);
        let s = GrayImage::from_fn(64, 48, |c, r| f(c as f64 + 0.5, r as f64 + 0.5) as f32);
        let t = s.patch(30, 20, 6).unwrap();
        for a in
            [[30.3, 1.0, 0.0, 20.9, 0.0, 1.0], [12.6, 1.04, 0.07, 23.2, -0.05, 0.97], [8.4, 1.0, 0.0, 40.0, 0.0, 1.0]]
        {
            let (n, rhs, ee, count) = normal_equations(&t, &s, &a, 3.0, 1.1).unwrap();
            let (mut n_ref, mut rhs_ref, mut ee_ref) = (Normal::zeros(), Rhs::zeros(), 0.0);
            for row in 0..t.height() {
                for col in 0..t.width() {
                    let (x, y) = (col as f64 + 0.5 - 6.5, row as f64 + 0.5 - 6.5);
                    let (u, v) = (a[0] + a[1] * x + a[2] * y, a[3] + a[4] * x + a[5] * y);
                    let [g, gl, gr, gt, gb] = cross_checked(&s, u, v).unwrap();
                    let (gu, gv) = (0.5 * (gr - gl), 0.5 * (gb - gt));
                    let j =
                        Rhs::from([1.1 * gu, 1.1 * gu * x, 1.1 * gu * y, 1.1 * gv, 1.1 * gv * x, 1.1 * gv * y, 1.0, g]);
                    let e = f64::from(t.get(col, row)) - 3.0 - 1.1 * g;
                    n_ref += j * j.transpose();
                    rhs_ref += j * e;
                    ee_ref += e * e;
                }
            }
            assert_eq!((n, rhs, ee, count), (n_ref, rhs_ref, ee_ref, 169), "affine {a:?}");
        }
        assert!(Interior::of(&s, &[8.4, 1.0, 0.0, 40.0, 0.0, 1.0], 13, 13).is_none());
    }

    #[test]
    fn converges_to_a_known_subpixel_shift_with_gain_and_offset() {
        for (seed, d) in [(1, [0.37, -0.61]), (2, [2.43, 1.18]), (3, [-1.71, 0.49])] {
            check(seed, d, [[1.0, 0.0], [0.0, 1.0]], 0.6, 35.0);
        }
    }

    #[test]
    fn recovers_a_small_rotation_and_scale_of_the_patch() {
        let (s, c) = (0.04f64.sin() * 1.03, 0.04f64.cos() * 1.03);
        check(4, [0.8, -0.3], [[c, -s], [s, c]], 1.4, -20.0);
    }

    #[test]
    fn a_flat_template_or_a_window_off_the_image_is_an_error() {
        let b = GrayImage::from_fn(40, 40, |c, r| (c * r) as f32);
        let flat = GrayImage::filled(9, 9, 5.0);
        assert!(matches!(
            least_squares_match(&flat, &b, translation(20.0, 20.0), &LsmConfig::default()),
            Err(ImagingError::Degenerate { .. })
        ));
        let t = b.patch(10, 10, 4).unwrap();
        assert!(matches!(
            least_squares_match(&t, &b, translation(2.0, 20.0), &LsmConfig::default()),
            Err(ImagingError::OutOfBounds { .. })
        ));
    }
}
