//! Step 5 of Jende et al. 2017 (§3.6, with §3.7's Wallis filter): the 3 cm MM patch blurred to simulate the aerial
//! optics, resampled to the aerial GSD and rotated into the aerial image's orientation in one warp, then
//! Wallis-filtered; the aerial window is Wallis-filtered too.
//!
//! Blur: resampling from the MM GSD g_m to the aerial GSD g_a (ratio r = g_a / g_m) needs an anti-aliasing
//! Gaussian of σ_aa = ½·√(1 − 1/r²) aerial pixels (the σ `plumbline_imaging::warp::resize` uses), and the
//! aerial optics add their own point spread σ_o (`AerialConfig::optics_blur_px`). Both are applied as one
//! Gaussian on the 3 cm patch with σ = r·√(σ_o² + σ_aa²) MM pixels before the bilinear resampling.

use plumbline_imaging::error::ImagingError;
use plumbline_imaging::filter::{Wallis, gaussian_blur};
use plumbline_imaging::integral::IntegralImage;
use plumbline_imaging::ortho::GroundGrid;
use plumbline_imaging::{GrayImage, Mask};

/// The MM patch blurred once at its own GSD, with the cells whose blurred value is free of invalid pixels.
#[derive(Clone, Debug)]
pub(crate) struct BlurredPatch {
    /// Blurred ortho-image (invalid cells were filled with the valid mean first).
    pub image: GrayImage,
    /// Valid cells at least two σ of the blur away from any invalid cell.
    pub valid: Mask,
    /// The MM patch's grid.
    pub grid: GroundGrid,
}

/// A patch resampled onto a grid oriented like one aerial image.
#[derive(Clone, Debug)]
pub(crate) struct Prepared {
    /// Wallis-filtered image at the aerial GSD.
    pub image: GrayImage,
    /// Cells with an MM sample.
    pub valid: Mask,
    /// Its grid: the MM patch's centre, the aerial GSD, the aerial image's up direction.
    pub grid: GroundGrid,
}

/// The σ (in MM pixels) of the Gaussian that turns the MM patch into an aerial-like image (module docs).
pub(crate) fn blur_sigma_mm_px(mm_gsd: f64, aerial_gsd: f64, optics_px: f64) -> f64 {
    let r = (aerial_gsd / mm_gsd).max(1.0);
    let anti_alias = 0.5 * (1.0 - 1.0 / (r * r)).sqrt(); // Jende et al. 2017 §3.6, as in imaging::warp::resize
    r * (optics_px * optics_px + anti_alias * anti_alias).sqrt() // Jende et al. 2017 §3.6: simulated aerial optics
}

/// Blur the MM patch for an aerial GSD (Jende et al. 2017 §3.6).
pub(crate) fn blur_patch(
    image: &GrayImage,
    valid: &Mask,
    grid: &GroundGrid,
    aerial_gsd: f64,
    optics_px: f64,
) -> Result<BlurredPatch, ImagingError> {
    let sigma = blur_sigma_mm_px(grid.gsd, aerial_gsd, optics_px);
    let filled = fill_invalid(image, valid);
    let blurred = gaussian_blur(&filled, sigma)?;
    Ok(BlurredPatch { image: blurred, valid: erode(valid, (2.0 * sigma).ceil() as usize), grid: *grid })
}

/// Invalid cells replaced by the mean of the valid ones (so blurs and Wallis see no black borders).
fn fill_invalid(image: &GrayImage, valid: &Mask) -> GrayImage {
    let (sum, n) = image
        .data()
        .iter()
        .zip(valid.data())
        .filter(|p| *p.1)
        .fold((0.0f64, 0usize), |(s, n), (&x, _)| (s + f64::from(x), n + 1));
    let mean = (sum / n.max(1) as f64) as f32;
    GrayImage::from_fn(image.width(), image.height(), |c, r| if valid.get(c, r) { image.get(c, r) } else { mean })
}

/// Cells whose (2·radius + 1)² neighbourhood is entirely valid.
fn erode(valid: &Mask, radius: usize) -> Mask {
    let invalid = GrayImage::from_fn(valid.width(), valid.height(), |c, r| if valid.get(c, r) { 0.0 } else { 1.0 });
    let ii = IntegralImage::new(&invalid);
    let n = 2 * radius + 1;
    Mask::from_fn(valid.width(), valid.height(), |c, r| {
        let st = ii.centred(c, r, radius);
        st.sum < 0.5 && st.n == n * n
    })
}

