//! Corner operators: Förstner with subpixel location (Jende et al. 2017 §3.4) and Harris (Cazzaniga et al. 2007 §4.3).

use nalgebra::{Matrix2, Vector2};

use crate::error::{ImagingError, require};
use crate::filter::gaussian_kernel;
use crate::image::GrayImage;
use crate::integral::IntegralImage;

/// A detected corner at continuous pixel coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    /// Column, continuous pixels.
    pub u: f64,
    /// Row, continuous pixels.
    pub v: f64,
    /// Operator response: Förstner's weight w = det N / tr N, or Harris' R.
    pub strength: f64,
    /// Förstner's roundness q = 4 det N / tr² N ∈ [0, 1] (1 for Harris, which does not compute it).
    pub roundness: f64,
}

/// Image gradients by central differences at the pixel centres (edges replicated).
pub(crate) struct Gradients {
    pub gx: GrayImage,
    pub gy: GrayImage,
}

impl Gradients {
    pub(crate) fn new(img: &GrayImage) -> Self {
        let g = |dc: isize, dr: isize| {
            GrayImage::from_fn(img.width(), img.height(), |c, r| {
                let (c, r) = (c as isize, r as isize);
                0.5 * (img.get_clamped(c + dc, r + dr) - img.get_clamped(c - dc, r - dr))
            })
        };
        Self { gx: g(1, 0), gy: g(0, 1) }
    }

    /// Gradients by derivative-of-Gaussian filters of standard deviation `sigma` (isotropic, so gradient
    /// directions along a slanted edge stay perpendicular to it); central differences when `sigma` is 0.
    pub(crate) fn gaussian(img: &GrayImage, sigma: f64) -> Self {
        if sigma < 1e-3 {
            return Self::new(img);
        }
        let smooth = gaussian_kernel(sigma);
        let radius = (smooth.len() / 2) as i64;
        let raw: Vec<f64> =
            (-radius..=radius).map(|i| -(i as f64) * f64::from(smooth[(i + radius) as usize])).collect();
        // Scale so that a unit ramp has unit derivative: Σ k(i)·(−i) = 1 for correlation with x + i.
        let norm: f64 = raw.iter().zip(-radius..=radius).map(|(k, i)| -k * i as f64).sum();
        let deriv: Vec<f32> = raw.iter().map(|k| (-k / norm) as f32).collect();
        let gx = crate::filter::convolve_columns(&crate::filter::convolve_rows(img, &deriv), &smooth);
        let gy = crate::filter::convolve_columns(&crate::filter::convolve_rows(img, &smooth), &deriv);
        Self { gx, gy }
    }

    /// The structure products gx², gx·gy, gy².
    fn products(&self) -> [GrayImage; 3] {
        let (gx, gy) = (self.gx.data(), self.gy.data());
        let (w, h) = (self.gx.width(), self.gx.height());
        let f = |op: fn(f32, f32) -> f32| GrayImage::from_fn(w, h, |c, r| op(gx[r * w + c], gy[r * w + c]));
        [f(|x, _| x * x), f(|x, y| x * y), f(|_, y| y * y)]
    }
}

/// Parameters of the Förstner operator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Foerstner {
    /// σ of the derivative-of-Gaussian gradient filter, pixels (0: central differences).
    pub sigma: f64,
    /// Half-size of the square window of the structure tensor.
    pub half_window: usize,
    /// Minimum roundness q (Förstner & Gülch suggest 0.5–0.75).
    pub min_roundness: f64,
    /// Minimum weight as a multiple of the mean weight over the image (0.5–1.5 in the original).
    pub min_weight_factor: f64,
    /// Non-maximum suppression radius, pixels.
    pub nms_radius: usize,
}

impl Default for Foerstner {
    fn default() -> Self {
        Self { sigma: 0.7, half_window: 7, min_roundness: 0.5, min_weight_factor: 1.5, nms_radius: 5 }
    }
}

