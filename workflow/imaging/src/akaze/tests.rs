//! Known-transform tests of AKAZE: repeatability of keypoints and recovery of the transform by matching.

use super::*;
use crate::models::{Correspondence, Model};
use crate::ransac::{RansacConfig, ransac};
use crate::warp::apply_h;
use nalgebra::Matrix3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A field of Gaussian blobs of sizes 1.5–6 px, bright and dark, on grey.
fn blob_field(seed: u64, n: usize, extent: f64) -> impl Fn(f64, f64) -> f64 + Sync {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let blobs: Vec<[f64; 4]> = (0..n)
        .map(|_| {
            let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
            [
                rng.random_range(0.0..extent),
                rng.random_range(0.0..extent),
                rng.random_range(1.5..6.0),
                sign * rng.random_range(40.0..90.0),
            ]
        })
        .collect();
    move |x, y| {
        128.0
            + blobs
                .iter()
                .map(|b| {
                    let d2 = (x - b[0]).powi(2) + (y - b[1]).powi(2);
                    if d2 > 25.0 * b[2] * b[2] { 0.0 } else { b[3] * (-d2 / (2.0 * b[2] * b[2])).exp() }
                })
                .sum::<f64>()
    }
}

fn similarity(angle: f64, scale: f64, centre: f64, shift: [f64; 2]) -> Matrix3<f64> {
    let (s, c) = (scale * angle.sin(), scale * angle.cos());
    let t = [centre - c * centre + s * centre + shift[0], centre - s * centre - c * centre + shift[1]];
    Matrix3::new(c, -s, t[0], s, c, t[1], 0.0, 0.0, 1.0)
}

/// Image A of the scene and image B showing A's point p at `truth · p`, with an illumination change.
fn pair(seed: u64, size: usize, truth: &Matrix3<f64>) -> (GrayImage, GrayImage) {
    let f = blob_field(seed, size * size / 300, size as f64);
    let inv = truth.try_inverse().unwrap();
    let a = GrayImage::from_fn(size, size, |c, r| f(c as f64 + 0.5, r as f64 + 0.5) as f32);
    let b = GrayImage::from_fn(size, size, |c, r| {
        let (x, y) = apply_h(&inv, c as f64 + 0.5, r as f64 + 0.5).unwrap();
        (0.8 * f(x, y) + 20.0) as f32
    });
    (a, b)
}

/// Share of A's keypoints, projected inside B (16 px margin), with a B keypoint within 2.5 px.
fn repeatability(fa: &Features, fb: &Features, truth: &Matrix3<f64>, size: f64) -> (f64, usize) {
    let projected: Vec<(f64, f64)> = fa
        .keypoints
        .iter()
        .filter_map(|k| apply_h(truth, k.u, k.v))
        .filter(|(u, v)| *u > 16.0 && *v > 16.0 && *u < size - 16.0 && *v < size - 16.0)
        .collect();
    let hits = projected.iter().filter(|(u, v)| fb.keypoints.iter().any(|k| (k.u - u).hypot(k.v - v) < 2.5)).count();
    (hits as f64 / projected.len().max(1) as f64, projected.len())
}

/// Match, fit a similarity by RANSAC, and return (inliers, largest error over the image in pixels).
fn recover(fa: &Features, fb: &Features, truth: &Matrix3<f64>, size: f64) -> (usize, f64) {
    let matches = match_descriptors(&fa.descriptors, &fb.descriptors, 0.8, true);
    let pairs: Vec<Correspondence> = matches
        .iter()
        .map(|m| Correspondence {
            a: [fa.keypoints[m.a].u, fa.keypoints[m.a].v],
            b: [fb.keypoints[m.b].u, fb.keypoints[m.b].v],
        })
        .collect();
    let fit = ransac(Model::Similarity, &pairs, &RansacConfig { threshold: 2.0, ..RansacConfig::default() }).unwrap();
    let err = [[0.0, 0.0], [size, 0.0], [0.0, size], [size, size]]
        .iter()
        .map(|p| {
            let (f, t) = (apply_h(&fit.transform, p[0], p[1]).unwrap(), apply_h(truth, p[0], p[1]).unwrap());
            (f.0 - t.0).hypot(f.1 - t.1)
        })
        .fold(0.0, f64::max);
    (fit.inlier_count(), err)
}

#[test]
fn upright_akaze_is_repeatable_under_scale_and_illumination_change_and_matches() {
    let truth = similarity(0.04, 0.85, 128.0, [6.0, -4.0]);
    for seed in [1, 2] {
        let (a, b) = pair(seed, 256, &truth);
        let config = AkazeConfig { upright: true, ..AkazeConfig::default() };
        let (fa, fb) = (akaze(&a, &config).unwrap(), akaze(&b, &config).unwrap());
        let (rep, n) = repeatability(&fa, &fb, &truth, 256.0);
        let (inliers, err) = recover(&fa, &fb, &truth, 256.0);
        eprintln!(
            "seed {seed}: {} / {} keypoints, repeatability {rep:.2} of {n}, {inliers} inliers, {err:.3} px",
            fa.keypoints.len(),
            fb.keypoints.len()
        );
        assert!(n >= 40 && rep > 0.5, "repeatability {rep:.2} over {n} keypoints");
        assert!(inliers >= 20 && err < 0.5, "{inliers} inliers, {err:.3} px");
    }
}

#[test]
fn oriented_akaze_matches_across_a_large_rotation() {
    let truth = similarity(0.7, 1.0, 128.0, [0.0, 0.0]);
    let (a, b) = pair(3, 256, &truth);
    let config = AkazeConfig::default();
    let (fa, fb) = (akaze(&a, &config).unwrap(), akaze(&b, &config).unwrap());
    let (rep, n) = repeatability(&fa, &fb, &truth, 256.0);
    let (inliers, err) = recover(&fa, &fb, &truth, 256.0);
    eprintln!("rotated: repeatability {rep:.2} of {n}, {inliers} inliers, {err:.3} px");
    assert!(rep > 0.5 && inliers >= 15 && err < 0.5, "rep {rep:.2}, {inliers} inliers, {err:.3} px");
}

#[test]
fn bad_settings_are_refused_with_the_field_named() {
    let img = GrayImage::filled(64, 64, 10.0);
    let err = akaze(&img, &AkazeConfig { sigma0: 0.0, ..AkazeConfig::default() }).unwrap_err();
    assert!(err.to_string().contains("sigma0"), "{err}");
    let err = crate::kaze::kaze(&img, &crate::kaze::KazeConfig { grey_scale: -1.0, ..Default::default() }).unwrap_err();
    assert!(err.to_string().contains("grey_scale"), "{err}");
    // A flat image has no features, and that is not an error.
    assert!(akaze(&img, &AkazeConfig::default()).unwrap().keypoints.is_empty());
}
