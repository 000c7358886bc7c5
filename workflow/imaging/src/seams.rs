//! Exposure steps between the sub-cameras of a stitched panorama, found in the image and levelled.
//!
//! A panoramic rig stitches several cameras into one equirectangular image, and each camera keeps its own
//! exposure: where two meet, every row of the image changes brightness by the same factor. Natural edges do
//! not: a building corner darkens some rows and brightens others, the road and the sky not at all. So for
//! each boundary between neighbouring columns the median over the rows of the log-ratio of the two columns'
//! grey values measures the exposure step there and stays near zero elsewhere. Summed over a few columns
//! (`blend_columns`), it also catches a seam the stitcher blended over several columns.
//!
//! A boundary is a seam when its step is at least `min_step` and `robust_z` times the robust spread (MAD) of
//! all boundaries' steps; seams are taken largest first, at least `min_spacing` of the width apart, at most
//! `max_seams`. Levelling gives the stretches between seams gains that remove every step; around the full
//! circle the steps should cancel, and what remains is spread evenly over the seams. The gains are scaled so
//! that the image's mean log-brightness does not change.

use plumbline_geo::metrics::median;

use crate::image::GrayImage;

/// Settings of [`find_seams`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeamConfig {
    /// Smallest step taken for a seam, as a log-ratio (0.02 ≈ 2 % in grey value, about 4.5 % in linear
    /// exposure after a 2.2 gamma).
    pub min_step: f32,
    /// A seam's step must also be this many robust standard deviations (1.4826 · MAD) of all boundaries' steps.
    pub robust_z: f32,
    /// Columns a step is summed over (blended seams spread over a few).
    pub blend_columns: usize,
    /// Least distance between two seams, as a share of the width (a rig of up to 12 cameras).
    pub min_spacing: f32,
    /// Most seams taken.
    pub max_seams: usize,
    /// Rows whose grey value at either column is outside this range (black, saturated) are not compared.
    pub usable: (f32, f32),
}

impl Default for SeamConfig {
    fn default() -> Self {
        Self {
            min_step: 0.02,
            robust_z: 8.0,
            blend_columns: 2,
            min_spacing: 1.0 / 16.0,
            max_seams: 12,
            usable: (4.0, 250.0),
        }
    }
}

/// Seams found in a panorama: the boundary after column `column` and its step (log-ratio of right over left).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Seams {
    /// Per seam: the last column before it, and its step.
    pub found: Vec<(usize, f32)>,
}

/// The exposure steps of a full-circle panorama `image` (its columns spanning 360°, the last one next to the
/// first), comparing only pixels where `valid(col, row)` (e.g. not the vehicle).
pub fn find_seams(image: &GrayImage, valid: impl Fn(usize, usize) -> bool, config: &SeamConfig) -> Seams {
    let (w, h) = (image.width(), image.height());
    if w < 8 || h == 0 {
        return Seams::default();
    }
    let (lo, hi) = config.usable;
    let log = |v: f32| (v + 1.0).ln();
    // The median log-ratio over the rows at each boundary (after column c).
    let mut ratios = Vec::with_capacity(h);
    let boundary: Vec<f32> = (0..w)
        .map(|c| {
            let next = (c + 1) % w;
            ratios.clear();
            for row in 0..h {
                let (a, b) = (image.get(c, row), image.get(next, row));
                if (lo..=hi).contains(&a) && (lo..=hi).contains(&b) && valid(c, row) && valid(next, row) {
                    ratios.push(f64::from(log(b) - log(a)));
                }
            }
            if ratios.len() < h.min(16) { 0.0 } else { median(&mut ratios).unwrap_or(0.0) as f32 }
        })
        .collect();
    let blend = config.blend_columns.clamp(1, w / 4);
    let steps: Vec<f32> = (0..w).map(|c| (0..blend).map(|k| boundary[(c + w - blend / 2 + k) % w]).sum()).collect();
    let mut spread: Vec<f64> = steps.iter().map(|s| f64::from(s.abs())).collect();
    let mad = median(&mut spread).unwrap_or(0.0) as f32;
    let bound = config.min_step.max(config.robust_z * 1.4826 * mad);
    let spacing = ((config.min_spacing * w as f32) as usize).max(blend);
    let mut taken: Vec<(usize, f32)> = Vec::new();
    let mut order: Vec<usize> = (0..w).collect();
    order.sort_by(|&a, &b| steps[b].abs().total_cmp(&steps[a].abs()).then(a.cmp(&b)));
    for c in order {
        if taken.len() >= config.max_seams || steps[c].abs() < bound {
            break;
        }
        let apart = |t: &(usize, f32)| {
            let d = c.abs_diff(t.0);
            d.min(w - d) >= spacing
        };
        if taken.iter().all(apart) {
            // The seam lies at the window's largest single-boundary step.
            let window = (0..blend).map(|k| (c + w - blend / 2 + k) % w);
            let at = window.max_by(|&a, &b| boundary[a].abs().total_cmp(&boundary[b].abs())).unwrap_or(c);
            taken.push((at, steps[c]));
        }
    }
    taken.sort_by_key(|t| t.0);
    Seams { found: taken }
}

