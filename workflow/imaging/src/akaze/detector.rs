//! AKAZE's detector: scale-normalised Hessian determinant per level, 3×3 maxima above a threshold,
//! subpixel refinement by a quadratic fit, and suppression across neighbouring levels (Alcantarilla et al. 2013 §4.2).

use nalgebra::{Matrix2, Vector2};
use rayon::prelude::*;

use super::scale_space::Level;
use crate::image::GrayImage;
use crate::stencil::{hessian_det, scharr_pair};

/// Derivatives of one level, kept for the descriptor.
#[derive(Clone, Debug)]
pub(crate) struct Derivatives {
    /// Scale-normalised first derivatives (× s).
    pub lx: GrayImage,
    pub ly: GrayImage,
    /// Normalised Hessian determinant (× s⁴).
    pub det: GrayImage,
    /// Derivative spacing s in level pixels.
    pub step: usize,
}

/// Compute the derivatives of every level in parallel; spacing s = round(σ · factor / 2^octave).
pub(crate) fn derivatives(levels: &[Level], factor: f64) -> Vec<Derivatives> {
    levels
        .par_iter()
        .map(|lv| {
            let s = ((lv.sigma * factor / lv.ratio()).round() as usize).max(1);
            level_derivatives(&lv.image, s)
        })
        .collect()
}

/// First derivatives and Hessian determinant of `image` at spacing `s`, all scale-normalised.
pub(crate) fn level_derivatives(image: &GrayImage, s: usize) -> Derivatives {
    let (mut lx, mut ly) = scharr_pair(image, s);
    // Alcantarilla et al. 2013 eq. (6): det H = σ⁴ (Lxx Lyy − Lxy²), σ the derivative scale in level pixels
    let det = hessian_det(&lx, &ly, s);
    let sf = s as f32;
    lx.data_mut().iter_mut().chain(ly.data_mut().iter_mut()).for_each(|x| *x *= sf);
    Derivatives { lx, ly, det, step: s }
}

/// A detected point before description.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Candidate {
    /// Position in input pixels.
    pub u: f64,
    pub v: f64,
    /// Hessian response.
    pub response: f32,
    /// Level index.
    pub level: usize,
    /// Suppression radius in input pixels.
    pub radius: f64,
    /// Scale σ in input pixels (the level's, or refined between levels).
    pub sigma: f64,
}

/// 3×3 maxima above `threshold` on every level, refined to subpixel.
pub(crate) fn candidates(levels: &[Level], ders: &[Derivatives], threshold: f32) -> Vec<Candidate> {
    levels
        .par_iter()
        .zip(ders.par_iter())
        .enumerate()
        .flat_map_iter(|(i, (lv, d))| {
            level_maxima(&d.det, threshold).into_iter().filter_map(move |(c, r)| {
                let (dx, dy) = refine(&d.det, c, r)?;
                let ratio = lv.ratio();
                Some(Candidate {
                    u: (c as f64 + 0.5 + dx) * ratio,
                    v: (r as f64 + 0.5 + dy) * ratio,
                    response: d.det.get(c, r),
                    level: i,
                    radius: d.step as f64 * ratio,
                    sigma: lv.sigma,
                })
            })
        })
        .collect()
}

/// Strict 3×3 maxima above the threshold, at least 2 pixels inside the level. The threshold test runs over
/// row slices first; only the few pixels above it look at their neighbours.
pub(crate) fn level_maxima(det: &GrayImage, threshold: f32) -> Vec<(usize, usize)> {
    let (w, h) = (det.width(), det.height());
    let mut out = Vec::new();
    if w < 5 || h < 5 {
        return out;
    }
    for r in 2..h - 2 {
        let (up, mid, down) = (det.row(r - 1), det.row(r), det.row(r + 1));
        for (i, &x) in mid[2..w - 2].iter().enumerate() {
            if x <= threshold {
                continue;
            }
            let c = i + 2;
            let is_max = [up, down].iter().all(|line| line[c - 1..=c + 1].iter().all(|&y| y < x))
                && mid[c - 1] < x
                && mid[c + 1] < x;
            if is_max {
                out.push((c, r));
            }
        }
    }
    out
}

/// Offset of the vertex of the quadratic through the 3×3 neighbourhood; `None` if it leaves the pixel's
/// neighbourhood (|offset| > 1) or the fit is not a maximum.
fn refine(det: &GrayImage, c: usize, r: usize) -> Option<(f64, f64)> {
    let at = |dc: isize, dr: isize| f64::from(det.get((c as isize + dc) as usize, (r as isize + dr) as usize));
    let g = Vector2::new(0.5 * (at(1, 0) - at(-1, 0)), 0.5 * (at(0, 1) - at(0, -1)));
    let dxx = at(1, 0) + at(-1, 0) - 2.0 * at(0, 0);
    let dyy = at(0, 1) + at(0, -1) - 2.0 * at(0, 0);
    let dxy = 0.25 * (at(1, 1) + at(-1, -1) - at(-1, 1) - at(1, -1));
    let h = Matrix2::new(dxx, dxy, dxy, dyy);
    let d = -(h.try_inverse()? * g);
    (d.x.abs() <= 1.0 && d.y.abs() <= 1.0).then_some((d.x, d.y))
}

/// Keep the strongest of candidates closer than their radius on the same or a neighbouring level
/// (Alcantarilla et al. 2013 §4.2); a grid of 32-pixel cells finds the neighbours.
pub(crate) fn suppress(mut cands: Vec<Candidate>) -> Vec<Candidate> {
    cands.sort_unstable_by(|a, b| b.response.total_cmp(&a.response).then(a.level.cmp(&b.level)));
    let cell = 32.0;
    let index = |x: f64| (x.max(0.0) / cell) as usize;
    let cols = cands.iter().map(|c| index(c.u)).max().unwrap_or(0) + 1;
    let rows = cands.iter().map(|c| index(c.v)).max().unwrap_or(0) + 1;
    let mut grid: Vec<Vec<usize>> = vec![Vec::new(); cols * rows];
    let mut kept: Vec<Candidate> = Vec::new();
    for c in cands {
        let reach = (c.radius * 2.0 / cell).ceil() as usize + 1;
        let (gx, gy) = (index(c.u), index(c.v));
        let clash = (gy.saturating_sub(reach)..(gy + reach + 1).min(rows)).any(|y| {
            (gx.saturating_sub(reach)..(gx + reach + 1).min(cols)).any(|x| {
                grid[y * cols + x].iter().any(|&k| {
                    let o = &kept[k];
                    o.level.abs_diff(c.level) <= 1
                        && (o.u - c.u).powi(2) + (o.v - c.v).powi(2) < o.radius.max(c.radius).powi(2)
                })
            })
        });
        if !clash {
            grid[gy * cols + gx].push(kept.len());
            kept.push(c);
        }
    }
    // Describe in scan order (level, band of 32 rows, column): neighbouring patches then share cache lines,
    // which matters more than any arithmetic in the descriptors.
    let band = |c: &Candidate| (c.v / cell) as usize;
    kept.sort_unstable_by(|a, b| a.level.cmp(&b.level).then(band(a).cmp(&band(b))).then(a.u.total_cmp(&b.u)));
    kept
}
