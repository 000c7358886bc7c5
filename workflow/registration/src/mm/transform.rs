//! Step 2, Jende et al. 2017 §3.3: the transformation between two adjacent MM ortho-images from upright KAZE
//! features and RANSAC, verified against the DG relative orientation; the orientation-based transformation
//! replaces it when no transformation is found or it disagrees.

use nalgebra::{Matrix3, Vector3};
use plumbline_imaging::kaze::{KazeFeatures, SurfDescriptor, kaze};
use plumbline_imaging::models::{Correspondence, Model};
use plumbline_imaging::ransac::{RansacConfig, ransac};
use plumbline_imaging::warp::apply_h;
use serde::{Deserialize, Serialize};

use super::ortho::OrthoPatch;
use super::{MmConfig, MmError};

/// Why the orientation-based transformation was used.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum FallbackReason {
    /// Too few descriptor matches for RANSAC.
    TooFewMatches {
        /// Matches after the ratio test.
        matches: usize,
    },
    /// RANSAC found too few inliers.
    TooFewInliers {
        /// Inliers of the best transformation.
        inliers: usize,
    },
    /// The feature-based transformation moves the image centre too far from where the DG poses put it.
    Disagrees {
        /// Distance between both predictions of the centre, metres.
        disagreement_m: f64,
    },
    /// The similarity's scale is not 1 (both images share the GSD).
    Scale {
        /// The estimated scale.
        scale: f64,
    },
}

/// Which transformation step 3 used.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(tag = "source", rename_all = "snake_case")]
pub enum TransformSource {
    /// KAZE + RANSAC, verified.
    Kaze {
        /// Descriptor matches.
        matches: usize,
        /// RANSAC inliers.
        inliers: usize,
        /// Distance between the feature- and the orientation-based centre prediction, metres.
        disagreement_m: f64,
    },
    /// From the DG poses (both ortho-grids are in mapping coordinates).
    Orientation(FallbackReason),
}

/// A transformation from pixels of ortho-image A to pixels of ortho-image B.
#[derive(Clone, Debug, PartialEq)]
pub struct PairTransform {
    /// 3×3 matrix (h33 = 1).
    pub matrix: Matrix3<f64>,
    /// Where it came from.
    pub source: TransformSource,
    /// The feature-based similarity when RANSAC found one with enough inliers and unit scale, whether or not
    /// it passed the verification (a DG jump is what makes it disagree): it measures the vehicle's motion.
    pub fit: Option<FeatureFit>,
}

/// A KAZE + RANSAC similarity between two ortho-images and the correspondences that support it.
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureFit {
    /// 3×3 similarity from A pixels to B pixels (least squares on the inliers).
    pub matrix: Matrix3<f64>,
    /// The RANSAC inliers, A and B ortho pixels.
    pub inliers: Vec<Correspondence>,
}

/// Upright KAZE features of an ortho-image (Jende et al. 2017 §3.3), without those whose blob reaches an invalid
/// cell (they describe the vehicle's or the panorama's edge, not the ground).
pub fn features(patch: &OrthoPatch, image_id: &str, config: &MmConfig) -> Result<KazeFeatures, MmError> {
    let all = kaze(&patch.image, &config.kaze).map_err(|source| MmError::Imaging {
        image: image_id.to_owned(),
        step: "kaze features",
        source,
    })?;
    let keep = |k: &plumbline_imaging::akaze::Keypoint| {
        let half = config.kaze_margin.max((3.0 * k.sigma).ceil() as usize);
        patch.valid_around(k.u.floor() as isize, k.v.floor() as isize, half)
    };
    let (keypoints, descriptors) = all.keypoints.into_iter().zip(all.descriptors).filter(|(k, _)| keep(k)).unzip();
    Ok(KazeFeatures { keypoints, descriptors })
}

/// The transformation the DG poses imply: A pixel → map (A's grid) → B pixel (B's grid).
pub fn orientation_transform(a: &OrthoPatch, b: &OrthoPatch) -> Matrix3<f64> {
    let b_from_map = b.grid.map_from_pixel().try_inverse().unwrap_or_else(Matrix3::identity);
    b_from_map * a.grid.map_from_pixel()
}

