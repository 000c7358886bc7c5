//! AKAZE features (Alcantarilla et al. 2013, fast explicit diffusion for accelerated features in
//! nonlinear scale spaces): FED scale space, Hessian detector with subpixel refinement, M-LDB
//! binary descriptor, upright or oriented; Hamming matching with ratio test and mutual check.

pub(crate) mod descriptor;
pub(crate) mod detector;
pub(crate) mod scale_space;

use rayon::prelude::*;

pub use descriptor::Descriptor;

use crate::error::{ImagingError, require};
use crate::image::GrayImage;
use crate::nearest;

/// AKAZE settings (defaults: the authors').
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AkazeConfig {
    /// Octaves of the scale space.
    pub octaves: u32,
    /// Levels per octave.
    pub sublevels: u32,
    /// Scale of the first level, input pixels.
    pub sigma0: f64,
    /// Derivative scale relative to the level scale.
    pub derivative_factor: f64,
    /// Minimum Hessian response (grey values scaled to [0, 1] by `grey_scale`).
    pub threshold: f32,
    /// Percentile of the gradient histogram that sets the diffusion contrast k.
    pub contrast_percentile: f64,
    /// Skip orientation (Jende et al. 2017 §3.3: ortho-images need no rotational invariance).
    pub upright: bool,
    /// Grey value that maps to 1 (255 for 8-bit images).
    pub grey_scale: f32,
}

impl Default for AkazeConfig {
    fn default() -> Self {
        Self {
            octaves: 4,
            sublevels: 4,
            sigma0: 1.6,
            derivative_factor: 1.5,
            threshold: 0.001,
            contrast_percentile: 0.7,
            upright: false,
            grey_scale: 255.0,
        }
    }
}

/// A feature point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keypoint {
    /// Column, continuous input pixels.
    pub u: f64,
    /// Row, continuous input pixels.
    pub v: f64,
    /// Scale σ of its level, input pixels.
    pub sigma: f64,
    /// Orientation, radians (0 when upright).
    pub angle: f64,
    /// Hessian response.
    pub response: f32,
    /// Octave of its level.
    pub octave: u32,
}

/// Keypoints and their descriptors, index-aligned.
#[derive(Clone, Debug, Default)]
pub struct Features {
    /// The keypoints.
    pub keypoints: Vec<Keypoint>,
    /// One descriptor per keypoint.
    pub descriptors: Vec<Descriptor>,
}

/// Detect and describe AKAZE features.
pub fn akaze(img: &GrayImage, config: &AkazeConfig) -> Result<Features, ImagingError> {
    require(
        config.octaves >= 1 && config.sublevels >= 1,
        "octaves/sublevels",
        f64::from(config.octaves.min(config.sublevels)),
        "must be at least 1",
    )?;
    require(config.sigma0 > 0.0, "sigma0", config.sigma0, "must be positive")?;
    require(config.grey_scale > 0.0, "grey_scale", f64::from(config.grey_scale), "must be positive")?;
    let scaled = img.map(|x| x / config.grey_scale);
    let levels =
        scale_space::build(&scaled, config.octaves, config.sublevels, config.sigma0, config.contrast_percentile);
    let ders = detector::derivatives(&levels, config.derivative_factor);
    let kept = detector::suppress(detector::candidates(&levels, &ders, config.threshold));
    let described: Vec<(Keypoint, Descriptor)> = kept
        .par_iter()
        .map(|c| {
            let (lv, d) = (&levels[c.level], &ders[c.level]);
            let ratio = lv.ratio();
            let (x, y) = (c.u / ratio, c.v / ratio);
            let scale = (lv.sigma * config.derivative_factor / ratio).round().max(1.0);
            let angle = if config.upright { 0.0 } else { descriptor::orientation(d, x, y, scale) };
            let kp = Keypoint { u: c.u, v: c.v, sigma: lv.sigma, angle, response: c.response, octave: lv.octave };
            (kp, descriptor::describe(lv, d, x, y, scale, angle))
        })
        .collect();
    let (keypoints, descriptors) = described.into_iter().unzip();
    Ok(Features { keypoints, descriptors })
}

/// Hamming distance of two descriptors.
pub fn hamming(a: &Descriptor, b: &Descriptor) -> u32 {
    a.iter().zip(b).map(|(x, y)| (x ^ y).count_ones()).sum()
}

/// A descriptor match: indices into A and B and the Hamming distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DescriptorMatch {
    /// Index in A.
    pub a: usize,
    /// Index in B.
    pub b: usize,
    /// Hamming distance.
    pub distance: u32,
}

/// Nearest neighbours of A's descriptors in B that pass Lowe's ratio test (best < `ratio` · second best)
/// and, if `mutual`, are also A's nearest from B's side; of equal distances, the lowest index wins. Brute
/// force in one pass over |A| · |B| distances (both directions), blocked for cache, in parallel over A.
pub fn match_descriptors(a: &[Descriptor], b: &[Descriptor], ratio: f64, mutual: bool) -> Vec<DescriptorMatch> {
    let passes = |best: u32, second: u32| f64::from(best) < ratio * f64::from(second);
    let blocks = nearest::pack_hamming(b);
    nearest::match_blocked(a, &blocks, b.len(), nearest::hamming_tile, passes, mutual, u32::MAX)
        .into_iter()
        .map(|(a, b, distance)| DescriptorMatch { a, b, distance })
        .collect()
}

#[cfg(test)]
mod tests;
