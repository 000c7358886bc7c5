//! The same problem through plumbline's adjustment and GTSAM (PyPI `gtsam`, Levenberg–Marquardt, by
//! `benches/gtsam_compare.py`): agreement of the node corrections and the time ratio. Poles + DG chain only
//! (the export leaves ties and GNSS out), plain least squares on both sides (no Huber, no snooping).
//! Run: `pip install gtsam` once, then `cargo bench -p plumbline-adjustment --bench gtsam [-- sizes...]`.
//! Without gtsam the table says so; nothing in CI depends on it.
#![allow(clippy::unwrap_used)]

use plumbline_fixtures::adjustment;

use std::process::Command;
use std::time::Instant;

use faer::Par;
use plumbline_adjustment::{AdjustmentConfig, AdjustmentInput, ObservationSetV1, adjust, export};
use rand::SeedableRng;

fn main() {
    let sizes: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let sizes = if sizes.is_empty() { vec![2_000, 20_000] } else { sizes };
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/gtsam_compare.py");
    let dir = std::env::temp_dir().join(format!("plumbline-gtsam-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    println!(
        "| epochs | nodes | poles | plumbline s | GTSAM s | GTSAM / plumbline | max |Δ position| m | max |Δ rotation| rad | GTSAM iterations |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for n in sizes {
        let s = adjustment::scene(n as f64 / 10.0 - 0.1, 10.0, None, adjustment::drift_and_jump(f64::INFINITY), 0.05);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let obs = ObservationSetV1 { poles: adjustment::poles(&s, 10, 0.03, 0.05, &mut rng), ..Default::default() };
        let m = adjustment::mount();
        let input = AdjustmentInput { trajectory: &s.dg, observations: &obs, mount: &m, weak_links: &[] };
        let config = AdjustmentConfig { huber: None, snooping: None, tolerance: 1e-9, ..AdjustmentConfig::default() };
        let t = Instant::now();
        let ours = adjust(&input, &config, Par::Seq).unwrap();
        let t_ours = t.elapsed().as_secs_f64();
        let problem = dir.join(format!("problem-{n}.json"));
        let solution = dir.join(format!("solution-{n}.json"));
        std::fs::write(&problem, serde_json::to_vec(&export(&input, &config)).unwrap()).unwrap();
        let run = Command::new("python3").arg(script).arg(&problem).arg(&solution).output();
        if !run.as_ref().is_ok_and(|o| o.status.success()) {
            if let Ok(o) = &run {
                eprintln!("{}", String::from_utf8_lossy(&o.stderr));
            }
            println!(
                "| {n} | {} | {} | {t_ours:.2} | — (python3 + gtsam not available) | | | | |",
                ours.nodes.len(),
                obs.poles.len()
            );
            continue;
        }
        let theirs: serde_json::Value = serde_json::from_slice(&std::fs::read(&solution).unwrap()).unwrap();
        let nodes = theirs["nodes"].as_array().unwrap();
        assert_eq!(nodes.len(), ours.nodes.len());
        let (mut dp, mut dr) = (0.0f64, 0.0f64);
        for (a, b) in ours.nodes.iter().zip(nodes) {
            let b: Vec<f64> = b.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
            for c in 0..3 {
                dp = dp.max((a.position[c] - b[c]).abs());
                dr = dr.max((a.rotation[c] - b[c + 3]).abs());
            }
        }
        let t_gtsam = theirs["seconds"].as_f64().unwrap();
        println!(
            "| {n} | {} | {} | {t_ours:.3} | {t_gtsam:.3} | {:.1} | {dp:.2e} | {dr:.2e} | {} |",
            ours.nodes.len(),
            obs.poles.len(),
            t_gtsam / t_ours,
            theirs["iterations"]
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
