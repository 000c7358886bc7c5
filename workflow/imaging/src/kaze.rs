//! KAZE features (Alcantarilla, Bartoli, Davison: KAZE features, ECCV 2012), as paper 000 §3.3 uses them:
//! a nonlinear scale space at full resolution evolved by additive operator splitting (AOS), the Hessian
//! detector shared with AKAZE, and the 64-float M-SURF descriptor, upright or oriented.

use rayon::prelude::*;

use crate::akaze::Keypoint;
use crate::akaze::descriptor::orientation;
use crate::akaze::detector::{Derivatives, candidates, derivatives, suppress};
use crate::akaze::scale_space::{Level, conductance, contrast_factor, rows};
use crate::error::{ImagingError, require};
use crate::filter::gaussian_blur;
use crate::image::GrayImage;

/// A 64-float M-SURF descriptor (unit length).
pub type SurfDescriptor = [f32; 64];

/// KAZE settings (defaults: the authors').
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KazeConfig {
    /// Octaves of the scale space (paper 000 §3.3 uses two for ortho-images).
    pub octaves: u32,
    /// Levels per octave.
    pub sublevels: u32,
    /// Scale of the first level, input pixels.
    pub sigma0: f64,
    /// Minimum Hessian response (grey values scaled to [0, 1] by `grey_scale`).
    pub threshold: f32,
    /// Percentile of the gradient histogram that sets the diffusion contrast k.
    pub contrast_percentile: f64,
    /// Skip orientation.
    pub upright: bool,
    /// Grey value that maps to 1.
    pub grey_scale: f32,
}

impl Default for KazeConfig {
    fn default() -> Self {
        Self {
            octaves: 4,
            sublevels: 4,
            sigma0: 1.6,
            threshold: 0.001,
            contrast_percentile: 0.7,
            upright: false,
            grey_scale: 255.0,
        }
    }
}

/// KAZE keypoints and their descriptors, index-aligned.
#[derive(Clone, Debug, Default)]
pub struct KazeFeatures {
    /// The keypoints.
    pub keypoints: Vec<Keypoint>,
    /// One M-SURF descriptor per keypoint.
    pub descriptors: Vec<SurfDescriptor>,
}

/// Solve the tridiagonal systems (I − 2τ A) u = f along every row, A the 1-D diffusion operator with
/// half-point conductances (g_i + g_{i+1})/2 (ECCV 2012 eq. (8), Thomas algorithm).
fn aos_rows(l: &GrayImage, g: &GrayImage, tau: f32) -> GrayImage {
    let w = l.width();
    rows(w, l.height(), |r, out| {
        let (f, c) = (l.row(r), g.row(r));
        let link = |i: usize| tau * (c[i] + c[i + 1]); // 2τ · (g_i + g_{i+1}) / 2
        let mut upper = vec![0.0f32; w];
        for i in 0..w {
            let left = if i > 0 { link(i - 1) } else { 0.0 };
            let right = if i + 1 < w { link(i) } else { 0.0 };
            let diag = 1.0 + left + right - if i > 0 { left * upper[i - 1] } else { 0.0 };
            let rhs = f[i] + if i > 0 { left * out[i - 1] } else { 0.0 };
            upper[i] = right / diag;
            out[i] = rhs / diag;
        }
        for i in (0..w.saturating_sub(1)).rev() {
            out[i] += upper[i] * out[i + 1];
        }
    })
}

/// Transpose an image (so columns can be solved as rows).
fn transpose(img: &GrayImage) -> GrayImage {
    GrayImage::from_fn(img.height(), img.width(), |c, r| img.get(r, c))
}

/// One AOS step of size τ: L' = ½ [(I − 2τA_x)⁻¹ + (I − 2τA_y)⁻¹] L (ECCV 2012 eq. (8)).
fn aos_step(l: &GrayImage, g: &GrayImage, tau: f32) -> GrayImage {
    let ux = aos_rows(l, g, tau);
    let uy = transpose(&aos_rows(&transpose(l), &transpose(g), tau));
    GrayImage::from_fn(l.width(), l.height(), |c, r| 0.5 * (ux.get(c, r) + uy.get(c, r)))
}

/// The full-resolution nonlinear scale space, σ_i = σ0 · 2^(o + s/S), one AOS step per level.
fn scale_space(img: &GrayImage, config: &KazeConfig) -> Vec<Level> {
    let base = gaussian_blur(img, config.sigma0).unwrap_or_else(|_| img.clone());
    let k = contrast_factor(&base, config.contrast_percentile);
    let mut levels = vec![Level { image: base, octave: 0, sigma: config.sigma0 }];
    for i in 1..(config.octaves * config.sublevels) {
        let prev = &levels[levels.len() - 1];
        let sigma = config.sigma0 * 2f64.powf(f64::from(i) / f64::from(config.sublevels));
        let tau = 0.5 * (sigma * sigma - prev.sigma * prev.sigma);
        let image = aos_step(&prev.image, &conductance(&prev.image, k), tau as f32);
        levels.push(Level { image, octave: 0, sigma });
    }
    levels
}

