//! Step 8 of paper 000 (§3.9) over a patch's correspondences: multi-image triangulation of every point seen
//! in at least two frames, or the orthophoto + terrain lookup.

use super::config::AerialConfig;
use super::image::ImageResult;
use super::triangulate::{Ray, triangulate};
use super::view::View;
use super::{AerialObservation, AerialPointResult, MmPatch, Orthophoto};

/// Step 8: every point seen in at least two images, triangulated with blunder checks (paper 000 §3.9).
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
            if !plausible_height(t.position[2], t.covariance[2][2].sqrt(), height, config) {
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

/// Paper 000 §3.9 blunder check for narrow-baseline points: two nadir rays cannot reveal a mismatch along
/// their baseline, which moves the point vertically by about GSD · height / base per pixel; a height
/// `z` (σ `sigma_z`) further than `height_sigmas · σ + height_floor_m` from the patch's (DG) ground height
/// marks such a blunder.
fn plausible_height(z: f64, sigma_z: f64, patch_height: f64, config: &AerialConfig) -> bool {
    (z - patch_height).abs() <= config.height_sigmas * sigma_z + config.height_floor_m
}

/// The orthophoto path: positions from the geotransform and the terrain height, covariance from the GSD.
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
        .filter_map(|&(slot, pixel)| {
            let [e, n] = view.ortho_map(pixel)?;
            let (h, var_h) = match &ortho.terrain {
                Some(t) => (t.height_at(e, n)?, config.terrain_sigma_m.powi(2)),
                None => (patch_height, (3.0 * patch.position_sigma).powi(2) + config.terrain_sigma_m.powi(2)),
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
