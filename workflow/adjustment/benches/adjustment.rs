//! Time and memory of the adjustment against problem size: synthetic drives of 10 k, 100 k and 1 M epochs
//! (10 Hz, one node per epoch) with a pole CUPT at every 10th epoch. Run with
//! `cargo bench -p plumbline-adjustment --bench adjustment [-- sizes...]`; prints a table. Peak RSS is the
//! process's VmHWM after each size (sizes run in increasing order, so it is that size's peak).
#![allow(clippy::unwrap_used)]

use plumbline_fixtures::adjustment;

use std::time::Instant;

use faer::Par;
use plumbline_adjustment::{AdjustmentConfig, AdjustmentInput, ObservationSetV1, adjust};
use rand::SeedableRng;

/// Peak resident set size of this process so far (VmHWM), GiB.
fn peak_gib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let kib = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(f64::NAN);
    kib / (1024.0 * 1024.0)
}

fn main() {
    let sizes: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let sizes = if sizes.is_empty() { vec![10_000, 100_000, 1_000_000] } else { sizes };
    // PLUMBLINE_BENCH_THREADS=1 for the sequential run; default: every core.
    let threads = std::env::var("PLUMBLINE_BENCH_THREADS").ok().and_then(|v| v.parse().ok()).unwrap_or(0);
    let par = if threads == 1 { Par::Seq } else { Par::rayon(threads) };
    println!("threads: {}", par.degree());
    let header = [
        "epochs",
        "observations",
        "build s",
        "symbolic s",
        "numeric s (count)",
        "solve s",
        "selected inverse s",
        "total s",
        "iterations",
        "rms before m",
        "rms after m",
        "peak RSS GiB",
    ];
    println!("| {} |", header.join(" | "));
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for n in sizes {
        let t0 = Instant::now();
        let s = adjustment::scene(n as f64 / 10.0 - 0.1, 10.0, None, adjustment::drift_and_jump(f64::INFINITY), 0.05);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let obs = ObservationSetV1 { poles: adjustment::poles(&s, 10, 0.03, 0.05, &mut rng), ..Default::default() };
        let build = t0.elapsed().as_secs_f64();
        let m = adjustment::mount();
        let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: &[] };
        let config = AdjustmentConfig { node_spacing: Some(0.1), min_node_gap: 0.05, ..AdjustmentConfig::default() };
        let t1 = Instant::now();
        let result = adjust(&input, &config, par).unwrap();
        let total = t1.elapsed().as_secs_f64();
        let corrected = result.apply(&s.dg).unwrap();
        let before = adjustment::rms(&adjustment::horizontal_errors(&s.dg, &s.truth));
        let after = adjustment::rms(&adjustment::horizontal_errors(&corrected, &s.truth));
        let t = result.timings;
        print!("| {n} | {} | {build:.2} | {:.2} | ", obs.poles.len(), t.symbolic.as_secs_f64());
        print!("{:.2} ({}) | {:.2} | ", t.numeric.as_secs_f64(), t.factorizations, t.solve.as_secs_f64());
        print!("{:.2} | {total:.2} | {} | ", t.selected_inverse.as_secs_f64(), result.iterations);
        println!("{before:.3} | {after:.4} | {:.2} |", peak_gib());
    }
}