impl Foerstner {
    /// Detect corners: local maxima of w with q and w above the thresholds, each located to subpixel
    /// precision by [`Foerstner::locate`].
    pub fn detect(&self, img: &GrayImage) -> Result<Vec<Corner>, ImagingError> {
        self.check()?;
        let grads = Gradients::gaussian(img, self.sigma);
        let sums = grads.products().map(|p| IntegralImage::new(&p));
        let (w, h) = (img.width(), img.height());
        let interest = |c: usize, r: usize| {
            let [a, b, d] = [&sums[0], &sums[1], &sums[2]].map(|s| s.centred(c, r, self.half_window).sum);
            let (det, tr) = (a * d - b * b, a + d);
            // Jende et al. 2017 §3.4 (Förstner & Gülch 1987): w = det N / tr N, q = 4 det N / tr² N
            if tr > 1e-12 { (det / tr, 4.0 * det / (tr * tr)) } else { (0.0, 0.0) }
        };
        let wq: Vec<(f64, f64)> = (0..w * h).map(|i| interest(i % w, i / w)).collect();
        let mean_w = wq.iter().map(|p| p.0).sum::<f64>() / wq.len() as f64;
        let weight = GrayImage::from_fn(w, h, |c, r| {
            let (wv, q) = wq[r * w + c];
            if q >= self.min_roundness && wv > self.min_weight_factor * mean_w { wv as f32 } else { 0.0 }
        });
        let margin = self.half_window + 1;
        Ok(local_maxima(&weight, self.nms_radius, margin)
            .into_iter()
            .filter_map(|(c, r)| locate_with(&grads, c, r, self.half_window))
            .collect())
    }

    /// The subpixel corner in the window of half-size `half_window` around pixel (col, row): the point
    /// closest to all lines through the pixel centres perpendicular to their gradients.
    pub fn locate(&self, img: &GrayImage, col: usize, row: usize) -> Result<Corner, ImagingError> {
        self.check()?;
        let h = self.half_window + 1;
        if col < h || row < h || col + h >= img.width() || row + h >= img.height() {
            return Err(img.out_of_bounds("förstner window", col as f64 + 0.5, row as f64 + 0.5, h));
        }
        let grads = Gradients::gaussian(img, self.sigma);
        locate_with(&grads, col, row, self.half_window)
            .ok_or(ImagingError::Degenerate { what: "förstner window", reason: "no corner (singular normal matrix)" })
    }

    fn check(&self) -> Result<(), ImagingError> {
        require(self.half_window > 0, "half_window", self.half_window as f64, "must be positive")?;
        require((0.0..=1.0).contains(&self.min_roundness), "min_roundness", self.min_roundness, "must be in [0, 1]")
    }
}

/// Förstner's point estimator: the point closest, in the least-squares sense, to the lines through every
/// pixel centre p perpendicular to its gradient g: N x = Σ g gᵀ p (Jende et al. 2017 §3.4, Förstner & Gülch 1987),
/// solved a second time without the pixels around the first estimate.
fn locate_with(g: &Gradients, col: usize, row: usize, half: usize) -> Option<Corner> {
    let first = solve_window(g, col, row, half, None)?;
    let refined = solve_window(g, col, row, half, Some((first.u, first.v, TIP_RADIUS))).unwrap_or(first);
    Some(Corner { strength: first.strength, roundness: first.roundness, ..refined })
}

/// Gradients this close to the corner (pixels) mix both edges and pull the estimate into the corner; the
/// second pass of [`locate_with`] leaves them out.
const TIP_RADIUS: f64 = 1.5;

fn solve_window(g: &Gradients, col: usize, row: usize, half: usize, skip: Option<(f64, f64, f64)>) -> Option<Corner> {
    let (mut n, mut b) = (Matrix2::zeros(), Vector2::zeros());
    for r in row - half..=row + half {
        for c in col - half..=col + half {
            if skip.is_some_and(|(u, v, t)| (c as f64 + 0.5 - u).hypot(r as f64 + 0.5 - v) < t) {
                continue;
            }
            let gv = Vector2::new(f64::from(g.gx.get(c, r)), f64::from(g.gy.get(c, r)));
            let ggt = gv * gv.transpose();
            n += ggt;
            b += ggt * Vector2::new(c as f64 + 0.5, r as f64 + 0.5);
        }
    }
    let (det, tr) = (n.determinant(), n.trace());
    if tr <= 1e-12 || det <= 1e-9 * tr * tr {
        return None;
    }
    let x = n.try_inverse()? * b;
    let inside = (x.x - (col as f64 + 0.5)).abs() <= half as f64 && (x.y - (row as f64 + 0.5)).abs() <= half as f64;
    inside.then(|| Corner { u: x.x, v: x.y, strength: det / tr, roundness: 4.0 * det / (tr * tr) })
}