/// Resample the blurred patch onto a square grid at `gsd` whose up direction has heading `up_heading`
/// (Jende et al. 2017 §3.6: resampling to the aerial GSD and rotation into the aerial image), then Wallis (§3.7).
pub(crate) fn prepare(
    patch: &BlurredPatch,
    up_heading: f64,
    gsd: f64,
    wallis: &Wallis,
) -> Result<Prepared, ImagingError> {
    let mm = &patch.grid;
    let diagonal = (mm.width as f64).hypot(mm.height as f64) * mm.gsd;
    let side = (diagonal / gsd).ceil() as usize + 1;
    let grid = GroundGrid::new(mm.centre, gsd, side, side, up_heading)?;
    let source = |c: usize, r: usize| {
        let [e, n] = grid.to_map(c as f64 + 0.5, r as f64 + 0.5);
        let [u, v] = mm.to_pixel(e, n);
        let inside = u >= 0.0 && v >= 0.0 && u < mm.width as f64 && v < mm.height as f64;
        (inside && patch.valid.get(u as usize, v as usize)).then_some((u, v))
    };
    let valid = Mask::from_fn(side, side, |c, r| source(c, r).is_some());
    let raw =
        GrayImage::from_fn(side, side, |c, r| source(c, r).map_or(0.0, |(u, v)| patch.image.sample_clamped(u, v)));
    let image = wallis.apply(&fill_invalid(&raw, &valid))?;
    Ok(Prepared { image, valid, grid })
}

impl Prepared {
    /// The prepared-grid pixel of an MM-patch pixel.
    pub fn pixel_of_mm(&self, mm: &GroundGrid, pixel: [f64; 2]) -> [f64; 2] {
        let [e, n] = mm.to_map(pixel[0], pixel[1]);
        self.grid.to_pixel(e, n)
    }

    /// True when the square of half-size `half` around continuous pixel `p` is entirely valid.
    pub fn valid_around(&self, p: [f64; 2], half: usize) -> bool {
        let (c, r) = (p[0].floor() as i64, p[1].floor() as i64);
        let h = half as i64 + 1;
        let (w, ht) = (self.valid.width() as i64, self.valid.height() as i64);
        if c - h < 0 || r - h < 0 || c + h >= w || r + h >= ht {
            return false;
        }
        (r - h..=r + h).all(|rr| (c - h..=c + h).all(|cc| self.valid.get(cc as usize, rr as usize)))
    }

    /// A (2·half + 1)² template of the prepared image centred exactly on continuous pixel `p` (bilinear).
    pub fn template(&self, p: [f64; 2], half: usize) -> GrayImage {
        let n = 2 * half + 1;
        let h = half as f64;
        GrayImage::from_fn(n, n, |c, r| self.image.sample_clamped(p[0] + c as f64 - h, p[1] + r as f64 - h))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_sigma_adds_anti_aliasing_and_optics_in_quadrature() {
        // 3 cm → 12 cm: σ_aa = ½√(1 − 1/16) = 0.484 aerial px; with 0.7 px optics: 4·√(0.49 + 0.234) MM px.
        let s = blur_sigma_mm_px(0.03, 0.12, 0.7);
        assert!((s - 4.0 * (0.49f64 + 0.234_375).sqrt()).abs() < 1e-9, "{s}");
        // No optics and equal GSDs: no blur at all.
        assert!(blur_sigma_mm_px(0.12, 0.12, 0.0).abs() < 1e-12);
    }

    #[test]
    fn resampled_patch_puts_a_ground_point_where_both_grids_say() {
        // A bright 30 cm square 1 m east and 2 m north of the centre in a north-up 3 cm patch; after
        // resampling to 12 cm with the up direction heading 90° (east), the square must lie where the
        // prepared grid maps that ground point.
        let mm = GroundGrid::new([500.0, 800.0], 0.03, 400, 400, 0.0).unwrap();
        let image = GrayImage::from_fn(400, 400, |c, r| {
            let [e, n] = mm.to_map(c as f64 + 0.5, r as f64 + 0.5);
            if (e - 501.0).abs() < 0.15 && (n - 802.0).abs() < 0.15 { 200.0 } else { 50.0 }
        });
        let valid = Mask::from_fn(400, 400, |_, _| true);
        let blurred = blur_patch(&image, &valid, &mm, 0.12, 0.0).unwrap();
        let p = prepare(&blurred, std::f64::consts::FRAC_PI_2, 0.12, &Wallis::default()).unwrap();
        let [u, v] = p.grid.to_pixel(501.0, 802.0);
        let centre = (p.grid.width as f64 / 2.0, p.grid.height as f64 / 2.0);
        // Up = east: 1 m east is 1/0.12 px up; 2 m north is to the left (right = south).
        assert!((u - (centre.0 - 2.0 / 0.12)).abs() < 1e-9 && (v - (centre.1 - 1.0 / 0.12)).abs() < 1e-9);
        let (c, r) = (u as usize, v as usize);
        let peak = p.image.get(c, r);
        assert!(peak > p.image.get(c + 4, r) + 20.0 && peak > p.image.get(c, r + 4) + 20.0, "{peak}");
        // The corners of the rotated square grid have no MM sample.
        assert!(!p.valid.get(0, 0) && p.valid.get(c, r));
    }
}
