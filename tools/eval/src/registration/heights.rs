//! The aerial points' height errors against the truth (Jende et al. 2017 §3.9: two or three nadir rays from 1500 m
//! fix the height to metres): their median and spread, how much of it the points of one panorama share
//! (the same frames, the same orientation errors), and how the reported σ_H compares. Part of
//! `plumbline-eval registration` (`cargo run --release -p plumbline-eval -- registration`).

use plumbline_geo::metrics;

/// One aerial point: panorama id, height error (triangulated − true, m), reported σ_H (m).
pub type HeightError = (String, f64, f64);

/// One table row per profile: its name and its points' height errors.
pub fn print_table(rows: &[(&str, &[HeightError])]) {
    println!("\nAerial points' height error (triangulated − true, m): all points; the per-panorama median (the part");
    println!("the points of one panorama share); the spread inside a panorama around its median; the reported σ_H.");
    println!("Spread = 1.4826 · MAD.\n");
    println!(
        "| profile | points | median | spread | panoramas | spread of panorama medians | spread within panoramas | median σ_H | within 3σ_H |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (name, points) in rows {
        let errors: Vec<f64> = points.iter().map(|p| p.1).collect();
        let mut ids: Vec<&str> = points.iter().map(|p| p.0.as_str()).collect();
        ids.dedup();
        let per_pano: Vec<(f64, Vec<f64>)> = ids
            .iter()
            .map(|id| {
                let e: Vec<f64> = points.iter().filter(|p| p.0 == *id).map(|p| p.1).collect();
                (median(&e), e)
            })
            .collect();
        let medians: Vec<f64> = per_pano.iter().map(|p| p.0).collect();
        let within: Vec<f64> = per_pano.iter().flat_map(|(m, e)| e.iter().map(move |x| x - m)).collect();
        let sigmas: Vec<f64> = points.iter().map(|p| p.2).collect();
        let inside = points.iter().filter(|p| p.1.abs() <= 3.0 * p.2).count();
        println!(
            "| {name} | {} | {:+.2} | {:.2} | {} | {:.2} | {:.2} | {:.2} | {:.1} % |",
            points.len(),
            median(&errors),
            spread(&errors),
            ids.len(),
            spread(&medians),
            spread(&within),
            median(&sigmas),
            100.0 * inside as f64 / points.len().max(1) as f64
        );
    }
}

/// The median of `v` (NaN when empty), on a copy.
fn median(v: &[f64]) -> f64 {
    metrics::median(&mut v.to_vec()).unwrap_or(f64::NAN)
}

/// 1.4826 · median absolute deviation (σ of a normal distribution).
fn spread(v: &[f64]) -> f64 {
    let m = median(v);
    1.4826 * median(&v.iter().map(|x| (x - m).abs()).collect::<Vec<_>>())
}
