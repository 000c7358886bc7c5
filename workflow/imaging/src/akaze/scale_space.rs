//! The nonlinear scale space of AKAZE: Perona–Malik g2 conductance, fast explicit diffusion (FED) cycles,
//! octaves by 2× area downsampling (Alcantarilla et al., BMVC 2013, §3–4).

use rayon::prelude::*;

use crate::filter::gaussian_blur;
use crate::image::GrayImage;

/// One level of the scale space.
#[derive(Clone, Debug)]
pub(crate) struct Level {
    /// The diffused image at this level's resolution.
    pub image: GrayImage,
    /// Octave index; the level's pixels are 2^octave input pixels wide.
    pub octave: u32,
    /// Scale σ in input pixels.
    pub sigma: f64,
}

impl Level {
    /// Input pixels per level pixel.
    pub fn ratio(&self) -> f64 {
        f64::from(1u32 << self.octave)
    }
}

/// Scharr-type first derivative along x (`dx = true`) or y at spacing `s` pixels: central difference
/// across 2s, smoothed with weights 3/16, 10/16, 3/16 across; borders replicated.
pub(crate) fn scharr(img: &GrayImage, s: usize, dx: bool) -> GrayImage {
    let s = s.max(1);
    if dx { smooth_vertical(&diff_horizontal(img, s), s) } else { diff_vertical(&smooth_horizontal(img, s), s) }
}

/// Run `f(row_index, output_row)` over all rows in parallel.
pub(crate) fn rows(w: usize, h: usize, f: impl Fn(usize, &mut [f32]) + Sync) -> GrayImage {
    let mut out = GrayImage::filled(w, h, 0.0);
    out.data_mut().par_chunks_mut(w).enumerate().for_each(|(r, line)| f(r, line));
    out
}

/// (L(c + s) − L(c − s)) / 2s along rows, edges replicated.
fn diff_horizontal(img: &GrayImage, s: usize) -> GrayImage {
    let (w, inv) = (img.width(), 1.0 / (2.0 * s as f32));
    rows(w, img.height(), |r, out| {
        let src = img.row(r);
        for (c, o) in out.iter_mut().enumerate() {
            *o = (src[(c + s).min(w - 1)] - src[c.saturating_sub(s)]) * inv;
        }
    })
}

/// (3 L(c − s) + 10 L(c) + 3 L(c + s)) / 16 along rows, edges replicated.
fn smooth_horizontal(img: &GrayImage, s: usize) -> GrayImage {
    let w = img.width();
    rows(w, img.height(), |r, out| {
        let src = img.row(r);
        for (c, o) in out.iter_mut().enumerate() {
            *o = (3.0 * (src[c.saturating_sub(s)] + src[(c + s).min(w - 1)]) + 10.0 * src[c]) / 16.0;
        }
    })
}

/// (L(r + s) − L(r − s)) / 2s along columns, edges replicated.
fn diff_vertical(img: &GrayImage, s: usize) -> GrayImage {
    let (h, inv) = (img.height(), 1.0 / (2.0 * s as f32));
    rows(img.width(), h, |r, out| {
        let (up, down) = (img.row(r.saturating_sub(s)), img.row((r + s).min(h - 1)));
        out.iter_mut().zip(up.iter().zip(down)).for_each(|(o, (u, d))| *o = (d - u) * inv);
    })
}

/// (3 L(r − s) + 10 L(r) + 3 L(r + s)) / 16 along columns, edges replicated.
fn smooth_vertical(img: &GrayImage, s: usize) -> GrayImage {
    let h = img.height();
    rows(img.width(), h, |r, out| {
        let (up, mid, down) = (img.row(r.saturating_sub(s)), img.row(r), img.row((r + s).min(h - 1)));
        for (i, o) in out.iter_mut().enumerate() {
            *o = (3.0 * (up[i] + down[i]) + 10.0 * mid[i]) / 16.0;
        }
    })
}

