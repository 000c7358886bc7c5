//! The image-derived motion table of `plumbline-eval registration` (Jende et al. 2017 §3.3, Cazzaniga et al. 2007 §4.1): the
//! share of pairs with a motion, its error against the true motion (median and 95 % of the horizontal error and
//! of the heading-change error), the share within 3σ, the median σ, and the DG motion's error beside it.

use plumbline_geo::metrics;
use plumbline_geo::{Attitude, Trajectory, TrajectoryRecord, ValidationLimits};
use plumbline_navigation::{ConsistencyConfig, ImageMotion, check_consistency};
use plumbline_registration::mm::Panorama;

use plumbline_fixtures::registration::MotionCheck;

/// A DG motion this far off the truth (horizontally, m) is a jump the check should flag.
const JUMP_M: f64 = 0.05;

/// Per motion: flagged by `check_consistency` (default configuration) against the DG poses of the
/// panoramas as a trajectory.
pub fn flags(panoramas: &[Panorama], motions: &[ImageMotion]) -> Vec<bool> {
    let mut records: Vec<TrajectoryRecord> = panoramas
        .iter()
        .map(|p| TrajectoryRecord {
            time: p.time,
            position: p.pose.translation,
            attitude: Attitude::from_rotation(&p.pose.rotation),
            std: None,
        })
        .collect();
    records.sort_by(|a, b| a.time.total_cmp(&b.time));
    records.dedup_by(|a, b| a.time == b.time);
    let dg = Trajectory::new(records, &ValidationLimits::default()).expect("DG trajectory");
    let report = check_consistency(&dg, motions, &ConsistencyConfig::default()).expect("consistency check");
    let mut flagged = vec![false; motions.len()];
    report.flags.iter().for_each(|f| flagged[f.pair] = true);
    flagged
}

/// Type-7 quantile `q` of `v` (NaN when empty).
fn quantile(mut v: Vec<f64>, q: f64) -> f64 {
    metrics::quantile(&mut v, q).unwrap_or(f64::NAN)
}

/// "median / 95 %" of a series, scaled.
fn spread(v: Vec<f64>, scale: f64) -> String {
    format!("{:.1} / {:.1}", scale * quantile(v.clone(), 0.5), scale * quantile(v, 0.95))
}

/// Every pair's errors split along and across the true displacement (mm), heading error (mrad), σ.
pub fn print_pairs(name: &str, checks: &[MotionCheck]) {
    for c in checks {
        let len = c.truth[0].hypot(c.truth[1]).max(1e-9);
        let (f, r) = ([c.truth[0] / len, c.truth[1] / len], [c.truth[1] / len, -c.truth[0] / len]);
        let along = |e: &[f64; 3]| 1e3 * (e[0] * f[0] + e[1] * f[1]);
        let across = |e: &[f64; 3]| 1e3 * (e[0] * r[0] + e[1] * r[1]);
        println!(
            "{name}: {len:.2} m, image along {:+.1} across {:+.1} Δψ {:+.2} (σ {:.1} / {:.2}); DG along {:+.1} across {:+.1} Δψ {:+.2}",
            along(&c.error),
            across(&c.error),
            1e3 * c.error[2],
            1e3 * c.std[0],
            1e3 * c.std[2],
            along(&c.dg_error),
            across(&c.dg_error),
            1e3 * c.dg_error[2]
        );
    }
}

/// Print one row per profile: (name, panoramas, motion checks, flagged by the consistency check).
pub fn print_table(rows: &[(&str, usize, &[MotionCheck], &[bool])]) {
    println!("\nImage-derived motion between neighbouring panoramas (KAZE similarity, also when it disagreed with");
    println!("DG) against the truth; errors as median / 95 %; horizontal in mm, heading change in mrad.\n");
    println!(
        "| profile | pairs with motion | image error (mm) | image Δψ error (mrad) | within 3σ | median σ (mm / mrad) | DG error (mm) | DG Δψ error (mrad) | DG off > {:.0} cm: flagged | others flagged |",
        JUMP_M * 100.0
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (name, images, checks, flagged) in rows {
        let horizontal = |e: &[f64; 3]| e[0].hypot(e[1]);
        let within = checks.iter().filter(|c| c.within(3.0)).count();
        let jump = |c: &MotionCheck| horizontal(&c.dg_error) > JUMP_M;
        let jumps = checks.iter().filter(|c| jump(c)).count();
        let caught = checks.iter().zip(flagged.iter()).filter(|(c, f)| jump(c) && **f).count();
        let false_flags = checks.iter().zip(flagged.iter()).filter(|(c, f)| !jump(c) && **f).count();
        println!(
            "| {name} | {} / {images} | {} | {} | {:.0} % | {:.1} / {:.2} | {} | {} | {caught} of {jumps} | {false_flags} of {} |",
            checks.len(),
            spread(checks.iter().map(|c| horizontal(&c.error)).collect(), 1e3),
            spread(checks.iter().map(|c| c.error[2].abs()).collect(), 1e3),
            100.0 * within as f64 / checks.len().max(1) as f64,
            1e3 * quantile(checks.iter().map(|c| c.std[0]).collect(), 0.5),
            1e3 * quantile(checks.iter().map(|c| c.std[2]).collect(), 0.5),
            spread(checks.iter().map(|c| horizontal(&c.dg_error)).collect(), 1e3),
            spread(checks.iter().map(|c| c.dg_error[2].abs()).collect(), 1e3),
            checks.len() - jumps,
        );
    }
}
