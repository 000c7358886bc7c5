#![allow(clippy::unwrap_used)]
//! The adjuster's pure path on a simulated deep-canyon drive: merged tile outputs corrected by the global
//! adjustment, a wrong control point rejected and reported, broken observations skipped and reported.

use plumbline_campaign::{SkipReason, Stage};
use plumbline_fixtures::adjuster;

use plumbline_adjuster::{AdjusterConfig, build_report, merge, panorama_mount, solve};
use plumbline_geo::metrics::compare;

/// The DG error of a deep canyon (decimetres, multipath jumps) falls by a large factor: pooled over six
/// seeds the 2D RMSE drops at least fourfold, to below a decimetre, and no seed improves by less than half.
/// Ties with aerial coordinates, pole CUPTs, the image motions' weak links and standstills all reach the
/// adjustment; without observations or without applying the corrections nothing changes (factor 1).
#[test]
fn adjustment_reduces_the_dg_error() {
    let (mut before2, mut after2) = (0.0, 0.0);
    for seed in 1..=6 {
        let s = adjuster::scenario(seed);
        let c = adjuster::campaign(&s, "/tmp/unused/");
        let merged = merge(&adjuster::tiles(&s, &s.poles));
        assert!(merged.observations.ties.len() > 100 && merged.observations.poles.len() > 20);
        assert_eq!(merged.motions.len(), s.motions.len());
        let solved = solve(&s.dg, &merged, &panorama_mount(&c.manifest), &AdjusterConfig::default()).unwrap();
        assert!(!solved.weak_links.is_empty(), "seed {seed}: no DG jump flagged");
        assert_eq!(solved.weak_links, solved.consistency.weak_links());
        assert_eq!(solved.corrected.len(), s.dg.len());
        let before = compare(&s.dg, &s.truth).unwrap().rmse_2d;
        let after = compare(&solved.corrected, &s.truth).unwrap().rmse_2d;
        println!("seed {seed}: 2D RMSE DG {before:.3} m, adjusted {after:.3} m");
        assert!(before > 0.15, "seed {seed}: the canyon DG error should be decimetres, got {before:.3} m");
        assert!(after < before / 2.0, "seed {seed}: adjusted {after:.3} m vs DG {before:.3} m");
        (before2, after2) = (before2 + before * before, after2 + after * after);
    }
    let (before, after) = ((before2 / 6.0).sqrt(), (after2 / 6.0).sqrt());
    println!("pooled: 2D RMSE DG {before:.3} m, adjusted {after:.3} m");
    assert!(after < 0.1 && after < before / 4.0, "pooled: adjusted {after:.3} m vs DG {before:.3} m");
}

/// A pole update 1 m off (the best-measured street light's cadastre entry moved by (0.6, 0.8) m) is
/// rejected by data snooping and listed in the report's `rejected` with its id, epoch and |w| beyond the
/// critical value; a pole update with a NaN coordinate is skipped and listed under the adjustment's skips.
#[test]
fn a_wrong_pole_is_rejected_and_reported() {
    let s = adjuster::scenario(3);
    let mut poles = s.poles.clone();
    let wrong = adjuster::best_light(&poles);
    poles[wrong].cadastre[0] += 0.6;
    poles[wrong].cadastre[1] += 0.8;
    let broken = (wrong + poles.len() / 2) % poles.len();
    poles[broken].observed[1] = f64::NAN;
    let c = adjuster::campaign(&s, "/tmp/unused/");
    let merged = merge(&adjuster::tiles(&s, &poles));
    let config = AdjusterConfig::default();
    let solved = solve(&s.dg, &merged, &panorama_mount(&c.manifest), &config).unwrap();
    let report = build_report(&c, &merged, &solved, c.reference.as_ref(), &[]);

    let (id, time) = (&poles[wrong].cadastre_id, poles[wrong].time);
    let hit = report.rejected.iter().find(|r| r.kind == "pole" && &r.id == id && r.time == time);
    let hit = hit.unwrap_or_else(|| panic!("wrong pole {id} at {time} not in {:?}", report.rejected));
    let critical = config.adjustment.snooping.unwrap().critical_value;
    assert!(hit.w_test.abs() > critical, "|w| {} ≤ {critical}", hit.w_test);
    // Only a handful of the hundreds of correct observations may be rejected alongside (α = 0.1 %).
    let poles_rejected = report.rejected.iter().filter(|r| r.kind == "pole").count();
    assert!(poles_rejected <= 1 + poles.len() / 100, "{poles_rejected} poles rejected of {}", poles.len());

    let bad = &poles[broken].cadastre_id;
    let skipped = report.skipped.iter().find(|k| k.stage == Stage::Adjustment && k.item == format!("pole {bad}"));
    assert!(skipped.is_some_and(|k| k.reason == SkipReason::BadField("observed".into())), "{:?}", report.skipped);
    assert_eq!(report.summary.pole_updates, poles.len() - 1);
}

/// The merge groups the ties with aerial coordinates by the aerial frames their first panorama was matched
/// in (here a new frame pair every 20 s of drive), and the adjustment estimates one height bias per group:
/// the simulated aerial heights carry no shared error, so every bias is zero within 3σ.
#[test]
fn aerial_frame_sets_reach_the_adjustment_as_height_biases() {
    let s = adjuster::scenario(3);
    let c = adjuster::campaign(&s, "/tmp/unused/");
    let merged = merge(&adjuster::tiles(&s, &s.poles));
    let sets = &merged.observations.aerial_frame_sets;
    let with_aerial = merged.observations.ties.iter().filter(|t| t.aerial.is_some()).count();
    assert!(sets.len() >= 2, "{} sets", sets.len());
    assert_eq!(sets.iter().map(|f| f.ties.len()).sum::<usize>(), with_aerial, "every aerial tie in one set");
    for set in sets {
        let n: i64 = set.frames[0].strip_prefix("aerial").unwrap().parse().unwrap();
        assert_eq!(set.frames, [format!("aerial{n:04}"), format!("aerial{:04}", n + 1)]);
        for id in &set.ties {
            let tie = merged.observations.ties.iter().find(|t| &t.id == id).unwrap();
            assert_eq!(((tie.rays[0].time / adjuster::FRAME_SPAN).floor() as i64), n, "{id:?} in {:?}", set.frames);
        }
    }
    let solved = solve(&s.dg, &merged, &panorama_mount(&c.manifest), &AdjusterConfig::default()).unwrap();
    let biases = &solved.adjustment.height_biases;
    assert_eq!(biases.len(), sets.len());
    for b in biases {
        assert!(b.points > 0 && b.sigma > 0.0 && b.sigma < b.prior_sigma, "{b:?}");
        assert!(b.bias.abs() < 3.0 * b.sigma, "{b:?}");
    }
    // The report carries them, one line per set in the adjustment's order.
    let report = build_report(&c, &merged, &solved, None, &[]);
    assert_eq!(report.height_biases.len(), biases.len());
    for (line, b) in report.height_biases.iter().zip(biases) {
        assert_eq!((&line.frames, line.points), (&b.frames, b.points));
        assert_eq!([line.bias_m, line.sigma_m, line.prior_sigma_m], [b.bias, b.sigma, b.prior_sigma]);
    }
}