/// The contrast factor k: the `percentile` of the gradient magnitude histogram of the σ = 1 smoothed
/// image (KAZE, ECCV 2012 §3.1; 300 bins, as the authors' code).
pub(crate) fn contrast_factor(img: &GrayImage, percentile: f64) -> f32 {
    let Ok(smooth) = gaussian_blur(img, 1.0) else { return 0.03 };
    let (lx, ly) = (scharr(&smooth, 1, true), scharr(&smooth, 1, false));
    let (w, h) = (img.width(), img.height());
    let mags: Vec<f32> = (1..h.saturating_sub(1))
        .flat_map(|r| (1..w.saturating_sub(1)).map(move |c| (c, r)))
        .map(|(c, r)| lx.get(c, r).hypot(ly.get(c, r)))
        .filter(|&m| m > 0.0)
        .collect();
    let max = mags.iter().fold(0.0f32, |m, &x| m.max(x));
    if mags.is_empty() || max <= 0.0 {
        return 0.03;
    }
    let bins = 300usize;
    let mut hist = vec![0usize; bins];
    mags.iter().for_each(|&m| hist[((m / max * bins as f32) as usize).min(bins - 1)] += 1);
    let target = (percentile * mags.len() as f64) as usize;
    let (mut acc, mut k) = (0, 0);
    while k < bins && acc + hist[k] < target {
        acc += hist[k];
        k += 1;
    }
    (max * k as f32 / bins as f32).max(1e-6)
}

/// Perona–Malik g2 conductance 1 / (1 + |∇L_σ|² / k²) of the σ = 1 smoothed image (BMVC 2013 eq. (2)).
pub(crate) fn conductance(img: &GrayImage, k: f32) -> GrayImage {
    let smooth = gaussian_blur(img, 1.0).unwrap_or_else(|_| img.clone());
    let (lx, ly) = (scharr(&smooth, 1, true), scharr(&smooth, 1, false));
    let k2 = k * k;
    GrayImage::from_fn(img.width(), img.height(), |c, r| {
        let g2 = lx.get(c, r).powi(2) + ly.get(c, r).powi(2);
        1.0 / (1.0 + g2 / k2)
    })
}

/// FED step sizes for diffusion time `t` with stable step `tau_max` (Grewenig et al. 2010; BMVC 2013 eq. (5)):
/// n = ⌈√(3t/τ_max + 1/4) − 1/2⌉, τ_j = τ_max / (2 cos²(π(2j + 1)/(4n + 2))), rescaled to sum to t.
pub(crate) fn fed_steps(t: f64, tau_max: f64) -> Vec<f64> {
    if t <= 0.0 {
        return Vec::new();
    }
    let n = ((3.0 * t / tau_max + 0.25).sqrt() - 0.5 - 1e-8).ceil().max(1.0) as usize;
    let scale = 3.0 * t / (tau_max * (n * (n + 1)) as f64);
    let c = 1.0 / (4 * n + 2) as f64;
    (0..n)
        .map(|j| {
            let h = (std::f64::consts::PI * (2 * j + 1) as f64 * c).cos();
            scale * tau_max / (2.0 * h * h)
        })
        .collect()
}

/// One explicit step L ← L + τ · div(c ∇L) with half-point conductances and reflecting borders.
fn diffusion_step(l: &GrayImage, cond: &GrayImage, tau: f32) -> GrayImage {
    let (w, h) = (l.width(), l.height());
    rows(w, h, |r, out| {
        let (up, down) = (r.saturating_sub(1), (r + 1).min(h - 1));
        let (lu, lm, ld) = (l.row(up), l.row(r), l.row(down));
        let (cu, cm, cd) = (cond.row(up), cond.row(r), cond.row(down));
        for (c, o) in out.iter_mut().enumerate() {
            let (left, right) = (c.saturating_sub(1), (c + 1).min(w - 1));
            let (lc, cc) = (lm[c], cm[c]);
            let flux = (cc + cm[right]) * (lm[right] - lc)
                + (cc + cm[left]) * (lm[left] - lc)
                + (cc + cd[c]) * (ld[c] - lc)
                + (cc + cu[c]) * (lu[c] - lc);
            *o = lc + 0.5 * tau * flux; // BMVC 2013 eq. (4), explicit step of the FED cycle
        }
    })
}

