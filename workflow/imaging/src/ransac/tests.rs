//! Known-answer tests of the models and RANSAC on seeded synthetic correspondences with outliers.

use super::*;
use crate::warp::apply_h;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn similarity(angle: f64, scale: f64, tx: f64, ty: f64) -> Matrix3<f64> {
    let (s, c) = (scale * angle.sin(), scale * angle.cos());
    Matrix3::new(c, -s, tx, s, c, ty, 0.0, 0.0, 1.0)
}

/// `n` correspondences through `h` with Gaussian-ish noise `sigma` (sum of uniforms), a share `outliers`
/// of them replaced by random points; returns them with the true inlier flags.
fn synth(h: &Matrix3<f64>, n: usize, sigma: f64, outliers: f64, seed: u64) -> (Vec<Correspondence>, Vec<bool>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = |rng: &mut ChaCha8Rng| sigma * ((0..12).map(|_| rng.random::<f64>()).sum::<f64>() - 6.0);
    (0..n)
        .map(|_| {
            let a = [rng.random_range(0.0..1000.0), rng.random_range(0.0..800.0)];
            if rng.random::<f64>() < outliers {
                (Correspondence { a, b: [rng.random_range(-200.0..1200.0), rng.random_range(-200.0..1000.0)] }, false)
            } else {
                let (u, v) = apply_h(h, a[0], a[1]).unwrap();
                (Correspondence { a, b: [u + noise(&mut rng), v + noise(&mut rng)] }, true)
            }
        })
        .unzip()
}

/// Largest distance between the fitted and true mappings over the corners of the 1000 × 800 image.
fn corner_error(fit: &Matrix3<f64>, truth: &Matrix3<f64>) -> f64 {
    [[0.0, 0.0], [1000.0, 0.0], [0.0, 800.0], [1000.0, 800.0], [500.0, 400.0]]
        .iter()
        .map(|p| {
            let (a, b) = (apply_h(fit, p[0], p[1]).unwrap(), apply_h(truth, p[0], p[1]).unwrap());
            (a.0 - b.0).hypot(a.1 - b.1)
        })
        .fold(0.0, f64::max)
}

fn check(model: Model, truth: Matrix3<f64>, seed: u64) {
    let (pairs, truly) = synth(&truth, 300, 0.1, 0.4, seed);
    let fit = ransac(model, &pairs, &RansacConfig { seed, ..RansacConfig::default() }).unwrap();
    let err = corner_error(&fit.transform, &truth);
    assert!(err < 0.1, "{model:?} seed {seed}: {err:.4} px at the corners");
    // Every true inlier is kept (noise is far below the threshold); a random outlier rarely falls within it.
    let missed = truly.iter().zip(&fit.inliers).filter(|(t, f)| **t && !**f).count();
    let false_in = truly.iter().zip(&fit.inliers).filter(|(t, f)| !**t && **f).count();
    assert!(missed == 0 && false_in <= 2, "{model:?}: missed {missed}, accepted {false_in} outliers");
    assert!(fit.rms < 0.2 && fit.iterations < 2000, "{fit:?}");
    // The same seed gives the same answer.
    assert_eq!(fit, ransac(model, &pairs, &RansacConfig { seed, ..RansacConfig::default() }).unwrap());
}

#[test]
fn recovers_each_model_from_noisy_correspondences_with_forty_percent_outliers() {
    for seed in [1, 2, 3] {
        check(Model::Similarity, similarity(0.3, 1.1, 40.0, -25.0), seed);
        check(Model::Affine, Matrix3::new(1.05, 0.08, 30.0, -0.12, 0.93, 12.0, 0.0, 0.0, 1.0), seed);
        check(Model::Homography, Matrix3::new(0.9, 0.1, 50.0, -0.05, 1.1, -20.0, 2e-4, -1e-4, 1.0), seed);
    }
}

#[test]
fn exact_minimal_samples_reproduce_the_transform() {
    let h = Matrix3::new(1.2, -0.3, 5.0, 0.25, 0.8, -7.0, 3e-4, 2e-4, 1.0);
    let (pairs, _) = synth(&h, 4, 0.0, 0.0, 9);
    let fit = Model::Homography.fit(&pairs).unwrap();
    assert!(corner_error(&fit, &h) < 1e-6);
    let (pairs, _) = synth(&similarity(-1.0, 0.7, 3.0, 4.0), 2, 0.0, 0.0, 9);
    assert!(corner_error(&Model::Similarity.fit(&pairs).unwrap(), &similarity(-1.0, 0.7, 3.0, 4.0)) < 1e-9);
}

#[test]
fn too_few_or_collinear_points_are_errors() {
    let line: Vec<Correspondence> =
        (0..6).map(|i| Correspondence { a: [f64::from(i), 2.0 * f64::from(i)], b: [f64::from(i), 1.0] }).collect();
    assert!(matches!(Model::Affine.fit(&line), Err(ImagingError::Degenerate { .. })));
    assert!(matches!(Model::Homography.fit(&line), Err(ImagingError::Degenerate { .. })));
    assert!(matches!(
        ransac(Model::Homography, &line[..3], &RansacConfig::default()),
        Err(ImagingError::TooFew { needed: 4, got: 3, .. })
    ));
    assert!(ransac(Model::Affine, &line, &RansacConfig { threshold: 0.0, ..RansacConfig::default() }).is_err());
}

#[test]
fn iteration_count_follows_the_inlier_ratio() {
    // 50 % inliers, 4-point samples, 99 %: log(0.01)/log(1 − 1/16) = 71.4 → 72.
    assert_eq!(needed_iterations(0.99, 0.5, 4, 10_000), 72);
    assert_eq!(needed_iterations(0.99, 1.0, 4, 10_000), 1);
    assert_eq!(needed_iterations(0.99, 0.0, 4, 500), 500);
}
