//! Step 8 of Jende et al. 2017 (§3.9) over a patch's correspondences: multi-image triangulation of every point seen
//! in at least two frames, single rays where only one frame kept correspondences, or the orthophoto +
//! terrain lookup.

use nalgebra::Matrix3;

use super::config::AerialConfig;
use super::image::ImageResult;
use super::triangulate::{Ray, triangulate};
use super::view::View;
use super::{AerialObservation, AerialPointResult, MmPatch, Orthophoto};

/// Step 8: every point seen in at least two images, triangulated with blunder checks (Jende et al. 2017 §3.9); a
/// point whose template is an edge at the aerial GSD (roundness below `config.min_roundness`) voted in the
/// common offset but is not output: its position along the edge was not measured.
pub(super) fn triangulate_points(
    patch: &MmPatch<'_>,
    results: &[ImageResult],
    views: &[View<'_>],
    height: f64,
    config: &AerialConfig,
) -> Vec<AerialPointResult> {
    let slots: std::collections::BTreeSet<usize> = results.iter().flat_map(|r| r.matches.iter().map(|m| m.0)).collect();
    slots
        .into_iter()
        .filter(|&slot| roundness(results, slot) >= config.min_roundness)
        .filter_map(|slot| {
            let obs: Vec<(usize, [f64; 2])> = results
                .iter()
                .enumerate()
                .flat_map(|(i, r)| r.matches.iter().filter(|m| m.0 == slot).map(move |m| (i, m.1)))
                .collect();
            let rays: Vec<Ray> = obs
                .iter()
                .filter_map(|&(i, pixel)| match views[i] {
                    View::Frame(f) => Some(Ray { camera: f.camera, pose: f.pose, pixel }),
                    View::Ortho(_) => None,
                })
                .collect();
            let t = triangulate(&rays, config.pixel_sigma, config.max_reprojection_px).ok()?;
            let ground = height + patch.points[slot].rise;
            if !plausible_height(t.position[2], t.covariance[2][2].sqrt(), ground, config) {
                return None;
            }
            let observations = obs
                .iter()
                .zip(&t.used)
                .filter(|p| *p.1)
                .map(|(&(i, pixel), _)| AerialObservation { frame: views[i].id().to_string(), pixel })
                .collect();
            Some(AerialPointResult {
                index: patch.points[slot].index,
                position: t.position,
                covariance: t.covariance,
                observations,
            })
        })
        .collect()
}

/// The points of a patch only one frame kept correspondences for: each its aerial ray, as the point where
/// the ray meets the patch's ground height `height` (plus the ground's rise at the point) with a covariance
/// of `pixel_sigma` (at the ray's range) across the ray and `along` metres along it. The adjustment thus
/// learns the point's position across the ray — horizontal, for a near-nadir ray — and takes the height
/// from the panoramas. Edges are left out as in [`triangulate_points`].
pub(super) fn single_ray_points(
    patch: &MmPatch<'_>,
    results: &[ImageResult],
    views: &[View<'_>],
    height: f64,
    along: f64,
    config: &AerialConfig,
) -> Vec<AerialPointResult> {
    let Some((i, result)) = results.iter().enumerate().find(|(_, r)| !r.matches.is_empty()) else {
        return Vec::new();
    };
    let View::Frame(frame) = views[i] else { return Vec::new() };
    result
        .matches
        .iter()
        .filter(|m| roundness(results, m.0) >= config.min_roundness)
        .filter_map(|&(slot, pixel)| {
            let ray = Ray { camera: frame.camera, pose: frame.pose, pixel };
            let (origin, d) = ray.line()?;
            // Only a ray that looks down meets the ground in front of the camera.
            if d.z > -0.1 {
                return None;
            }
            let range = (height + patch.points[slot].rise - origin.z) / d.z;
            if !(range.is_finite() && range > 0.0) {
                return None;
            }
            let position = origin + d * range;
            // σ across the ray: the angle one pixel subtends, at the ray's range.
            let beside = Ray { pixel: [pixel[0] + 1.0, pixel[1]], ..ray }.line()?.1;
            let across = config.pixel_sigma * d.angle(&beside) * range;
            let dd = d * d.transpose();
            let covariance = (Matrix3::identity() - dd) * across.powi(2) + dd * along.powi(2);
            Some(AerialPointResult {
                index: patch.points[slot].index,
                position: position.into(),
                covariance: covariance.into(),
                observations: vec![AerialObservation { frame: views[i].id().to_string(), pixel }],
            })
        })
        .collect()
}

/// The Förstner roundness of point `slot`'s template at the aerial GSD: the smallest over the images that
/// matched it (the template differs only between orientation groups); 1 when no search recorded it.
fn roundness(results: &[ImageResult], slot: usize) -> f64 {
    results
        .iter()
        .flat_map(|r| r.trace.attempts.iter().filter(|a| a.slot == slot && a.matched.is_some()))
        .map(|a| a.roundness)
        .fold(1.0, f64::min)
}

/// Jende et al. 2017 §3.9 blunder check for narrow-baseline points: two nadir rays cannot reveal a mismatch along
/// their baseline, which moves the point vertically by about GSD · height / base per pixel; a height
/// `z` (σ `sigma_z`) further than `height_sigmas · σ + height_floor_m` from the (DG) ground height at the
/// point marks such a blunder.
fn plausible_height(z: f64, sigma_z: f64, patch_height: f64, config: &AerialConfig) -> bool {
    (z - patch_height).abs() <= config.height_sigmas * sigma_z + config.height_floor_m
}

/// The orthophoto path: positions from the geotransform and the terrain height, covariance from the GSD;
/// edges are left out as in [`triangulate_points`].
pub(super) fn ortho_points(
    patch: &MmPatch<'_>,
    results: &[ImageResult],
    view: &View<'_>,
    ortho: &Orthophoto,
    patch_height: f64,
    config: &AerialConfig,
) -> Vec<AerialPointResult> {
    let g = &ortho.geotransform;
    let gsd = (g[1] * g[5] - g[2] * g[4]).abs().sqrt();
    let horizontal = (config.ortho_sigma_px * gsd).powi(2);
    results[0]
        .matches
        .iter()
        .filter(|m| roundness(results, m.0) >= config.min_roundness)
        .filter_map(|&(slot, pixel)| {
            let [e, n] = view.ortho_map(pixel)?;
            let (h, var_h) = match &ortho.terrain {
                Some(t) => (t.height_at(e, n)?, config.terrain_sigma_m.powi(2)),
                None => {
                    let h = patch_height + patch.points[slot].rise;
                    (h, (3.0 * patch.position_sigma).powi(2) + config.terrain_sigma_m.powi(2))
                }
            };
            Some(AerialPointResult {
                index: patch.points[slot].index,
                position: [e, n, h],
                covariance: [[horizontal, 0.0, 0.0], [0.0, horizontal, 0.0], [0.0, 0.0, var_h]],
                observations: vec![AerialObservation { frame: view.id().to_string(), pixel }],
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aerial::diagnostics::AerialImageDiagnostic;
    use crate::aerial::trace::{Attempt, ImageTrace};
    use crate::aerial::{AerialFrame, PatchPoint};
    use plumbline_geo::camera::{CameraModel, Pinhole};
    use plumbline_geo::{MapFromCamera, OmegaPhiKappa, Point3};
    use plumbline_imaging::ortho::GroundGrid;
    use plumbline_imaging::{GrayImage, Mask};

    /// A nadir frame 1500 m above a ground at 8 m, 12 cm GSD, centred at (e, n).
    fn frame(id: &str, e: f64, n: f64) -> AerialFrame {
        let camera = Pinhole::new(600, 450, 12_500.0, 12_500.0, 300.0, 225.0, 0.0, 0.0).unwrap();
        let pose =
            MapFromCamera::new(OmegaPhiKappa::from_degrees(0.2, -0.1, 0.0).to_rotation(), Point3::new(e, n, 1508.0));
        AerialFrame { id: id.into(), image: GrayImage::from_fn(600, 450, |_, _| 0.0), origin: [0, 0], camera, pose }
    }

    fn pixel(f: &AerialFrame, x: [f64; 3]) -> [f64; 2] {
        let c = f.pose.inverse().transform_point(&Point3::new(x[0], x[1], x[2]));
        let p = f.camera.project(&(c - Point3::origin())).unwrap();
        [p.u, p.v]
    }

    #[test]
    fn an_edge_point_is_not_output_and_a_corner_is() {
        let frames = [frame("a", 1000.0, 2000.0), frame("b", 1030.0, 2000.0)];
        let views: Vec<View<'_>> = frames.iter().map(View::Frame).collect();
        // Two points seen exactly in both frames; slot 0's template is a corner, slot 1's an edge.
        let truth = [[1012.0, 2003.0, 8.0], [1014.5, 2001.0, 8.0]];
        let roundness = [0.7, 0.02];
        let results: Vec<ImageResult> = frames
            .iter()
            .map(|f| {
                let matches: Vec<(usize, [f64; 2])> = (0..2).map(|k| (k, pixel(f, truth[k]))).collect();
                let attempts = matches
                    .iter()
                    .map(|&(slot, p)| Attempt {
                        slot,
                        predicted: p,
                        peak: Some(p),
                        score: Some(0.95),
                        second: Some(0.9),
                        roundness: roundness[slot],
                        matched: Some(p),
                    })
                    .collect();
                let trace = ImageTrace { frame: f.id.clone(), attempts, ..ImageTrace::default() };
                let diagnostic = AerialImageDiagnostic {
                    frame: f.id.clone(),
                    passed: true,
                    rejection: None,
                    initial_inliers: 20,
                    fallback_ncc: None,
                    offset_m: Some(0.1),
                    candidates: 2,
                    matched: 2,
                    correspondences: 2,
                };
                ImageResult { diagnostic, matches, trace }
            })
            .collect();
        let (image, valid) = (GrayImage::from_fn(10, 10, |_, _| 0.0), Mask::from_fn(10, 10, |_, _| true));
        let grid = GroundGrid { centre: [1013.0, 2002.0], gsd: 0.12, width: 10, height: 10, up_heading: 0.0 };
        let points: Vec<PatchPoint> =
            (0..2).map(|k| PatchPoint { index: 40 + k, pixel: [1.0, 1.0], map: truth[k], rise: 0.0 }).collect();
        let patch = MmPatch { image: &image, valid: &valid, grid: &grid, points: &points, position_sigma: 0.5 };
        let config = AerialConfig::default();
        let out = triangulate_points(&patch, &results, &views, 8.0, &config);
        assert_eq!(out.iter().map(|p| p.index).collect::<Vec<_>>(), vec![40]);
        assert!((out[0].position[0] - 1012.0).hypot(out[0].position[1] - 2003.0) < 0.01, "{:?}", out[0].position);
        // Without the bound the edge point is output too: the filter, not the geometry, dropped it.
        let all = triangulate_points(&patch, &results, &views, 8.0, &AerialConfig { min_roundness: 0.0, ..config });
        assert_eq!(all.iter().map(|p| p.index).collect::<Vec<_>>(), vec![40, 41]);
    }

    #[test]
    fn a_height_far_outside_its_sigma_is_a_blunder() {
        let config = AerialConfig { height_sigmas: 3.0, height_floor_m: 2.0, ..AerialConfig::default() };
        // σ 2.6 m from two nadir rays: up to 3 · 2.6 + 2 = 9.8 m from the patch height passes.
        assert!(plausible_height(8.0 + 9.7, 2.6, 8.0, &config));
        assert!(plausible_height(8.0 - 9.7, 2.6, 8.0, &config));
        assert!(!plausible_height(8.0 + 9.9, 2.6, 8.0, &config));
        assert!(!plausible_height(8.0 - 9.9, 2.6, 8.0, &config));
        // A well-determined height (σ 0.1 m) gets little more than the floor.
        assert!(!plausible_height(10.4, 0.1, 8.0, &config) && plausible_height(10.2, 0.1, 8.0, &config));
    }
}