/// Average 2×2 blocks (the odd last row/column is dropped): level pixel c covers input [2c, 2c + 2).
fn half_sample(img: &GrayImage) -> GrayImage {
    let (w, h) = ((img.width() / 2).max(1), (img.height() / 2).max(1));
    GrayImage::from_fn(w, h, |c, r| {
        let at = |dc: usize, dr: usize| img.get_clamped((2 * c + dc) as isize, (2 * r + dr) as isize);
        0.25 * (at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1))
    })
}

/// Build the scale space: `octaves` × `sublevels` levels, σ_i = σ0 · 2^(o + s/S), t_i = σ_i²/2.
pub(crate) fn build(img: &GrayImage, octaves: u32, sublevels: u32, sigma0: f64, percentile: f64) -> Vec<Level> {
    let base = gaussian_blur(img, sigma0).unwrap_or_else(|_| img.clone());
    let mut k = contrast_factor(&base, percentile);
    let mut levels = vec![Level { image: base, octave: 0, sigma: sigma0 }];
    for o in 0..octaves {
        for s in 0..sublevels {
            if o == 0 && s == 0 {
                continue;
            }
            let prev = &levels[levels.len() - 1];
            let mut image = prev.image.clone();
            if o != prev.octave {
                image = half_sample(&image);
                k *= 0.75; // the authors' code: contrast shrinks with resolution
            }
            if image.width() < 8 || image.height() < 8 {
                return levels;
            }
            let sigma = sigma0 * 2f64.powf(f64::from(o) + f64::from(s) / f64::from(sublevels));
            let cond = conductance(&image, k);
            for tau in fed_steps(0.5 * (sigma * sigma - prev.sigma * prev.sigma), 0.25) {
                image = diffusion_step(&image, &cond, tau as f32);
            }
            levels.push(Level { image, octave: o, sigma });
        }
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fed_steps_sum_to_the_diffusion_time_and_exceed_the_stable_step() {
        for t in [0.3, 2.0, 17.5, 120.0] {
            let steps = fed_steps(t, 0.25);
            let total: f64 = steps.iter().sum();
            assert!((total - t).abs() < 1e-9 * t.max(1.0), "{t}: {total}");
            // The point of FED: a cycle covers time quadratic in its length, so n ≈ √(3t/τ).
            assert!(steps.len() as f64 <= (3.0 * t / 0.25).sqrt() + 1.0);
        }
    }

    #[test]
    fn diffusion_keeps_the_mean_and_smooths_more_where_contrast_is_low() {
        // Flat regions diffuse, a strong step edge survives: the point of nonlinear diffusion.
        let img = GrayImage::from_fn(64, 32, |c, r| {
            let noise = ((c * 7 + r * 13) % 5) as f32 * 0.004;
            if c < 32 { 0.2 + noise } else { 0.8 + noise }
        });
        let cond = conductance(&img, 0.05);
        let mut l = img.clone();
        for tau in fed_steps(4.0, 0.25) {
            l = diffusion_step(&l, &cond, tau as f32);
        }
        assert!((l.mean() - img.mean()).abs() < 1e-4);
        // Linear diffusion for the same time t = 4 is a Gaussian of σ = √(2t): it would blur the step.
        let linear = gaussian_blur(&img, 8f64.sqrt()).unwrap();
        let step = |im: &GrayImage| im.get(33, 16) - im.get(30, 16);
        assert!(step(&l) > 0.9 * step(&img) && step(&linear) < 0.6 * step(&img), "{} {}", step(&l), step(&linear));
        let spread = |im: &GrayImage| {
            let v: Vec<f32> = (0..16).map(|c| im.get(c + 4, 16)).collect();
            v.iter().fold(f32::MIN, |m, &x| m.max(x)) - v.iter().fold(f32::MAX, |m, &x| m.min(x))
        };
        assert!(spread(&l) < 0.3 * spread(&img), "{} vs {}", spread(&l), spread(&img));
    }
}
