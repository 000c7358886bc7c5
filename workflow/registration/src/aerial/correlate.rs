//! A fallback for step 6 of Jende et al. 2017 (§3.7) when KAZE finds no initial transformation: since the prepared
//! MM patch already has the aerial image's orientation and GSD (§3.6), the remaining transformation is
//! close to a translation, which zero-mean NCC of the whole Wallis-filtered patch finds coarse to fine
//! (first at a quarter of the resolution over the DG uncertainty, then at full resolution). The result goes
//! through the same plausibility check, corner matching and RANSAC as a KAZE transformation.

use nalgebra::Matrix3;
use plumbline_imaging::GrayImage;
use plumbline_imaging::ncc::{NccMatch, NccSearcher};
use plumbline_imaging::warp::resize;

use super::prepare::Prepared;

/// Reduction of the coarse level.
const COARSE: f64 = 0.25;

/// Smallest template side of the correlation, full-resolution pixels.
const SMALLEST_TEMPLATE: usize = 31;

/// The central odd-sided crop of `img` at most `max_w × max_h`, and the position of its (0, 0) in `img`.
fn central_crop(img: &GrayImage, max_w: usize, max_h: usize) -> Option<(GrayImage, [usize; 2])> {
    let odd = |n: usize| if n.is_multiple_of(2) { n.saturating_sub(1) } else { n };
    let (w, h) = (odd(img.width().min(max_w)), odd(img.height().min(max_h)));
    if w < SMALLEST_TEMPLATE || h < SMALLEST_TEMPLATE {
        return None;
    }
    let (x0, y0) = ((img.width() - w) / 2, (img.height() - h) / 2);
    Some((GrayImage::from_fn(w, h, |c, r| img.get(x0 + c, y0 + r)), [x0, y0]))
}

/// The largest odd-sided crop of `img` anchored at its top-left corner.
fn odd(img: &GrayImage) -> GrayImage {
    let (w, h) = (img.width() - (1 - img.width() % 2), img.height() - (1 - img.height() % 2));
    GrayImage::from_fn(w.max(1), h.max(1), |c, r| img.get(c, r))
}

/// Centre of an odd template anchored at (0, 0), continuous pixels.
fn centre(t: &GrayImage) -> [f64; 2] {
    [(t.width() / 2) as f64 + 0.5, (t.height() / 2) as f64 + 0.5]
}

/// NCC of `template` around the continuous pixel `at` of `searcher`'s image within `radius` pixels; `None`
/// when the best placement lies on the border of the search range (the true peak may lie beyond).
pub(crate) fn search(
    searcher: &NccSearcher<'_>,
    template: &GrayImage,
    at: [f64; 2],
    radius: usize,
) -> Option<NccMatch> {
    if at[0] < 0.0 || at[1] < 0.0 {
        return None;
    }
    let (col, row) = (at[0] as usize, at[1] as usize);
    let m = searcher.search(template, col, row, radius).ok()?;
    let inside = |x: f64, c: usize| (x - (c as f64 + 0.5)).abs() <= radius as f64 - 0.5 + 1e-9;
    (inside(m.u, col) && inside(m.v, row)).then_some(m)
}

