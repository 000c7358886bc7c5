//! Tests of KAZE: AOS conserves grey mass and smooths; keypoints repeat and match under a known similarity.

use super::*;
use crate::models::{Correspondence, Model};
use crate::ransac::{RansacConfig, ransac};
use crate::warp::apply_h;
use nalgebra::Matrix3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn an_aos_step_conserves_the_mean_keeps_constants_and_smooths() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let noisy = GrayImage::new(40, 30, (0..1200).map(|_| rng.random_range(0.0..1.0f32)).collect()).unwrap();
    let g = GrayImage::new(40, 30, (0..1200).map(|_| rng.random_range(0.2..1.0f32)).collect()).unwrap();
    let out = aos_step(&noisy, &g, 3.0);
    assert!((out.mean() - noisy.mean()).abs() < 1e-4, "{} vs {}", out.mean(), noisy.mean());
    let var = |im: &GrayImage| im.data().iter().map(|&x| (f64::from(x) - im.mean()).powi(2)).sum::<f64>();
    assert!(var(&out) < 0.2 * var(&noisy));
    let flat = aos_step(&GrayImage::filled(40, 30, 0.37), &g, 10.0);
    assert!(flat.data().iter().all(|&x| (x - 0.37).abs() < 1e-5));
}

fn blob_field(seed: u64, n: usize, extent: f64) -> impl Fn(f64, f64) -> f64 + Sync {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let blobs: Vec<[f64; 4]> = (0..n)
        .map(|_| {
            let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
            let (x, y) = (rng.random_range(0.0..extent), rng.random_range(0.0..extent));
            [x, y, rng.random_range(1.5..6.0), sign * rng.random_range(40.0..90.0)]
        })
        .collect();
    move |x, y| {
        128.0
            + blobs
                .iter()
                .map(|b| b[3] * (-((x - b[0]).powi(2) + (y - b[1]).powi(2)) / (2.0 * b[2] * b[2])).exp())
                .sum::<f64>()
    }
}

#[test]
fn kaze_is_repeatable_and_recovers_a_known_similarity() {
    let (s, c) = (0.9 * 0.3f64.sin(), 0.9 * 0.3f64.cos());
    let truth = Matrix3::new(
        c,
        -s,
        128.0 - c * 128.0 + s * 128.0 + 5.0,
        s,
        c,
        128.0 - s * 128.0 - c * 128.0 - 3.0,
        0.0,
        0.0,
        1.0,
    );
    let inv = truth.try_inverse().unwrap();
    let f = blob_field(11, 200, 256.0);
    let a = GrayImage::from_fn(256, 256, |c, r| f(c as f64 + 0.5, r as f64 + 0.5) as f32);
    let b = GrayImage::from_fn(256, 256, |c, r| {
        let (x, y) = apply_h(&inv, c as f64 + 0.5, r as f64 + 0.5).unwrap();
        (0.75 * f(x, y) + 30.0) as f32
    });
    let config = KazeConfig { octaves: 3, ..KazeConfig::default() };
    let (fa, fb) = (kaze(&a, &config).unwrap(), kaze(&b, &config).unwrap());
    let inside: Vec<(f64, f64)> = fa
        .keypoints
        .iter()
        .filter_map(|k| apply_h(&truth, k.u, k.v))
        .filter(|(u, v)| *u > 16.0 && *v > 16.0 && *u < 240.0 && *v < 240.0)
        .collect();
    let hits = inside.iter().filter(|(u, v)| fb.keypoints.iter().any(|k| (k.u - u).hypot(k.v - v) < 2.5)).count();
    let rep = hits as f64 / inside.len().max(1) as f64;
    let pairs: Vec<Correspondence> = match_surf(&fa.descriptors, &fb.descriptors, 0.8, true)
        .iter()
        .map(|&(i, j, _)| Correspondence {
            a: [fa.keypoints[i].u, fa.keypoints[i].v],
            b: [fb.keypoints[j].u, fb.keypoints[j].v],
        })
        .collect();
    let fit = ransac(Model::Similarity, &pairs, &RansacConfig { threshold: 2.0, ..RansacConfig::default() }).unwrap();
    let err = [[0.0, 0.0], [256.0, 0.0], [0.0, 256.0], [256.0, 256.0]]
        .iter()
        .map(|p| {
            let (g, t) = (apply_h(&fit.transform, p[0], p[1]).unwrap(), apply_h(&truth, p[0], p[1]).unwrap());
            (g.0 - t.0).hypot(g.1 - t.1)
        })
        .fold(0.0, f64::max);
    eprintln!(
        "kaze: {} / {} keypoints, repeatability {rep:.2} of {}, {} inliers of {}, {err:.3} px",
        fa.keypoints.len(),
        fb.keypoints.len(),
        inside.len(),
        fit.inlier_count(),
        pairs.len()
    );
    assert!(inside.len() >= 40 && rep > 0.5, "repeatability {rep:.2} of {}", inside.len());
    assert!(fit.inlier_count() >= 20 && err < 0.5, "{} inliers, {err:.3} px", fit.inlier_count());
}