/// Level the exposure steps of `seams` in `image`: per stretch between seams a gain on (value + 1), clamped
/// to 0–255; the steps' sum around the circle is spread evenly over them first.
pub fn level_seams(image: &mut GrayImage, seams: &Seams) {
    let w = image.width();
    let n = seams.found.len();
    if n < 2 || w == 0 {
        return;
    }
    let closure = seams.found.iter().map(|s| s.1).sum::<f32>() / n as f32;
    // Log-gain of the stretch after each seam (the stretch before the first seam continues the last one).
    let mut gains = vec![0f32; n];
    for k in 1..n {
        gains[k] = gains[k - 1] - (seams.found[k].1 - closure);
    }
    let widths: Vec<usize> = (0..n).map(|k| (seams.found[(k + 1) % n].0 + w - seams.found[k].0 - 1) % w + 1).collect();
    let mean = gains.iter().zip(&widths).map(|(g, &n)| g * n as f32).sum::<f32>() / w as f32;
    let mut column_gain = vec![0f32; w];
    for k in 0..n {
        let gain = (gains[k] - mean).exp();
        for j in 1..=widths[k] {
            column_gain[(seams.found[k].0 + j) % w] = gain;
        }
    }
    let data = image.data_mut();
    for (i, v) in data.iter_mut().enumerate() {
        *v = ((*v + 1.0) * column_gain[i % w] - 1.0).clamp(0.0, 255.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 360 × 120 panorama: per row a wave of its own frequency and phase (texture that neighbouring
    /// columns share, as in a real image) plus pixel noise (a fixed linear congruential stream), vertical
    /// stripes over the top sixth (facades), and `gains` per sixth of the width (cameras' axes every 60°).
    fn panorama(gains: &[f32; 6]) -> GrayImage {
        let mut state: u64 = 12345;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as f32 / (1u64 << 31) as f32
        };
        // Whole periods around the circle, as in a panorama.
        let waves: Vec<(f32, f32)> =
            (0..120).map(|_| ((1.0 + (8.0 * next()).floor()) * std::f32::consts::TAU / 360.0, 6.3 * next())).collect();
        let base: Vec<f32> = (0..360 * 120)
            .map(|i| {
                let (col, row) = (i % 360, i / 360);
                let facade = if row < 20 && (col / 7) % 2 == 0 { 60.0 } else { 0.0 };
                let (f, phase) = waves[row];
                60.0 + facade + 30.0 * (f * col as f32 + phase).sin() + 6.0 * (next() - 0.5)
            })
            .collect();
        let data = base.iter().enumerate().map(|(i, v)| ((v + 1.0) * gains[(i % 360) / 60] - 1.0).min(255.0)).collect();
        GrayImage::new(360, 120, data).unwrap()
    }

    #[test]
    fn exposure_steps_between_cameras_are_found_and_levelled() {
        // Steps of 0.11–0.28 in log-ratio, the smallest 1.2 times the bound this texture sets (6 σ of its
        // boundaries' medians).
        let gains = [1.0, 1.15, 0.9, 1.05, 0.85, 1.12];
        let mut image = panorama(&gains);
        let seams = find_seams(&image, |_, _| true, &SeamConfig::default());
        let columns: Vec<usize> = seams.found.iter().map(|s| s.0).collect();
        assert_eq!(columns, [59, 119, 179, 239, 299, 359], "{seams:?}");
        for (k, (_, step)) in seams.found.iter().enumerate() {
            let want = (gains[(k + 1) % 6] / gains[k]).ln();
            assert!((step - want).abs() < 0.03, "seam {k}: {step} vs {want}");
        }
        level_seams(&mut image, &seams);
        // The levelled image is the ideal one times one common gain: the ratio is the same everywhere.
        let ideal = panorama(&[1.0; 6]);
        let ratio: Vec<f32> = (0..6)
            .map(|k| {
                let cols = k * 60 + 5..k * 60 + 55;
                let sum = |img: &GrayImage| {
                    cols.clone()
                        .flat_map(|c| (60..120).map(move |r| (c, r)))
                        .map(|(c, r)| img.get(c, r) + 1.0)
                        .sum::<f32>()
                };
                sum(&image) / sum(&ideal)
            })
            .collect();
        let (min, max) = ratio.iter().fold((f32::MAX, f32::MIN), |(a, b), &r| (a.min(r), b.max(r)));
        // From 1.15 / 0.85 = 1.35 between the brightest and the darkest camera to within the steps' errors.
        assert!(max / min < 1.03, "stretch gains after levelling: {ratio:?}");
    }

    #[test]
    fn an_image_without_exposure_steps_has_no_seams_and_is_left_alone() {
        let image = panorama(&[1.0; 6]);
        assert_eq!(find_seams(&image, |_, _| true, &SeamConfig::default()), Seams::default());
        let mut same = image.clone();
        level_seams(&mut same, &Seams::default());
        assert_eq!(same, image);
        // Pixels outside `valid` are not compared: a step in most rows, all of them masked, is not a seam.
        let mut masked = image.clone();
        for row in 50..120 {
            for col in 180..360 {
                masked.set(col, row, masked.get(col, row) * 0.5);
            }
        }
        assert_eq!(find_seams(&masked, |_, row| row < 50, &SeamConfig::default()), Seams::default());
        assert_eq!(find_seams(&masked, |_, _| true, &SeamConfig::default()).found.len(), 2);
    }
}
