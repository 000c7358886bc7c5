//! The blocked search against the plain one it replaces (kept here as the reference): the same pairs, the
//! same distances to the bit, the same tie-breaking, on seeded random descriptors with many ties, duplicates,
//! sizes across the block, tile and chunk boundaries, empty inputs, unordered and overflowing floats, and on
//! AKAZE and KAZE features of a rendered pair.

use super::*;
use crate::akaze::{AkazeConfig, Descriptor, akaze, match_descriptors};
use crate::image::GrayImage;
use crate::kaze::{KazeConfig, SurfDescriptor, kaze, match_surf};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The plain search: for each descriptor of `a`, one pass over `b` keeping the best and second best (the
/// first of equal distances wins); if `mutual`, the same pass from each descriptor of `b` over `a`.
fn reference<D, T: PartialOrd + Copy>(
    a: &[D],
    b: &[D],
    distance: impl Fn(&D, &D) -> T,
    passes: impl Fn(T, T) -> bool,
    mutual: bool,
    worst: T,
) -> Vec<(usize, usize, T)> {
    let nearest = |d: &D, set: &[D]| {
        let mut best = (worst, worst, usize::MAX);
        for (j, e) in set.iter().enumerate() {
            let h = distance(d, e);
            if h < best.0 {
                best = (h, best.0, j);
            } else if h < best.1 {
                best.1 = h;
            }
        }
        best
    };
    let back: Vec<usize> = if mutual { b.iter().map(|d| nearest(d, a).2).collect() } else { Vec::new() };
    a.iter()
        .enumerate()
        .filter_map(|(i, d)| {
            let (best, second, j) = nearest(d, b);
            let ok = j != usize::MAX && passes(best, second) && (!mutual || back[j] == i);
            ok.then_some((i, j, best))
        })
        .collect()
}

fn reference_hamming(a: &[Descriptor], b: &[Descriptor], ratio: f64, mutual: bool) -> Vec<(usize, usize, u32)> {
    let passes = |best: u32, second: u32| f64::from(best) < ratio * f64::from(second);
    reference(a, b, crate::akaze::hamming, passes, mutual, u32::MAX)
}

fn reference_l2(a: &[SurfDescriptor], b: &[SurfDescriptor], ratio: f32, mutual: bool) -> Vec<(usize, usize, f32)> {
    let dist = |x: &SurfDescriptor, y: &SurfDescriptor| x.iter().zip(y).map(|(p, q)| (p - q) * (p - q)).sum::<f32>();
    let passes = |best: f32, second: f32| best < ratio * ratio * second;
    reference(a, b, dist, passes, mutual, f32::INFINITY).into_iter().map(|(i, j, d2)| (i, j, d2.sqrt())).collect()
}

/// Both matchers agree on `a` × `b` for every ratio and both modes; returns the mutual matches at 0.8.
fn same_hamming(a: &[Descriptor], b: &[Descriptor]) -> usize {
    let mut found = 0;
    for ratio in [0.8, 1.0, 1.5] {
        for mutual in [false, true] {
            let want = reference_hamming(a, b, ratio, mutual);
            let got: Vec<(usize, usize, u32)> =
                match_descriptors(a, b, ratio, mutual).iter().map(|m| (m.a, m.b, m.distance)).collect();
            assert_eq!(got, want, "{} × {}, ratio {ratio}, mutual {mutual}", a.len(), b.len());
            if ratio == 0.8 && mutual {
                found = got.len();
            }
        }
    }
    found
}

/// As [`same_hamming`], for the L2 matcher; distances compared bit for bit.
fn same_l2(a: &[SurfDescriptor], b: &[SurfDescriptor]) -> usize {
    let bits = |m: Vec<(usize, usize, f32)>| m.into_iter().map(|(i, j, d)| (i, j, d.to_bits())).collect::<Vec<_>>();
    let mut found = 0;
    for ratio in [0.8, 1.0, 1.5] {
        for mutual in [false, true] {
            let (want, got) = (bits(reference_l2(a, b, ratio, mutual)), bits(match_surf(a, b, ratio, mutual)));
            assert_eq!(got, want, "{} × {}, ratio {ratio}, mutual {mutual}", a.len(), b.len());
            if ratio == 0.8 && mutual {
                found = got.len();
            }
        }
    }
    found
}

/// Random binary descriptors; with `few` bits set, from a small alphabet, so that distances tie often.
fn binary(rng: &mut ChaCha8Rng, n: usize, few: bool) -> Vec<Descriptor> {
    (0..n)
        .map(|_| {
            std::array::from_fn(|w| {
                if few { [0, 1, 3, 1 << 40][rng.random_range(0..4usize)] << (w % 2) } else { rng.random::<u64>() }
            })
        })
        .collect()
}

/// Random float descriptors; with `coarse`, small multiples of 1/4, so that sums are exact and tie often.
fn floats(rng: &mut ChaCha8Rng, n: usize, coarse: bool) -> Vec<SurfDescriptor> {
    (0..n)
        .map(|_| {
            std::array::from_fn(|_| {
                if coarse { f32::from(rng.random_range(0..3u8)) * 0.25 } else { rng.random_range(-0.3..0.3f32) }
            })
        })
        .collect()
}

/// Sizes on both sides of the block (8), tile (Hamming 512, L2 128) and chunk (64) lengths, and empty.
const SIZES: [(usize, usize); 10] =
    [(0, 0), (0, 5), (5, 0), (1, 1), (1, 2), (7, 9), (64, 8), (65, 130), (130, 65), (200, 600)];

#[test]
fn hamming_matches_the_plain_search_on_random_descriptors_with_ties_and_duplicates() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for (na, nb) in SIZES {
        for few in [false, true] {
            let a = binary(&mut rng, na, few);
            let mut b = binary(&mut rng, nb, few);
            same_hamming(&a, &b);
            // Exact duplicates of A in B, and repeats within B: equal best distances at several indices.
            for (k, d) in a.iter().enumerate().take(nb / 3) {
                b[(k * 7) % nb] = *d;
                b[(k * 11 + 3) % nb] = *d;
            }
            same_hamming(&a, &b);
            same_hamming(&b, &a);
        }
    }
}

