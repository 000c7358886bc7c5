//! Settings of the MM ↔ aerial registration (Jende et al. 2017 §3.6–3.9) with the paper's values where it gives them.

use plumbline_imaging::filter::Wallis;
use plumbline_imaging::kaze::KazeConfig;
use plumbline_imaging::lsm::LsmConfig;
use plumbline_imaging::ransac::RansacConfig;

/// Bounds of the plausibility check on the initial transformation (Jende et al. 2017 §3.7): the MM pose may be
/// wrong by a few metres, so only the translation's size (and a near-identity rotation and scale) is tested.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plausibility {
    /// Allowed ground offset as a multiple of the patch's DG position σ.
    pub sigma_factor: f64,
    /// Allowed ground offset added to `sigma_factor · σ` (covers AT and matching errors), metres.
    pub floor_m: f64,
    /// Smallest DG position σ the bound uses, metres: a GNSS/INS solution's reported σ is blind to multipath
    /// jumps (Cazzaniga et al. 2007 §1.2: shifts of tens of cm and more that the quality figures do not show), while MM
    /// poses are wrong "in the low-metre range at most" (Jende et al. 2017 §3.1). 0.5 m makes the bound 2 m, the 99 %
    /// horizontal DG error in deep canyons (synth DG: 0.9–2.0 m) against a reported σ of 2.5 cm.
    pub min_position_sigma: f64,
    /// Largest rotation between the rotated MM patch and the aerial patch, radians.
    pub max_rotation: f64,
    /// Largest relative scale difference.
    pub max_scale_error: f64,
}

impl Default for Plausibility {
    fn default() -> Self {
        Self {
            sigma_factor: 3.0,
            floor_m: 0.5,
            min_position_sigma: 0.5,
            max_rotation: 4f64.to_radians(),
            max_scale_error: 0.04,
        }
    }
}

impl Plausibility {
    /// The largest ground offset (m) the check accepts for a reported DG position σ (Jende et al. 2017 §3.7):
    /// `sigma_factor · max(σ, min_position_sigma) + floor_m`.
    pub fn bound_m(&self, position_sigma: f64) -> f64 {
        self.sigma_factor * position_sigma.max(self.min_position_sigma).max(0.0) + self.floor_m
    }
}

/// Settings of [`super::register_patch`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AerialConfig {
    /// σ of the aerial camera's optical point spread, aerial pixels (Jende et al. 2017 §3.6: the Gaussian that
    /// simulates the aerial optics; added in quadrature to the anti-aliasing σ of the 3 cm → GSD resampling).
    pub optics_blur_px: f64,
    /// Wallis filter applied to both patches (Jende et al. 2017 §3.7), in aerial pixels.
    pub wallis: Wallis,
    /// KAZE for the initial transformation: upright, two octaves (Jende et al. 2017 §3.3, §3.7).
    pub kaze: KazeConfig,
    /// Distance-ratio test of the KAZE descriptor matching.
    pub match_ratio: f32,
    /// Match KAZE descriptors only among pairs the DG georeferencing allows (within the plausibility bound;
    /// Jende et al. 2017 §3.1), instead of over the whole window.
    pub guided_matching: bool,
    /// Distance within which KAZE matches agree on the initial translation, aerial pixels (keypoint
    /// localisation at the coarser KAZE levels).
    pub initial_threshold_px: f64,
    /// Fewest KAZE inliers for an initial transformation.
    pub min_initial_inliers: usize,
    /// Plausible initial transformations the corner matching chooses between (1: the largest KAZE consensus
    /// only; 2: also a second significant one, which a repeated marking matched one period off gives).
    pub initial_candidates: usize,
    /// Pool the KAZE matches of all windows of a patch for a common initial offset (module `pooled`), tried
    /// beside each window's own.
    pub pool_windows: bool,
    /// When KAZE finds no initial transformation, correlate the whole prepared patch instead (a translation;
    /// module `correlate`).
    pub correlation_fallback: bool,
    /// Smallest NCC of the whole-patch correlation fallback.
    pub min_correlation: f64,
    /// The fallback's coarse peak must exceed the best placement a coarse pixel pair away by this much.
    pub min_correlation_margin: f64,
    /// When neither KAZE nor the whole-patch correlation finds a plausible initial transformation (none, or a
    /// wrong one the plausibility check rejected), search every corner over the whole plausibility bound
    /// around its DG transfer (Jende et al. 2017 §3.1: the DG pose bounds the search; the prepared patch already has
    /// the aerial orientation and GSD, §3.6) and let the per-image RANSAC (§3.8) find the common
    /// transformation, which must pass the same plausibility check (§3.7).
    pub dg_search: bool,
    /// Plausibility bounds of the initial transformation.
    pub plausibility: Plausibility,
    /// The patch centre must project at least this far inside an aerial frame, pixels.
    pub frame_margin_px: f64,
    /// Aerial frames that must pass the initial transformation and the matching (Jende et al. 2017 §3.7: two) when
    /// `single_ray_sigma_m` is `None`; with single rays one frame is enough.
    pub min_images: usize,
    /// When a single frame keeps correspondences (a block flown at 60 % / 30 % overlap shows many street
    /// points in two frames only, and one of them may fail), its points are still output, each as its one
    /// aerial ray: the point where the ray meets the patch's ground height, with a covariance of the pixel σ
    /// across the ray and this σ (metres) along it, so the adjustment learns the two directions across the
    /// ray and nothing along it. `None`: such patches are discarded (Jende et al. 2017: two images).
    pub single_ray_sigma_m: Option<f64>,
    /// Half-size of the NCC/LSM template, aerial pixels (Jende et al. 2017 §3.8: a small window).
    pub template_half: usize,
    /// NCC search radius around the transferred point, aerial pixels.
    pub search_radius: usize,
    /// Smallest accepted NCC coefficient.
    pub min_ncc: f64,
    /// Least-squares matching iterations.
    pub lsm: LsmConfig,
    /// LSM results further than this from the NCC peak are not trusted (the NCC position is kept), pixels.
    pub lsm_max_shift_px: f64,
    /// RANSAC over an image's correspondences (Jende et al. 2017 §3.8); threshold in aerial pixels.
    pub match_ransac: RansacConfig,
    /// Fewest correspondences per aerial image (Jende et al. 2017 §3.8: ten).
    pub min_correspondences: usize,
    /// Ground intersections of one point's rays may differ from their median by this many aerial pixels
    /// (Jende et al. 2017 §3.8 consistency across aerial images).
    pub consistency_px: f64,
    /// A-priori σ of a matched aerial image coordinate, pixels (weights of the triangulation).
    pub pixel_sigma: f64,
    /// Smallest Förstner roundness q = 4 det N / tr² N of a point's template at the aerial GSD for the point
    /// to be output (module `points`; default [`edge_roundness`]`(pixel_sigma, search_radius)` = 0.039).
    pub min_roundness: f64,
    /// A ray whose reprojection error exceeds this (pixels) is a blunder (Jende et al. 2017 §3.9).
    pub max_reprojection_px: f64,
    /// A triangulated height further than `height_sigmas · σ_H + height_floor_m` from the patch's ground
    /// height is a blunder (Jende et al. 2017 §3.9; two nadir rays hide mismatches along their baseline).
    pub height_sigmas: f64,
    /// See `height_sigmas`; covers the DG height error and objects above the ground, metres.
    pub height_floor_m: f64,
    /// σ of an orthophoto position, orthophoto pixels.
    pub ortho_sigma_px: f64,
    /// σ of a terrain height, metres.
    pub terrain_sigma_m: f64,
}

