//! KAZE features (Alcantarilla et al. 2012), as Jende et al. 2017 §3.3 use them:
//! a nonlinear scale space at full resolution evolved by additive operator splitting (AOS), the authors'
//! scale-normalised Hessian detector with 3-D extrema, and the 64-float M-SURF descriptor, upright or
//! oriented.

mod aos;
mod descriptor;
mod detector;

use rayon::prelude::*;

use crate::akaze::Keypoint;
use crate::akaze::descriptor::orientation;
use crate::akaze::detector::{Derivatives, level_derivatives, suppress};
use crate::akaze::scale_space::contrast_factor;
use crate::error::{ImagingError, require};
use crate::filter::gaussian_blur;
use crate::image::GrayImage;
use crate::stencil::conductance_of;
use aos::aos_step;
pub use descriptor::SurfDescriptor;
use descriptor::msurf;

/// KAZE settings (defaults: the authors').
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KazeConfig {
    /// Octaves of the scale space (Jende et al. 2017 §3.3 use two for ortho-images).
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

/// The derivative spacing of a level: the authors' σ_i rounded (Alcantarilla et al. 2012 §4.1).
fn spacing(sigma: f64) -> usize {
    (sigma.round() as usize).max(1)
}

/// The full-resolution nonlinear scale space, σ_i = σ0 · 2^(i/S), one AOS step of τ = (σ_i² − σ_{i−1}²)/2
/// per level, and the detector's derivatives of every level. As in the authors' code, level i's
/// derivatives and conductance come from L_smooth,i, the σ = 1 blur of level i − 1 (the blur of level 0
/// for level 0); only the derivatives are kept.
fn scale_space(img: &GrayImage, config: &KazeConfig) -> Vec<Derivatives> {
    let blur = |im: &GrayImage| gaussian_blur(im, 1.0).unwrap_or_else(|_| im.clone());
    let mut image = gaussian_blur(img, config.sigma0).unwrap_or_else(|_| img.clone());
    let k = contrast_factor(&image, config.contrast_percentile);
    let sigma = |i: u32| config.sigma0 * 2f64.powf(f64::from(i) / f64::from(config.sublevels));
    let mut ders = vec![level_derivatives(&blur(&image), spacing(config.sigma0))];
    for i in 1..(config.octaves * config.sublevels) {
        let smooth = blur(&image);
        let tau = 0.5 * (sigma(i).powi(2) - sigma(i - 1).powi(2)); // Alcantarilla et al. 2012 §3.1: t_i = σ_i²/2
        let (next, d) = rayon::join(
            || aos_step(&image, &conductance_of(&smooth, k), tau as f32),
            || level_derivatives(&smooth, spacing(sigma(i))),
        );
        image = next;
        ders.push(d);
    }
    ders
}

/// Detect and describe KAZE features.
pub fn kaze(img: &GrayImage, config: &KazeConfig) -> Result<KazeFeatures, ImagingError> {
    require(config.octaves >= 1 && config.sublevels >= 1, "octaves/sublevels", 0.0, "must be at least 1")?;
    require(config.sigma0 > 0.0, "sigma0", config.sigma0, "must be positive")?;
    require(config.grey_scale > 0.0, "grey_scale", f64::from(config.grey_scale), "must be positive")?;
    let ders = scale_space(&img.map(|x| x / config.grey_scale), config);
    let sublevels = f64::from(config.sublevels);
    let found = detector::candidates(&ders, config.threshold, |level| config.sigma0 * 2f64.powf(level / sublevels));
    let described: Vec<(Keypoint, SurfDescriptor)> = suppress(found)
        .par_iter()
        .map(|c| {
            let d = &ders[c.level];
            let scale = c.sigma.round().max(1.0);
            let angle = if config.upright { 0.0 } else { orientation(d, c.u, c.v, scale) };
            let kp = Keypoint { u: c.u, v: c.v, sigma: c.sigma, angle, response: c.response, octave: 0 };
            (kp, msurf(d, c.u, c.v, scale, angle))
        })
        .collect();
    let (keypoints, descriptors) = described.into_iter().unzip();
    Ok(KazeFeatures { keypoints, descriptors })
}

/// Nearest neighbours (Euclidean) of A's descriptors in B passing the ratio test (`ratio` on distances)
/// and, if `mutual`, also nearest from B's side; returns (index in A, index in B, distance). Of equal
/// distances the lowest index wins; squared distances are summed dimension by dimension, in order. Brute
/// force in one pass over |A| · |B| distances (both directions), blocked for cache, in parallel over A.
pub fn match_surf(a: &[SurfDescriptor], b: &[SurfDescriptor], ratio: f32, mutual: bool) -> Vec<(usize, usize, f32)> {
    // Squared distances: compare with ratio².
    let passes = |best: f32, second: f32| best < ratio * ratio * second;
    let blocks = crate::nearest::pack_l2(b);
    crate::nearest::match_blocked(a, &blocks, b.len(), crate::nearest::l2_tile, passes, mutual, f32::INFINITY)
        .into_iter()
        .map(|(i, j, d2)| (i, j, d2.sqrt()))
        .collect()
}

#[cfg(test)]
mod tests;