/// The translation (as a 3×3 matrix, prepared pixels → window pixels) that best correlates the prepared
/// patch with the Wallis-filtered aerial `window`, searched within `radius_px` of `predicted` (the window
/// pixel of the patch centre under the DG georeferencing); with its full-resolution NCC score. `None` when
/// the coarse peak does not stand `min_margin` above the best placement a metre or more away.
pub(crate) fn correlate(
    prepared: &Prepared,
    window: &GrayImage,
    predicted: [f64; 2],
    radius_px: f64,
    min_margin: f64,
) -> Option<(Matrix3<f64>, f64)> {
    // The central part of the patch that can slide over the whole search range inside the window (a window
    // clipped at the image border is smaller than the patch).
    let reach = 2 * (radius_px.ceil() as usize + 8);
    let max = [window.width().saturating_sub(reach), window.height().saturating_sub(reach)];
    let (full, [x0, y0]) = central_crop(&prepared.image, max[0], max[1])?;
    let patch_centre = [prepared.image.width() as f64 / 2.0, prepared.image.height() as f64 / 2.0];
    let coarse_patch = odd(&resize(&full, COARSE).ok()?);
    let coarse_window = resize(window, COARSE).ok()?;
    let sp = [scale(full.width()), scale(full.height())];
    let sw = [scale(window.width()), scale(window.height())];
    // The coarse template's centre in prepared pixels, and where the DG georeferencing expects it in the
    // window (rotation and scale are already ≈ 1).
    let c = centre(&coarse_patch);
    let c_full = [x0 as f64 + c[0] * sp[0], y0 as f64 + c[1] * sp[1]];
    let at =
        [(predicted[0] + c_full[0] - patch_centre[0]) / sw[0], (predicted[1] + c_full[1] - patch_centre[1]) / sw[1]];
    let rough = search(
        &NccSearcher::new(&coarse_window),
        &coarse_patch,
        at,
        (radius_px / sw[0].min(sw[1])).ceil() as usize + 1,
    )?;
    // A repeated pattern gives a second peak nearly as high: no unique translation.
    if rough.score - rough.second < min_margin {
        return None;
    }
    // The coarse translation, refined at full resolution within a coarse pixel.
    let d = [rough.u * sw[0] - c_full[0], rough.v * sw[1] - c_full[1]];
    let t = centre(&full);
    let t = [x0 as f64 + t[0], y0 as f64 + t[1]];
    let fine =
        search(&NccSearcher::new(window), &full, [t[0] + d[0], t[1] + d[1]], sw[0].max(sw[1]).ceil() as usize + 1)?;
    let (du, dv) = (fine.u - t[0], fine.v - t[1]);
    Some((Matrix3::new(1.0, 0.0, du, 0.0, 1.0, dv, 0.0, 0.0, 1.0), fine.score))
}

/// Full-resolution pixels per coarse pixel along an axis of `len` pixels (`resize` rounds the coarse size).
fn scale(len: usize) -> f64 {
    len as f64 / (len as f64 * COARSE).round().max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_imaging::Mask;
    use plumbline_imaging::ortho::GroundGrid;

    /// An aperiodic smooth texture (incommensurate plane waves, wavelengths 9–40 px).
    fn texture(u: f64, v: f64) -> f32 {
        let waves =
            [(0.16, 0.05, 0.3, 30.0), (-0.07, 0.21, 1.1, 25.0), (0.31, -0.12, 2.0, 15.0), (0.03, -0.4, 0.7, 12.0)];
        (100.0 + waves.iter().map(|w| w.3 * (w.0 * u + w.1 * v + w.2).sin()).sum::<f64>()) as f32
    }

    fn prepared(f: impl Fn(f64, f64) -> f32 + Sync) -> Prepared {
        let grid = GroundGrid::new([0.0, 0.0], 0.12, 121, 121, 0.0).unwrap();
        let image = GrayImage::from_fn(121, 121, |c, r| f(c as f64 + 0.5, r as f64 + 0.5));
        Prepared { image, valid: Mask::from_fn(121, 121, |_, _| true), grid }
    }

    #[test]
    fn finds_a_translation_beyond_the_dg_prediction_to_subpixel_precision() {
        // Patch pixel p is window pixel p + (33.4, 17.8); the DG georeferencing predicts p + (30, 20).
        let window = GrayImage::from_fn(190, 170, |c, r| texture(c as f64 + 0.5 - 33.4, r as f64 + 0.5 - 17.8));
        let (t, score) = correlate(&prepared(texture), &window, [60.5 + 30.0, 60.5 + 20.0], 12.0, 0.1).unwrap();
        assert!((t[(0, 2)] - 33.4).abs() < 0.2 && (t[(1, 2)] - 17.8).abs() < 0.2, "{t}");
        assert!(score > 0.95 && t[(0, 0)] == 1.0 && t[(0, 1)] == 0.0, "{score}");
        // A prediction 20 px off with a 2 px search radius (2 coarse pixels = 8 px reach): no answer rather
        // than the best placement on the border of the range.
        assert!(correlate(&prepared(texture), &window, [60.5 + 53.4, 60.5 + 17.8], 2.0, 0.1).is_none());
    }

    #[test]
    fn a_repeated_pattern_has_no_unique_translation() {
        // A checkerboard of 8 px period: every period gives the same score.
        let checker = |u: f64, v: f64| {
            (100.0
                + 60.0
                    * (u * std::f64::consts::PI / 4.0).sin().signum()
                    * (v * std::f64::consts::PI / 4.0).sin().signum()) as f32
        };
        let window = GrayImage::from_fn(190, 170, |c, r| checker(c as f64 + 0.5 - 33.0, r as f64 + 0.5 - 18.0));
        assert!(correlate(&prepared(checker), &window, [90.5, 80.5], 12.0, 0.1).is_none());
    }
}