/// Default `search_radius`, aerial pixels (also sets the default `min_roundness`).
const SEARCH_RADIUS: usize = 3;
/// Default `pixel_sigma`, aerial pixels (also sets the default `min_roundness`).
const PIXEL_SIGMA: f64 = 0.3;

impl Default for AerialConfig {
    fn default() -> Self {
        Self {
            optics_blur_px: 0.7,
            wallis: Wallis { half_window: 12, target_mean: 127.0, target_std: 50.0, contrast: 0.9, brightness: 0.9 },
            kaze: KazeConfig { octaves: 2, sublevels: 4, threshold: 0.0005, upright: true, ..KazeConfig::default() },
            match_ratio: 0.85,
            guided_matching: true,
            initial_threshold_px: 1.5,
            min_initial_inliers: 6,
            initial_candidates: 2,
            pool_windows: true,
            correlation_fallback: true,
            min_correlation: 0.5,
            min_correlation_margin: 0.1,
            dg_search: true,
            plausibility: Plausibility::default(),
            frame_margin_px: 10.0,
            min_images: 2,
            single_ray_sigma_m: Some(10.0),
            template_half: 6,
            search_radius: SEARCH_RADIUS,
            min_ncc: 0.7,
            lsm: LsmConfig::default(),
            lsm_max_shift_px: 1.0,
            match_ransac: RansacConfig { threshold: 1.0, ..RansacConfig::default() },
            min_correspondences: 10,
            consistency_px: 1.5,
            pixel_sigma: PIXEL_SIGMA,
            min_roundness: edge_roundness(PIXEL_SIGMA, SEARCH_RADIUS as f64),
            max_reprojection_px: 1.0,
            height_sigmas: 3.0,
            height_floor_m: 2.0,
            ortho_sigma_px: 0.5,
            terrain_sigma_m: 0.2,
        }
    }
}

/// The roundness below which a template is an edge the corner search cannot place along itself: an edge is
/// matched only across itself, and its position along the edge is where the transfer put it, not a
/// measurement (a car's roof edge along the road, seen by both panoramas, lands on the ground behind the
/// car). With σ across = `pixel_sigma` the σ along is `pixel_sigma · √(λmax / λmin)`; beyond the search
/// radius `radius_px` the search cannot localise it: λmin / λmax ≥ r = (pixel_sigma / radius_px)², and
/// q = 4 λmin λmax / (λmin + λmax)² = 4r / (1 + r)².
pub fn edge_roundness(pixel_sigma: f64, radius_px: f64) -> f64 {
    let r = (pixel_sigma / radius_px).powi(2);
    4.0 * r / (1.0 + r).powi(2)
}

/// How far around its MM patches the registration may look into an aerial frame: a reader that holds only a
/// window of a large frame ([`super::AerialFrame::origin`]) registers exactly as with the whole frame when the
/// window covers every patch's ground area grown by `metres` and then by `pixels`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameReach {
    /// Ground distance beyond the patch centres, metres: the patch's half-diagonal plus the plausibility bound.
    pub metres: f64,
    /// Frame pixels beyond that: the correlation's search radius and template, and the frame margin.
    pub pixels: f64,
}

impl AerialConfig {
    /// The [`FrameReach`] of patches with half-side `patch_half_m` (the MM ortho patch's `half_extent`) whose DG
    /// position σ is at most `max_position_sigma`.
    pub fn frame_reach(&self, patch_half_m: f64, max_position_sigma: f64) -> FrameReach {
        let metres = patch_half_m * std::f64::consts::SQRT_2 + self.plausibility.bound_m(max_position_sigma);
        let pixels = ((self.search_radius + self.template_half) as f64).max(self.frame_margin_px) + 2.0;
        FrameReach { metres, pixels }
    }
}