#[test]
fn l2_matches_the_plain_search_to_the_bit_on_random_descriptors_with_ties_and_duplicates() {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    for (na, nb) in SIZES {
        for coarse in [false, true] {
            let a = floats(&mut rng, na, coarse);
            let mut b = floats(&mut rng, nb, coarse);
            same_l2(&a, &b);
            for (k, d) in a.iter().enumerate().take(nb / 3) {
                b[(k * 7) % nb] = *d;
                b[(k * 11 + 3) % nb] = *d;
            }
            same_l2(&a, &b);
            same_l2(&b, &a);
        }
    }
}

#[test]
fn l2_treats_unordered_and_overflowing_distances_as_the_plain_search_does() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let mut a = floats(&mut rng, 40, true);
    let mut b = floats(&mut rng, 70, true);
    a[3][10] = f32::NAN;
    b[5][0] = f32::NAN;
    a[7] = [1e30; 64]; // squares overflow to infinity: never a nearest
    b[9] = [-1e30; 64];
    b[11] = [f32::INFINITY; 64];
    a[12] = b[20];
    same_l2(&a, &b);
    same_l2(&b, &a);
    // Every distance unordered or infinite: no match at all.
    let none = vec![[f32::NAN; 64]; 3];
    assert!(match_surf(&none, &b, 0.8, false).is_empty());
    assert!(match_surf(&a, &none, 0.8, true).is_empty());
}

/// A 256² field of Gaussian blobs, and the same field rotated, scaled and brightened.
fn rendered_pair() -> (GrayImage, GrayImage) {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let blobs: Vec<[f64; 4]> = (0..260)
        .map(|_| {
            let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
            [rng.random_range(0.0..256.0), rng.random_range(0.0..256.0), rng.random_range(1.5..6.0), sign * 60.0]
        })
        .collect();
    let field = move |x: f64, y: f64| {
        128.0
            + blobs
                .iter()
                .map(|b| b[3] * (-((x - b[0]).powi(2) + (y - b[1]).powi(2)) / (2.0 * b[2] * b[2])).exp())
                .sum::<f64>()
    };
    let (s, c) = (0.2f64.sin() / 0.9, 0.2f64.cos() / 0.9);
    let a = GrayImage::from_fn(256, 256, |col, row| field(col as f64 + 0.5, row as f64 + 0.5) as f32);
    let b = GrayImage::from_fn(256, 256, |col, row| {
        let (x, y) = (col as f64 + 0.5 - 128.0, row as f64 + 0.5 - 128.0);
        (0.8 * field(c * x + s * y + 131.0, -s * x + c * y + 126.0) + 20.0) as f32
    });
    (a, b)
}

#[test]
fn matching_real_features_gives_the_plain_search_s_matches() {
    let (a, b) = rendered_pair();
    let (fa, fb) = (akaze(&a, &AkazeConfig::default()).unwrap(), akaze(&b, &AkazeConfig::default()).unwrap());
    let n = same_hamming(&fa.descriptors, &fb.descriptors);
    eprintln!("AKAZE {} × {}: {n} mutual matches", fa.descriptors.len(), fb.descriptors.len());
    assert!(fa.descriptors.len() > 100 && n > 30, "{} descriptors, {n} matches", fa.descriptors.len());
    let config = KazeConfig { octaves: 3, ..KazeConfig::default() };
    let (ka, kb) = (kaze(&a, &config).unwrap(), kaze(&b, &config).unwrap());
    let n = same_l2(&ka.descriptors, &kb.descriptors);
    eprintln!("KAZE {} × {}: {n} mutual matches", ka.descriptors.len(), kb.descriptors.len());
    assert!(ka.descriptors.len() > 100 && n > 30, "{} descriptors, {n} matches", ka.descriptors.len());
}

#[test]
fn the_kernels_give_the_plain_distances() {
    let mut rng = ChaCha8Rng::seed_from_u64(24);
    let (a, b) = (binary(&mut rng, ROWS, false), binary(&mut rng, LANES + 3, false));
    let rows: [Descriptor; ROWS] = std::array::from_fn(|r| a[r]);
    let blocks = pack_hamming(&b);
    assert_eq!(blocks.len(), 2);
    let mut out = [[0; LANES]; ROWS];
    for (k, block) in blocks.iter().enumerate() {
        hamming_tile(&rows, block, &mut out);
        for (r, row) in out.iter().enumerate() {
            for (l, &h) in row.iter().enumerate() {
                let want = b
                    .get(k * LANES + l)
                    .map_or_else(|| crate::akaze::hamming(&a[r], &[0; 8]), |e| crate::akaze::hamming(&a[r], e));
                assert_eq!(h, want);
            }
        }
    }
    let (a, b) = (floats(&mut rng, ROWS, false), floats(&mut rng, LANES, false));
    let rows: [SurfDescriptor; ROWS] = std::array::from_fn(|r| a[r]);
    let mut out = [[0.0; LANES]; ROWS];
    l2_tile(&rows, &pack_l2(&b)[0], &mut out);
    for (r, row) in out.iter().enumerate() {
        for (l, &d) in row.iter().enumerate() {
            let want = a[r].iter().zip(&b[l]).map(|(p, q)| (p - q) * (p - q)).sum::<f32>();
            assert_eq!(d.to_bits(), want.to_bits());
        }
    }
}
