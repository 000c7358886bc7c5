//! The accepted tie rays' true angular errors split into their component in the ray's vertical plane
//! (elevation: where a ground-matching error along the range goes) and across it (azimuth), by range. Part
//! of `plumbline-eval rejections` (`--dump FILE` writes the rays as CSV).

use std::path::Path;

use plumbline_geo::metrics::{median, quantile_sorted};

use super::score::{RayScore, Scores};

/// Type-7 quantile of sorted values, NaN when empty.
fn q(sorted: &[f64], p: f64) -> f64 {
    quantile_sorted(sorted, p).unwrap_or(f64::NAN)
}

/// Ranges of the bands, metres.
const BANDS: [(f64, f64); 6] = [(0.0, 5.0), (5.0, 8.0), (8.0, 12.0), (12.0, 16.0), (16.0, 20.0), (20.0, f64::INFINITY)];

/// Surface class of the road in the truth (`truth::CLASSES`).
const GROUND: u8 = 1;

/// The 68th percentile of |values| (a robust σ).
fn robust(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.map(f64::abs).collect();
    v.sort_by(f64::total_cmp);
    q(&v, 0.683)
}

fn quantiles(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let mut v: Vec<f64> = values.map(f64::abs).collect();
    v.sort_by(f64::total_cmp);
    (q(&v, 0.5), q(&v, 0.95))
}

/// One table per ray position: the accepted rays after the first of ties whose first ray is on the road,
/// with their errors in panorama pixels (`pixel_angle` radians), in ground metres (across: × r; along the
/// range: × r² / h, the footprint's stretch) and in units of their own σ.
/// `dump`: write those rays as CSV to this file too.
pub fn print(scores: &Scores, solved: &plumbline_adjuster::Solved, pixel_angle: f64, dump_to: Option<&Path>) {
    let (rejected, _) = scores.rejected(solved);
    let rejected = &rejected;
    let rays: Vec<&RayScore> = scores
        .rays
        .iter()
        .enumerate()
        .filter(|(_, t)| t[0].class == Some(GROUND))
        .flat_map(|(i, t)| t.iter().enumerate().skip(1).filter(move |(k, _)| !rejected.contains(&(i, *k))))
        .map(|(_, r)| r)
        .filter(|r| r.components.is_some())
        .collect();
    if let Some(path) = dump_to {
        dump(path, &rays);
    }
    println!(
        "accepted later rays of road ties: true error = observed − true direction, tangents of `TieRay`; robust σ = 68th percentile of |e|\n"
    );
    println!(
        "| range | n | median h m | σ across px | σ elev px | σ across ground m | σ along-range ground m | model σ across px | model σ elev px | across/σ median, 95 % | elev/σ median, 95 % | whitened > 3.29 |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (lo, hi) in BANDS {
        let band: Vec<(&RayScore, [f64; 2], f64, f64)> = rays
            .iter()
            .filter_map(|r| Some((*r, r.components?, r.range?, r.height?)))
            .filter(|(_, _, range, _)| (lo..hi).contains(range))
            .collect();
        if band.is_empty() {
            continue;
        }
        let mut heights: Vec<f64> = band.iter().map(|b| b.3).collect();
        let px = |k: usize| robust(band.iter().map(|b| b.1[k] / pixel_angle));
        let across_m = robust(band.iter().map(|b| b.1[0] * b.2));
        let along_m = robust(band.iter().map(|b| b.1[1] * b.2 * b.2 / b.3.max(0.1)));
        let model = |k: usize| {
            let mut v: Vec<f64> = band.iter().map(|b| b.0.sigmas[k] / pixel_angle).collect();
            median(&mut v).unwrap_or(f64::NAN)
        };
        let (am, a95) = quantiles(band.iter().map(|b| b.1[0] / b.0.sigmas[0]));
        let (em, e95) = quantiles(band.iter().map(|b| b.1[1] / b.0.sigmas[1]));
        let beyond = band.iter().filter(|b| b.0.error.is_some_and(|e| e > 3.29)).count() as f64 / band.len() as f64;
        println!(
            "| {lo}–{hi} m | {} | {:.2} | {:.3} | {:.3} | {:.4} | {:.4} | {:.3} | {:.3} | {am:.2}, {a95:.2} | {em:.2}, {e95:.2} | {:.1} % |",
            band.len(),
            median(&mut heights).unwrap_or(f64::NAN),
            px(0),
            px(1),
            across_m,
            along_m,
            model(0),
            model(1),
            100.0 * beyond
        );
    }
    println!();
}

/// Write the rays of [`print()`] as CSV for a closer look.
fn dump(path: &Path, rays: &[&RayScore]) {
    let mut text = String::from("range,other_range,baseline,height,across,elevation,sigma,sigma_elevation,error\n");
    for r in rays {
        let (Some(c), Some(range), Some(h), Some(o)) = (r.components, r.range, r.height, r.other) else { continue };
        let e = r.error.unwrap_or(f64::NAN);
        let [s0, s1] = r.sigmas;
        text += &format!("{range},{},{},{h},{},{},{s0},{s1},{e}\n", o[0], o[1], c[0], c[1]);
    }
    std::fs::write(path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}