/// Detect and describe KAZE features.
pub fn kaze(img: &GrayImage, config: &KazeConfig) -> Result<KazeFeatures, ImagingError> {
    require(config.octaves >= 1 && config.sublevels >= 1, "octaves/sublevels", 0.0, "must be at least 1")?;
    require(config.sigma0 > 0.0, "sigma0", config.sigma0, "must be positive")?;
    require(config.grey_scale > 0.0, "grey_scale", f64::from(config.grey_scale), "must be positive")?;
    let levels = scale_space(&img.map(|x| x / config.grey_scale), config);
    // KAZE's derivative scale is the level scale itself (factor 1).
    let ders = derivatives(&levels, 1.0);
    let kept = suppress(candidates(&levels, &ders, config.threshold));
    let described: Vec<(Keypoint, SurfDescriptor)> = kept
        .par_iter()
        .map(|c| {
            let (lv, d) = (&levels[c.level], &ders[c.level]);
            let scale = lv.sigma.round().max(1.0);
            let angle = if config.upright { 0.0 } else { orientation(d, c.u, c.v, scale) };
            let kp = Keypoint { u: c.u, v: c.v, sigma: lv.sigma, angle, response: c.response, octave: 0 };
            (kp, msurf(d, c.u, c.v, scale, angle))
        })
        .collect();
    let (keypoints, descriptors) = described.into_iter().unzip();
    Ok(KazeFeatures { keypoints, descriptors })
}

/// M-SURF (Agrawal et al. 2008, as KAZE uses it, ECCV 2012 §4.3): 4×4 overlapping subregions of 9×9
/// samples at spacing `scale` over a 24·scale window, Gaussian weighted (σ = 2.5 scale inside, 1.5 across
/// subregions), each giving Σdx, Σdy, Σ|dx|, Σ|dy|; normalised to unit length.
fn msurf(d: &Derivatives, x: f64, y: f64, scale: f64, angle: f64) -> SurfDescriptor {
    let (sn, cs) = angle.sin_cos();
    let mut desc = [0.0f32; 64];
    let gauss = |dx: f64, dy: f64, s: f64| (-(dx * dx + dy * dy) / (2.0 * s * s)).exp();
    for (cy, i) in [-12i64, -7, -2, 3].into_iter().enumerate() {
        for (cx, j) in [-12i64, -7, -2, 3].into_iter().enumerate() {
            let (centre_i, centre_j) = ((i + 4) as f64, (j + 4) as f64);
            let mut acc = [0.0f64; 4];
            for k in i..i + 9 {
                for l in j..j + 9 {
                    let (px, py) = (l as f64 * scale, k as f64 * scale);
                    let (rx, ry) = (x + cs * px - sn * py, y + sn * px + cs * py);
                    let (col, row) = (rx.floor() as isize, ry.floor() as isize);
                    let (gx, gy) = (f64::from(d.lx.get_clamped(col, row)), f64::from(d.ly.get_clamped(col, row)));
                    let w = gauss((l as f64 - centre_j) * scale, (k as f64 - centre_i) * scale, 2.5 * scale);
                    let (u, v) = ((cs * gx + sn * gy) * w, (-sn * gx + cs * gy) * w);
                    acc[0] += u;
                    acc[1] += v;
                    acc[2] += u.abs();
                    acc[3] += v.abs();
                }
            }
            let w2 = gauss(cx as f64 - 1.5, cy as f64 - 1.5, 1.5);
            let base = 4 * (cy * 4 + cx);
            for (n, a) in acc.iter().enumerate() {
                desc[base + n] = (a * w2) as f32;
            }
        }
    }
    let norm = desc.iter().map(|v| v * v).sum::<f32>().sqrt();
    if norm > 0.0 {
        desc.iter_mut().for_each(|v| *v /= norm);
    }
    desc
}

/// Nearest neighbours (Euclidean) of A's descriptors in B passing the ratio test (`ratio` on distances)
/// and, if `mutual`, also nearest from B's side; returns (index in A, index in B, distance).
pub fn match_surf(a: &[SurfDescriptor], b: &[SurfDescriptor], ratio: f32, mutual: bool) -> Vec<(usize, usize, f32)> {
    let dist = |x: &SurfDescriptor, y: &SurfDescriptor| x.iter().zip(y).map(|(p, q)| (p - q) * (p - q)).sum::<f32>();
    // Squared distances: compare with ratio².
    let passes = |best: f32, second: f32| best < ratio * ratio * second;
    crate::nearest::match_nearest(a, b, dist, passes, mutual, f32::INFINITY)
        .into_iter()
        .map(|(i, j, d2)| (i, j, d2.sqrt()))
        .collect()
}

#[cfg(test)]
mod tests;