/// Parameters of the Harris operator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Harris {
    /// σ of the Gaussian window of the structure tensor, pixels.
    pub sigma: f64,
    /// The k of R = det M − k tr² M (0.04–0.06).
    pub k: f64,
    /// Keep maxima with R above this fraction of the largest R.
    pub relative_threshold: f64,
    /// Non-maximum suppression radius, pixels.
    pub nms_radius: usize,
}

impl Default for Harris {
    fn default() -> Self {
        Self { sigma: 1.5, k: 0.04, relative_threshold: 0.01, nms_radius: 3 }
    }
}

impl Harris {
    /// Detect corners as local maxima of R, refined by a parabola through R in u and in v.
    pub fn detect(&self, img: &GrayImage) -> Result<Vec<Corner>, ImagingError> {
        require(self.sigma > 0.0, "sigma", self.sigma, "must be positive")?;
        let grads = Gradients::new(img);
        let kernel = gaussian_kernel(self.sigma);
        let [a, b, d] = grads
            .products()
            .map(|p| crate::filter::convolve_columns(&crate::filter::convolve_rows(&p, &kernel), &kernel));
        let response = GrayImage::from_fn(img.width(), img.height(), |c, r| {
            let (a, b, d) = (a.get(c, r), b.get(c, r), d.get(c, r));
            (a * d - b * b) - self.k as f32 * (a + d) * (a + d) // Cazzaniga et al. 2007 §4.3 (Harris & Stephens 1988)
        });
        let max = response.data().iter().fold(0.0f32, |m, &x| m.max(x));
        let thresholded = response.map(|x| if x > self.relative_threshold as f32 * max { x } else { 0.0 });
        let margin = (3.0 * self.sigma).ceil() as usize;
        Ok(local_maxima(&thresholded, self.nms_radius, margin)
            .into_iter()
            .map(|(c, r)| {
                let at = |dc: isize, dr: isize| f64::from(response.get_clamped(c as isize + dc, r as isize + dr));
                let du = vertex(at(-1, 0), at(0, 0), at(1, 0));
                let dv = vertex(at(0, -1), at(0, 0), at(0, 1));
                Corner { u: c as f64 + 0.5 + du, v: r as f64 + 0.5 + dv, strength: at(0, 0), roundness: 1.0 }
            })
            .collect())
    }
}

/// Vertex offset of the parabola through (−1, a), (0, b), (1, c), clamped to half a pixel.
fn vertex(a: f64, b: f64, c: f64) -> f64 {
    let d = a - 2.0 * b + c;
    if d < 0.0 { (0.5 * (a - c) / d).clamp(-0.5, 0.5) } else { 0.0 }
}

/// Pixels with a positive value that is the strict maximum (ties broken by index) of their neighbourhood.
fn local_maxima(img: &GrayImage, radius: usize, margin: usize) -> Vec<(usize, usize)> {
    let (w, h) = (img.width(), img.height());
    let mut out = Vec::new();
    for r in margin..h.saturating_sub(margin) {
        for c in margin..w.saturating_sub(margin) {
            let x = img.get(c, r);
            if x <= 0.0 {
                continue;
            }
            let beaten = (r.saturating_sub(radius)..=(r + radius).min(h - 1)).any(|rr| {
                (c.saturating_sub(radius)..=(c + radius).min(w - 1)).any(|cc| {
                    let y = img.get(cc, rr);
                    y > x || (y == x && (rr, cc) < (r, c))
                })
            });
            if !beaten {
                out.push((c, r));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests;