/// KAZE matches → RANSAC similarity → verification by the image centre (Jende et al. 2017 §3.3); falls back to
/// [`orientation_transform`] when any of them fails.
pub fn pair_transform(
    a: &OrthoPatch,
    fa: &KazeFeatures,
    b: &OrthoPatch,
    fb: &KazeFeatures,
    config: &MmConfig,
) -> PairTransform {
    let oriented = orientation_transform(a, b);
    let fallback = |reason| PairTransform { matrix: oriented, source: TransformSource::Orientation(reason), fit: None };
    let pairs = guided_matches(fa, fb, &oriented, config.guide_radius / a.grid.gsd, config.kaze_ratio);
    if pairs.len() < config.min_kaze_inliers {
        return fallback(FallbackReason::TooFewMatches { matches: pairs.len() });
    }
    let ransac_config = RansacConfig { threshold: config.ransac_threshold, ..RansacConfig::default() };
    let fit = match ransac(Model::Similarity, &pairs, &ransac_config) {
        Ok(fit) if fit.inlier_count() >= config.min_kaze_inliers => fit,
        Ok(fit) => return fallback(FallbackReason::TooFewInliers { inliers: fit.inlier_count() }),
        Err(_) => return fallback(FallbackReason::TooFewInliers { inliers: 0 }),
    };
    let h = fit.transform;
    let scale = h[(0, 0)].hypot(h[(1, 0)]);
    if (scale - 1.0).abs() > config.max_scale_deviation {
        return fallback(FallbackReason::Scale { scale });
    }
    let inliers = pairs.iter().zip(&fit.inliers).filter(|&(_, &keep)| keep).map(|(c, _)| *c).collect();
    let measured = Some(FeatureFit { matrix: h, inliers });
    // Jende et al. 2017 §3.3: project A's centre with both transformations and compare metric distances.
    let disagreement_m = centre_disagreement(a, &h, &oriented) * a.grid.gsd;
    if disagreement_m > config.max_disagreement {
        let source = TransformSource::Orientation(FallbackReason::Disagrees { disagreement_m });
        return PairTransform { matrix: oriented, source, fit: measured };
    }
    let source = TransformSource::Kaze { matches: pairs.len(), inliers: fit.inlier_count(), disagreement_m };
    PairTransform { matrix: h, source, fit: measured }
}

/// Descriptor matches constrained by the DG relative orientation (Jende et al. 2017 §3.1: the MM orientation may
/// be off by metres at most, and far less between neighbours): each keypoint of A is compared only with
/// B's keypoints within `radius` pixels of where `oriented` puts it; nearest neighbour with the ratio
/// test, kept when it is also A's best candidate from B's side.
fn guided_matches(
    fa: &KazeFeatures,
    fb: &KazeFeatures,
    oriented: &Matrix3<f64>,
    radius: f64,
    ratio: f32,
) -> Vec<Correspondence> {
    let dist = |x: &SurfDescriptor, y: &SurfDescriptor| x.iter().zip(y).map(|(p, q)| (p - q) * (p - q)).sum::<f32>();
    let predicted: Vec<Option<(f64, f64)>> = fa.keypoints.iter().map(|k| apply_h(oriented, k.u, k.v)).collect();
    let near = |i: usize, j: usize| {
        let kb = &fb.keypoints[j];
        predicted[i].is_some_and(|(u, v)| (u - kb.u).hypot(v - kb.v) <= radius)
    };
    // Best and second-best squared distance among the candidates of A's keypoint i.
    let best_in_b = |i: usize| {
        let mut best = (usize::MAX, f32::INFINITY, f32::INFINITY);
        for j in (0..fb.keypoints.len()).filter(|&j| near(i, j)) {
            let d = dist(&fa.descriptors[i], &fb.descriptors[j]);
            if d < best.1 {
                best = (j, d, best.1);
            } else if d < best.2 {
                best.2 = d;
            }
        }
        best
    };
    let best_in_a = |j: usize| {
        (0..fa.keypoints.len()).filter(|&i| near(i, j)).min_by(|&x, &y| {
            dist(&fa.descriptors[x], &fb.descriptors[j]).total_cmp(&dist(&fa.descriptors[y], &fb.descriptors[j]))
        })
    };
    (0..fa.keypoints.len())
        .filter_map(|i| {
            let (j, d1, d2) = best_in_b(i);
            // Squared distances: compare with ratio².
            let unique = j != usize::MAX && d1 < ratio * ratio * d2;
            (unique && best_in_a(j) == Some(i)).then(|| Correspondence {
                a: [fa.keypoints[i].u, fa.keypoints[i].v],
                b: [fb.keypoints[j].u, fb.keypoints[j].v],
            })
        })
        .collect()
}

