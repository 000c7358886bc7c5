//! Geometric resampling: scaling with anti-aliasing, rotation, and warps by a 3×3 matrix (Jende et al. 2017 §3.6).

use nalgebra::{Matrix3, Vector3};

use crate::error::{ImagingError, require};
use crate::filter::gaussian_blur;
use crate::image::{GrayImage, Mask};

/// Apply a 3×3 projective matrix to a continuous pixel (u, v); `None` at or beyond the horizon (w ≤ 0).
pub fn apply_h(h: &Matrix3<f64>, u: f64, v: f64) -> Option<(f64, f64)> {
    let p = h * Vector3::new(u, v, 1.0);
    (p.z > 1e-12).then(|| (p.x / p.z, p.y / p.z))
}

/// A warped image and the mask of output pixels that had a source sample.
#[derive(Clone, Debug)]
pub struct Warped {
    /// The resampled image (0 where no source sample exists).
    pub image: GrayImage,
    /// `true` where the output pixel maps inside the source.
    pub valid: Mask,
}

/// Resample `src` into a `width × height` image whose pixel centre p maps to `dst_to_src · p` in the source
/// (bilinear, edges replicated within half a pixel of the border).
pub fn warp(src: &GrayImage, dst_to_src: &Matrix3<f64>, width: usize, height: usize) -> Warped {
    let sample = |c: usize, r: usize| {
        let (u, v) = apply_h(dst_to_src, c as f64 + 0.5, r as f64 + 0.5)?;
        src.sample(u, v)
    };
    let image = GrayImage::from_fn(width, height, |c, r| sample(c, r).unwrap_or(0.0));
    let valid = Mask::from_fn(width, height, |c, r| sample(c, r).is_some());
    Warped { image, valid }
}

/// Warp `src` by a forward transform `src_to_dst` (A pixels → B pixels) into a `width × height` image.
pub fn warp_forward(
    src: &GrayImage,
    src_to_dst: &Matrix3<f64>,
    width: usize,
    height: usize,
) -> Result<Warped, ImagingError> {
    let inv = src_to_dst
        .try_inverse()
        .ok_or(ImagingError::Degenerate { what: "warp transform", reason: "the 3×3 matrix is singular" })?;
    Ok(warp(src, &inv, width, height))
}

/// Scale by `factor` (> 1 enlarges): the output is round(W·factor) × round(H·factor) and the image corners
/// stay at the corners. Before shrinking, a Gaussian of σ = ½·√(1/factor² − 1) removes what the coarser grid
/// cannot hold (Jende et al. 2017 §3.6: 3 cm → 12 cm).
pub fn resize(src: &GrayImage, factor: f64) -> Result<GrayImage, ImagingError> {
    require(factor.is_finite() && factor > 0.0, "factor", factor, "must be a positive scale")?;
    let w = ((src.width() as f64 * factor).round() as usize).max(1);
    let h = ((src.height() as f64 * factor).round() as usize).max(1);
    let (sx, sy) = (src.width() as f64 / w as f64, src.height() as f64 / h as f64);
    let shrink = sx.max(sy);
    let smoothed = if shrink > 1.0 { gaussian_blur(src, 0.5 * (shrink * shrink - 1.0).sqrt())? } else { src.clone() };
    Ok(GrayImage::from_fn(w, h, |c, r| smoothed.sample_clamped((c as f64 + 0.5) * sx, (r as f64 + 0.5) * sy)))
}

/// The matrix rotating pixel positions by `angle` radians about (cu, cv): p' = c + R(angle)·(p − c), with
/// R the usual 2-D rotation in (u, v); since v points down, a positive angle turns clockwise on screen.
pub fn rotation_about(angle: f64, cu: f64, cv: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    Matrix3::new(c, -s, cu - c * cu + s * cv, s, c, cv - s * cu - c * cv, 0.0, 0.0, 1.0)
}

/// Rotate the image content by `angle` radians about the image centre, keeping the size (Jende et al. 2017 §3.6:
/// align the MM ortho-image with the aerial image). Pixels with no source sample are 0 and unset in `valid`.
pub fn rotate(src: &GrayImage, angle: f64) -> Result<Warped, ImagingError> {
    require(angle.is_finite(), "angle", angle, "must be finite")?;
    let (cu, cv) = (src.width() as f64 / 2.0, src.height() as f64 / 2.0);
    Ok(warp(src, &rotation_about(-angle, cu, cv), src.width(), src.height()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn smooth(u: f64, v: f64) -> f64 {
        50.0 + 20.0 * (u * 0.21).sin() + 15.0 * (v * 0.17 + 0.3).cos()
    }

    #[test]
    fn rotation_moves_a_point_where_the_matrix_says() {
        // A bright dot at (30.5, 20.5) in a 64×48 image turned by 90° about (32, 24) lands at (35.5, 22.5).
        let img = GrayImage::from_fn(64, 48, |c, r| if (c, r) == (30, 20) { 100.0 } else { 0.0 });
        let out = rotate(&img, std::f64::consts::FRAC_PI_2).unwrap();
        assert!((out.image.get(35, 22) - 100.0).abs() < 1e-3, "{}", out.image.get(35, 22));
        let (u, v) = apply_h(&rotation_about(std::f64::consts::FRAC_PI_2, 32.0, 24.0), 30.5, 20.5).unwrap();
        assert!((u - 35.5).abs() < 1e-12 && (v - 22.5).abs() < 1e-12);
        // The corners of a 45° turn have no source.
        let out = rotate(&img, std::f64::consts::FRAC_PI_4).unwrap();
        assert!(!out.valid.get(0, 0) && out.valid.get(32, 24));
    }

    #[test]
    fn resizing_a_smooth_image_samples_it_at_the_new_pixel_centres() {
        let img = GrayImage::from_fn(200, 120, |c, r| smooth(c as f64 + 0.5, r as f64 + 0.5) as f32);
        let half = resize(&img, 0.5).unwrap();
        assert_eq!((half.width(), half.height()), (100, 60));
        let double = resize(&img, 2.0).unwrap();
        for (c, r) in [(10, 10), (50, 30), (80, 45)] {
            // Output pixel (c, r) at scale s covers the source point ((c + 0.5)/s, (r + 0.5)/s).
            let expect = smooth((c as f64 + 0.5) * 2.0, (r as f64 + 0.5) * 2.0);
            assert!((f64::from(half.get(c, r)) - expect).abs() < 2.5, "{} vs {expect}", half.get(c, r));
            let expect = smooth((c as f64 + 0.5) / 2.0, (r as f64 + 0.5) / 2.0);
            assert!((f64::from(double.get(c, r)) - expect).abs() < 0.3);
        }
        assert!(resize(&img, 0.0).is_err());
    }

    #[test]
    fn warping_forward_then_back_returns_the_image() {
        let img = GrayImage::from_fn(90, 70, |c, r| smooth(c as f64 + 0.5, r as f64 + 0.5) as f32);
        let h = Matrix3::new(1.02, 0.05, 3.0, -0.04, 0.98, -2.0, 1e-4, -5e-5, 1.0);
        let there = warp_forward(&img, &h, 90, 70).unwrap();
        let back = warp(&there.image, &h, 90, 70);
        let err = (20..50)
            .flat_map(|r| (20..70).map(move |c| (c, r)))
            .map(|(c, r)| (back.image.get(c, r) - img.get(c, r)).abs());
        assert!(err.fold(0.0f32, f32::max) < 0.6);
    }
}
