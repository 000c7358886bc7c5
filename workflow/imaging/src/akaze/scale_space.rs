//! The nonlinear scale space of AKAZE: Perona–Malik g2 conductance, fast explicit diffusion (FED) cycles,
//! octaves by 2× area downsampling (Alcantarilla et al. 2013 §3–4).

use rayon::prelude::*;

use crate::filter::gaussian_blur;
use crate::image::GrayImage;
pub(crate) use crate::stencil::rows;
use crate::stencil::{conductance_of, neighbours, scharr_pair};

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

/// The contrast factor k: the `percentile` of the gradient magnitude histogram of the σ = 1 smoothed
/// image (KAZE, Alcantarilla et al. 2012 §3.1; 300 bins, as the authors' code).
pub(crate) fn contrast_factor(img: &GrayImage, percentile: f64) -> f32 {
    let Ok(smooth) = gaussian_blur(img, 1.0) else { return 0.03 };
    let (lx, ly) = scharr_pair(&smooth, 1);
    let (w, h) = (img.width(), img.height());
    let inner = |im: &GrayImage, r: usize| -> Vec<f32> { im.row(r)[1..w.saturating_sub(1).max(1)].to_vec() };
    let mags: Vec<f32> = (1..h.saturating_sub(1))
        .flat_map(|r| inner(&lx, r).into_iter().zip(inner(&ly, r)).map(|(x, y)| (x * x + y * y).sqrt()))
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

/// Perona–Malik g2 conductance 1 / (1 + |∇L_σ|² / k²) of the σ = 1 smoothed image (Alcantarilla et al. 2013 eq. (2)).
pub(crate) fn conductance(img: &GrayImage, k: f32) -> GrayImage {
    conductance_of(&gaussian_blur(img, 1.0).unwrap_or_else(|_| img.clone()), k)
}

/// FED step sizes for diffusion time `t` with stable step `tau_max` (Grewenig et al. 2010; Alcantarilla et
/// al. 2013 eq. (5)): n = ⌈√(3t/τ_max + 1/4) − 1/2⌉, τ_j = τ_max / (2 cos²(π(2j + 1)/(4n + 2))), rescaled
/// to sum to t, in the authors' κ-cycle order (see `reorder`).
pub(crate) fn fed_steps(t: f64, tau_max: f64) -> Vec<f64> {
    reorder(&fed_steps_ascending(t, tau_max))
}

/// The FED step sizes in their natural, ascending order.
fn fed_steps_ascending(t: f64, tau_max: f64) -> Vec<f64> {
    if t <= 0.0 {
        return Vec::new();
    }
    let n = ((3.0 * t / tau_max + 0.25).sqrt() - 0.5 - 1e-8).ceil().max(1.0) as usize;
    let scale = 3.0 * t / (tau_max * (n * (n + 1)) as f64);
    let c = 1.0 / (4 * n + 2) as f64;
    (0..n)
        .map(|j| {
            let h = (std::f64::consts::PI * (2 * j + 1) as f64 * c).cos();
            scale * tau_max / (2.0 * h * h) // Alcantarilla et al. 2013 eq. (5)
        })
        .collect()
}

/// Permute a FED cycle so that large and small steps alternate (Grewenig et al. 2010 §4: κ-cycles; the
/// authors' fed.cpp heuristic κ = ⌊n/2⌋ modulo the smallest prime p > n): step l is τ_{((k+1)κ mod p) − 1}
/// for the l-th k whose index falls inside the cycle. In exact arithmetic the order does not matter; in
/// f32 the ascending order lets the large last steps amplify high frequencies far above the input's range.
fn reorder(tau: &[f64]) -> Vec<f64> {
    let n = tau.len();
    if n < 3 {
        return tau.to_vec();
    }
    let is_prime = |p: usize| (2..).take_while(|d| d * d <= p).all(|d| !p.is_multiple_of(d));
    let (kappa, prime) = (n / 2, (n + 1..).find(|&p| is_prime(p)).unwrap_or(n + 1));
    (1..prime).map(|k| (k * kappa) % prime).filter(|&i| (1..=n).contains(&i)).map(|i| tau[i - 1]).collect()
}

/// One explicit step out = L + τ/2 · Σ (c + c_nb)(L_nb − L) over the 4-neighbourhood, reflecting borders
/// (Alcantarilla et al. 2013 eq. (4); the authors' nld_step_scalar).
fn diffusion_step(l: &GrayImage, cond: &GrayImage, tau: f32, out: &mut GrayImage) {
    let w = l.width();
    let half = 0.5 * tau;
    out.data_mut().par_chunks_mut(w).enumerate().for_each(|(r, o)| {
        let (lu, lm, ld) = neighbours(l, r, 1);
        let (cu, cm, cd) = neighbours(cond, r, 1);
        let edge = |c: usize| {
            let (left, right) = (c.saturating_sub(1), (c + 1).min(w - 1));
            let flux = (cm[c] + cm[right]) * (lm[right] - lm[c])
                + (cm[c] + cm[left]) * (lm[left] - lm[c])
                + (cm[c] + cd[c]) * (ld[c] - lm[c])
                + (cm[c] + cu[c]) * (lu[c] - lm[c]);
            lm[c] + half * flux
        };
        if w < 3 {
            (0..w).for_each(|c| o[c] = edge(c));
            return;
        }
        let n = w - 2;
        let (l0, l1, l2, c0, c1, c2) = (&lm[..n], &lm[1..=n], &lm[2..n + 2], &cm[..n], &cm[1..=n], &cm[2..n + 2]);
        let (u, d, gu, gd) = (&lu[1..=n], &ld[1..=n], &cu[1..=n], &cd[1..=n]);
        let inner = &mut o[1..=n];
        for i in 0..n {
            let lc = l1[i];
            let flux = (c1[i] + c2[i]) * (l2[i] - lc)
                + (c1[i] + c0[i]) * (l0[i] - lc)
                + (c1[i] + gd[i]) * (d[i] - lc)
                + (c1[i] + gu[i]) * (u[i] - lc);
            inner[i] = lc + half * flux; // Alcantarilla et al. 2013 eq. (4), explicit step of the FED cycle
        }
        o[0] = edge(0);
        o[w - 1] = edge(w - 1);
    });
}

/// Average 2×2 blocks (the odd last row/column is dropped): level pixel c covers input [2c, 2c + 2).
fn half_sample(img: &GrayImage) -> GrayImage {
    let (w, h) = (img.width() / 2, img.height() / 2);
    if w == 0 || h == 0 {
        return GrayImage::from_fn(w.max(1), h.max(1), |c, r| {
            let at = |dc: usize, dr: usize| img.get_clamped((2 * c + dc) as isize, (2 * r + dr) as isize);
            0.25 * (at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1))
        });
    }
    rows(w, h, |r, out| {
        let (a, b) = (img.row(2 * r), img.row(2 * r + 1));
        for ((o, p), q) in out.iter_mut().zip(a.chunks_exact(2)).zip(b.chunks_exact(2)) {
            *o = 0.25 * ((p[0] + p[1]) + (q[0] + q[1]));
        }
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
            let mut scratch = GrayImage::filled(image.width(), image.height(), 0.0);
            for tau in fed_steps(0.5 * (sigma * sigma - prev.sigma * prev.sigma), 0.25) {
                diffusion_step(&image, &cond, tau as f32, &mut scratch);
                std::mem::swap(&mut image, &mut scratch);
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

    /// Run one FED cycle of `steps` on `img` under unit conductance.
    fn cycle(img: &GrayImage, steps: &[f64]) -> GrayImage {
        let cond = GrayImage::filled(img.width(), img.height(), 1.0);
        let (mut l, mut scratch) = (img.clone(), img.clone());
        for &tau in steps {
            diffusion_step(&l, &cond, tau as f32, &mut scratch);
            std::mem::swap(&mut l, &mut scratch);
        }
        l
    }

    #[test]
    fn a_checkerboard_decays_by_the_known_factor_per_step() {
        // Under unit conductance the checkerboard is an eigenmode of the interior stencil: each step
        // multiplies it by 1 − 8τ. The centre of a 96² image is out of reach of the borders for 40 steps.
        let img = GrayImage::from_fn(96, 96, |c, r| if (c + r) % 2 == 0 { 1.0 } else { -1.0 });
        let steps = fed_steps(2.0, 0.25);
        let want: f64 = steps.iter().map(|t| 1.0 - 8.0 * t).product();
        let got = cycle(&img, &steps).get(48, 48);
        assert!((f64::from(got) - want).abs() < 1e-5, "{got} vs {want}");
    }

    #[test]
    fn reordering_permutes_the_cycle_and_keeps_f32_rounding_from_exploding() {
        let t = 200.0;
        let (ascending, reordered) = (fed_steps_ascending(t, 0.25), fed_steps(t, 0.25));
        let mut sorted = reordered.clone();
        sorted.sort_by(f64::total_cmp);
        assert_eq!(sorted, ascending);
        assert_ne!(reordered, ascending);
        // Diffusion obeys the maximum principle: values stay within the input's range. In the ascending
        // order the rounding error of early steps is amplified by the product of the large last steps.
        let img = GrayImage::from_fn(64, 64, |c, r| 0.5 + 0.3 * (((c * 7919 + r * 104_729) % 1000) as f32 / 1000.0));
        let range = |im: &GrayImage| im.data().iter().fold((f32::MAX, f32::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        let (lo, hi) = range(&cycle(&img, &reordered));
        assert!(lo >= 0.5 - 1e-3 && hi <= 0.8 + 1e-3, "reordered: [{lo}, {hi}]");
        let (lo, hi) = range(&cycle(&img, &ascending));
        assert!(!(lo >= 0.0 && hi <= 1.3), "ascending order stayed bounded: [{lo}, {hi}]");
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
        let mut scratch = img.clone();
        for tau in fed_steps(4.0, 0.25) {
            diffusion_step(&l, &cond, tau as f32, &mut scratch);
            std::mem::swap(&mut l, &mut scratch);
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
