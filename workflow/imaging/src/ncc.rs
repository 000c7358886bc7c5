//! Zero-mean normalised cross-correlation over a search window, with window sums from integral images
//! (Jende et al. 2017 §3.4, §3.8; Cazzaniga et al. 2007 §4.3: accept a match when the coefficient exceeds a
//! threshold, e.g. 0.7).

use crate::error::ImagingError;
use crate::image::GrayImage;
use crate::integral::IntegralImage;

/// The best placement of a template in a search image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NccMatch {
    /// Column of the template centre in the search image, continuous pixels (parabolic subpixel peak).
    pub u: f64,
    /// Row of the template centre in the search image, continuous pixels.
    pub v: f64,
    /// Zero-mean correlation coefficient at the best integer placement, in [−1, 1].
    pub score: f64,
    /// Second-best coefficient at least two pixels from the peak (ambiguity of repeated patterns), or −1.
    pub second: f64,
}

/// A search image prepared for repeated template searches (holds its integral images).
#[derive(Clone, Debug)]
pub struct NccSearcher<'a> {
    image: &'a GrayImage,
    integral: IntegralImage,
}

impl<'a> NccSearcher<'a> {
    /// Prepare `image` for searching.
    pub fn new(image: &'a GrayImage) -> Self {
        Self { image, integral: IntegralImage::new(image) }
    }

    /// Correlate `template` (odd sides) with every placement whose centre pixel lies within `radius` pixels
    /// (Chebyshev) of pixel (col, row) in the search image; placements leaving the image are skipped.
    pub fn search(
        &self,
        template: &GrayImage,
        col: usize,
        row: usize,
        radius: usize,
    ) -> Result<NccMatch, ImagingError> {
        let (tw, th) = (template.width(), template.height());
        if tw % 2 == 0 || th % 2 == 0 {
            return Err(ImagingError::Shape { what: "ncc template (odd sides)", width: tw, height: th, len: tw * th });
        }
        let t_mean = template.mean() as f32;
        let centred: Vec<f32> = template.data().iter().map(|&x| x - t_mean).collect();
        let t_ss: f64 = centred.iter().map(|&x| f64::from(x) * f64::from(x)).sum();
        if t_ss < 1e-9 {
            return Err(ImagingError::Degenerate { what: "ncc template", reason: "it has no contrast" });
        }
        let side = 2 * radius + 1;
        let mut scores = vec![f64::NAN; side * side];
        for dy in 0..side {
            for dx in 0..side {
                let (c, r) = ((col + dx) as isize - radius as isize, (row + dy) as isize - radius as isize);
                scores[dy * side + dx] = self.score_at(&centred, t_ss, tw, th, c, r).unwrap_or(f64::NAN);
            }
        }
        self.peak(&scores, side, col, row, radius)
    }

    /// Zero-mean NCC with the template centred on pixel (c, r), or `None` when it leaves the image.
    fn score_at(&self, centred: &[f32], t_ss: f64, tw: usize, th: usize, c: isize, r: isize) -> Option<f64> {
        let (hx, hy) = ((tw / 2) as isize, (th / 2) as isize);
        let (x0, y0) = (c - hx, r - hy);
        if x0 < 0 || y0 < 0 || x0 as usize + tw > self.image.width() || y0 as usize + th > self.image.height() {
            return None;
        }
        let (x0, y0) = (x0 as usize, y0 as usize);
        let stats = self.integral.window(x0, y0, x0 + tw, y0 + th);
        // Σ (t − t̄)(s − s̄) = Σ (t − t̄)·s because Σ (t − t̄) = 0; the search sums come from the integral image.
        let cross: f64 = (0..th)
            .map(|j| {
                let s = &self.image.row(y0 + j)[x0..x0 + tw];
                let t = &centred[j * tw..(j + 1) * tw];
                f64::from(t.iter().zip(s).map(|(a, b)| a * b).sum::<f32>())
            })
            .sum();
        let s_ss = stats.centred_sum_sq();
        (s_ss > 1e-9).then(|| cross / (t_ss * s_ss).sqrt()) // zero-mean NCC, Jende et al. 2017 §3.4
    }