/// Distance in B pixels between A's centre mapped by `h` and by `oriented`.
fn centre_disagreement(a: &OrthoPatch, h: &Matrix3<f64>, oriented: &Matrix3<f64>) -> f64 {
    let (cu, cv) = (a.grid.width as f64 / 2.0, a.grid.height as f64 / 2.0);
    let by_features = h * Vector3::new(cu, cv, 1.0);
    match apply_h(oriented, cu, cv) {
        Some((u, v)) if by_features.z.abs() > 1e-12 => {
            (by_features.x / by_features.z - u).hypot(by_features.y / by_features.z - v)
        }
        _ => f64::INFINITY,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mm::ortho::ortho_patch;
    use crate::mm::testing::{Ground, rig, scene_panorama};

    /// Two panoramas 4 m apart whose DG poses share an error, the second one's error off by `relative`.
    fn pair(relative: [f64; 3], flat: bool) -> (OrthoPatch, OrthoPatch, MmConfig) {
        let config = MmConfig { half_extent: 6.0, ..MmConfig::default() };
        let ground = if flat { Ground::markings(9, [500.0, 0.0], 1.0) } else { Ground::markings(5, [2.0, 0.5], 9.0) };
        let rig = rig(true);
        let common = [0.8, -0.5, 0.1];
        let moved = [common[0] + relative[0], common[1] + relative[1], common[2] + relative[2]];
        let a = scene_panorama("a", &ground, &rig, [0.0, 0.0], 1.2, common);
        let b = scene_panorama("b", &ground, &rig, [3.9, 0.9], 1.3, moved);
        let pa = ortho_patch(&a, &rig, config.gsd, config.half_extent).unwrap();
        let pb = ortho_patch(&b, &rig, config.gsd, config.half_extent).unwrap();
        (pa, pb, config)
    }

    /// Where A's pixel (u, v) truly is in B: the DG errors shift each ortho-image by its own error.
    fn true_in_b(a: &OrthoPatch, b: &OrthoPatch, relative: [f64; 2], u: f64, v: f64) -> [f64; 2] {
        let [e, n] = a.grid.to_map(u, v);
        b.grid.to_pixel(e + relative[0], n + relative[1])
    }

    #[test]
    fn kaze_recovers_the_relative_dg_error_and_passes_verification() {
        let relative = [0.12, -0.09, 0.0];
        let (a, b, config) = pair(relative, false);
        let (fa, fb) = (features(&a, "a", &config).unwrap(), features(&b, "b", &config).unwrap());
        let t = pair_transform(&a, &fa, &b, &fb, &config);
        assert!(matches!(t.source, TransformSource::Kaze { inliers, .. } if inliers >= 20), "{:?}", t.source);
        // Every point of A's overlap maps to its true place in B to within half a pixel (1.5 cm).
        for (u, v) in [(100.0, 100.0), (300.0, 250.0), (200.0, 200.0)] {
            let (bu, bv) = apply_h(&t.matrix, u, v).unwrap();
            let want = true_in_b(&a, &b, [relative[0], relative[1]], u, v);
            assert!((bu - want[0]).hypot(bv - want[1]) < 0.5, "({u}, {v}) → ({bu}, {bv}), want {want:?}");
        }
        // The orientation-based transformation is off by the relative DG error (0.15 m = 5 px).
        let (ou, ov) = apply_h(&orientation_transform(&a, &b), 200.0, 200.0).unwrap();
        let want = true_in_b(&a, &b, [relative[0], relative[1]], 200.0, 200.0);
        assert!(((ou - want[0]).hypot(ov - want[1]) - 5.0).abs() < 0.1);
    }

    #[test]
    fn a_relative_error_beyond_the_bound_or_a_textureless_road_falls_back_to_the_orientation() {
        let (a, b, config) = pair([0.45, 0.0, 0.0], false);
        let (fa, fb) = (features(&a, "a", &config).unwrap(), features(&b, "b", &config).unwrap());
        let t = pair_transform(&a, &fa, &b, &fb, &config);
        match t.source {
            TransformSource::Orientation(FallbackReason::Disagrees { disagreement_m }) => {
                assert!((disagreement_m - 0.45).abs() < 0.03, "{disagreement_m}")
            }
            other => panic!("expected a disagreement, got {other:?}"),
        }
        assert_eq!(t.matrix, orientation_transform(&a, &b));
        // The disagreeing similarity is kept: it measures the motion across the DG jump.
        let fit = t.fit.expect("the feature fit of a disagreeing pair");
        let (u, v) = apply_h(&fit.matrix, 200.0, 200.0).unwrap();
        let want = true_in_b(&a, &b, [0.45, 0.0], 200.0, 200.0);
        assert!((u - want[0]).hypot(v - want[1]) < 0.5 && fit.inliers.len() >= config.min_kaze_inliers);
        let (a, b, config) = pair([0.0; 3], true);
        let (fa, fb) = (features(&a, "a", &config).unwrap(), features(&b, "b", &config).unwrap());
        let t = pair_transform(&a, &fa, &b, &fb, &config);
        assert!(matches!(t.source, TransformSource::Orientation(FallbackReason::TooFewMatches { .. })), "{t:?}");
        assert_eq!(t.fit, None);
    }
}