    /// The best score with a parabolic subpixel refinement in u and v, and the runner-up.
    fn peak(
        &self,
        scores: &[f64],
        side: usize,
        col: usize,
        row: usize,
        radius: usize,
    ) -> Result<NccMatch, ImagingError> {
        let best = (0..scores.len())
            .filter(|&i| scores[i].is_finite())
            .max_by(|&a, &b| scores[a].total_cmp(&scores[b]))
            .ok_or_else(|| self.image.out_of_bounds("ncc search", col as f64 + 0.5, row as f64 + 0.5, radius))?;
        let (bx, by) = (best % side, best / side);
        let at = |x: isize, y: isize| {
            let ok = x >= 0 && y >= 0 && (x as usize) < side && (y as usize) < side;
            if ok { scores[y as usize * side + x as usize] } else { f64::NAN }
        };
        let (bxi, byi) = (bx as isize, by as isize);
        let du = parabola(at(bxi - 1, byi), scores[best], at(bxi + 1, byi));
        let dv = parabola(at(bxi, byi - 1), scores[best], at(bxi, byi + 1));
        let second = (0..scores.len())
            .filter(|&i| scores[i].is_finite() && ((i % side).abs_diff(bx) >= 2 || (i / side).abs_diff(by) >= 2))
            .map(|i| scores[i])
            .fold(-1.0, f64::max);
        Ok(NccMatch {
            u: (col + bx) as f64 - radius as f64 + 0.5 + du,
            v: (row + by) as f64 - radius as f64 + 0.5 + dv,
            score: scores[best],
            second,
        })
    }
}

/// Zero-mean NCC of two equally sized patches; `None` when the sizes differ or either has no contrast.
pub fn ncc_patches(a: &GrayImage, b: &GrayImage) -> Option<f64> {
    if a.width() != b.width() || a.height() != b.height() {
        return None;
    }
    let (ma, mb) = (a.mean(), b.mean());
    let (mut num, mut da, mut db) = (0.0, 0.0, 0.0);
    for (x, y) in a.data().iter().zip(b.data()) {
        let (x, y) = (f64::from(*x) - ma, f64::from(*y) - mb);
        num += x * y;
        da += x * x;
        db += y * y;
    }
    (da > 1e-12 && db > 1e-12).then(|| num / (da * db).sqrt()) // zero-mean NCC, Jende et al. 2017 §3.4
}

/// Vertex offset of the parabola through (−1, a), (0, b), (1, c); 0 when undefined.
fn parabola(a: f64, b: f64, c: f64) -> f64 {
    let d = a - 2.0 * b + c;
    if a.is_finite() && c.is_finite() && d < 0.0 { (0.5 * (a - c) / d).clamp(-0.5, 0.5) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn texture(seed: u64) -> impl Fn(f64, f64) -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let waves: Vec<[f64; 4]> = (0..12)
            .map(|_| {
                [
                    rng.random_range(-0.5..0.5),
                    rng.random_range(-0.5..0.5),
                    rng.random_range(0.0..6.3),
                    rng.random_range(5.0..15.0),
                ]
            })
            .collect();
        move |u, v| waves.iter().map(|w| w[3] * (w[0] * u + w[1] * v + w[2]).sin()).sum::<f64>()
    }

    #[test]
    fn finds_a_shifted_template_under_a_gain_and_offset_change() {
        let f = texture(7);
        let a = GrayImage::from_fn(120, 100, |c, r| 100.0 + f(c as f64 + 0.5, r as f64 + 0.5) as f32);
        // B = 0.5·A shifted by (+7, −4) plus 60: an illumination change that plain cross-correlation would
        // not survive; zero-mean NCC must still give 1 at the true offset.
        let b = GrayImage::from_fn(120, 100, |c, r| 60.0 + 0.5 * (100.0 + f(c as f64 - 6.5, r as f64 + 4.5)) as f32);
        let template = a.patch(50, 50, 7).unwrap();
        let m = NccSearcher::new(&b).search(&template, 55, 48, 6).unwrap();
        assert!((m.u - 57.5).abs() < 0.05 && (m.v - 46.5).abs() < 0.05, "{m:?}");
        assert!(m.score > 0.999 && m.second < m.score, "{m:?}");
        // The score equals the textbook coefficient computed directly.
        let direct = ncc_patches(&template, &b.patch(57, 46, 7).unwrap()).unwrap();
        assert!((m.score - direct).abs() < 1e-4);
    }

    #[test]
    fn subpixel_peak_follows_a_fractional_shift_and_flat_templates_are_rejected() {
        let f = texture(8);
        let a = GrayImage::from_fn(100, 100, |c, r| f(c as f64 + 0.5, r as f64 + 0.5) as f32);
        let b = GrayImage::from_fn(100, 100, |c, r| f(c as f64 + 0.5 - 2.3, r as f64 + 0.5 + 1.4) as f32);
        let m = NccSearcher::new(&b).search(&a.patch(50, 50, 8).unwrap(), 50, 50, 4).unwrap();
        // Parabolic interpolation of the correlation peak is good to a few tenths of a pixel.
        assert!((m.u - 52.8).abs() < 0.2 && (m.v - 49.1).abs() < 0.2, "{m:?}");
        let flat = GrayImage::filled(9, 9, 3.0);
        assert!(NccSearcher::new(&b).search(&flat, 50, 50, 3).is_err());
        assert!(NccSearcher::new(&b).search(&GrayImage::filled(8, 9, 1.0), 50, 50, 3).is_err());
    }
}
