//! The ground texture: deterministic, anti-aliased by the footprint, with markings where the streets say
//! and none on unmarked streets, and differences between the epochs.
#![allow(clippy::unwrap_used)]

use plumbline_synth::texture::Texture;
use plumbline_synth::world::polyline;
use plumbline_synth::world::{Epoch, Preset, StreetClass, World, WorldConfig};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn world(seed: u64) -> World {
    World::generate(&WorldConfig::new(Preset::District, seed)).unwrap()
}

fn lum(c: [f32; 3]) -> f32 {
    (c[0] + c[1] + c[2]) / 3.0
}

/// A point at station `s`, offset `t` (left positive) of a street.
fn at(w: &World, street: usize, s: f64, t: f64) -> [f64; 2] {
    let st = &w.streets[street];
    let (p, tan) = polyline::point_at(&st.points, &st.cum, s);
    [p[0] - tan[1] * t, p[1] + tan[0] * t]
}

/// True when no other street's carriageway (with a metre of margin) reaches the point.
fn own_carriageway(w: &World, sid: usize, p: [f64; 2]) -> bool {
    w.streets
        .iter()
        .enumerate()
        .all(|(k, o)| k == sid || polyline::nearest(&o.points, &o.cum, p).t.abs() > o.carriageway() / 2.0 + 1.0)
}

#[test]
fn deterministic_and_in_range() {
    let (a, b) = (world(1), world(1));
    let (ta, tb) = (Texture::new(&a, Epoch::Mobile), Texture::new(&b, Epoch::Mobile));
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let (lo, hi) = a.bounds();
    for _ in 0..5000 {
        let (e, n) = (rng.random_range(lo[0]..hi[0]), rng.random_range(lo[1]..hi[1]));
        let fp = rng.random_range(0.005..1.0);
        let c = ta.albedo(e, n, fp);
        assert_eq!(c, tb.albedo(e, n, fp));
        assert!(c.iter().all(|v| (0.0..=1.0).contains(v)), "{c:?}");
    }
}

#[test]
fn coarse_footprint_equals_the_average_of_fine_samples() {
    // The texture seen through a 0.4 m footprint must equal the mean of 0.01 m samples over that square;
    // a point sample (no filtering) misses edges of lines, slabs and kerbs by far more.
    let w = world(2);
    let tex = Texture::new(&w, Epoch::Mobile);
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let (fp, k) = (0.4, 20);
    let (mut err_aa, mut err_point, mut count) = (0.0f64, 0.0f64, 0);
    while count < 300 {
        let sid = rng.random_range(0..w.streets.len());
        let st = &w.streets[sid];
        if !st.markings {
            continue;
        }
        let s = rng.random_range(20.0..st.length() - 20.0);
        let t = rng.random_range(-st.half_corridor()..st.half_corridor());
        let p = at(&w, sid, s, t);
        let mut mean = 0.0f64;
        for i in 0..k {
            for j in 0..k {
                let dx = (f64::from(i) + 0.5) / f64::from(k) - 0.5;
                let dy = (f64::from(j) + 0.5) / f64::from(k) - 0.5;
                mean += f64::from(lum(tex.albedo(p[0] + dx * fp, p[1] + dy * fp, fp / f64::from(k))));
            }
        }
        mean /= f64::from(k * k);
        err_aa += (f64::from(lum(tex.albedo(p[0], p[1], fp))) - mean).abs();
        err_point += (f64::from(lum(tex.albedo(p[0], p[1], 1e-3))) - mean).abs();
        count += 1;
    }
    let (aa, point) = (err_aa / 300.0, err_point / 300.0);
    assert!(aa < 0.012, "filtered error {aa}");
    assert!(aa < 0.6 * point, "filtered {aa} vs point sample {point}");
}

#[test]
fn lines_where_marked_and_none_on_unmarked_streets() {
    for seed in 0..3 {
        let w = world(seed);
        let tex = Texture::new(&w, Epoch::Mobile);
        for (sid, st) in w.streets.iter().enumerate() {
            let (a, b) =
                (w.junctions[st.from as usize].radius + 6.0, st.length() - w.junctions[st.to as usize].radius - 6.0);
            let samples: Vec<f64> = (0..400).map(|i| a + (b - a) * f64::from(i) / 399.0).collect();
            let half = st.carriageway() / 2.0;
            let brightest_road = samples
                .iter()
                .flat_map(|&s| (0..30).map(move |k| (s, -half + 0.2 + (2.0 * half - 0.4) * f64::from(k) / 29.0)))
                .filter(|&(s, t)| own_carriageway(&w, sid, at(&w, sid, s, t)))
                .map(|(s, t)| lum(tex.albedo(at(&w, sid, s, t)[0], at(&w, sid, s, t)[1], 0.02)))
                .fold(0.0f32, f32::max);
            if !st.markings {
                assert!(brightest_road < 0.4, "unmarked street {sid}: {brightest_road}");
                continue;
            }
            // Centre line: solid double on arterials (at ±0.15 m), dashed 3 m on / 6 m off elsewhere.
            let c = if st.class == StreetClass::Arterial { 0.15 } else { 0.0 };
            let on: Vec<bool> = samples
                .iter()
                .map(|&s| lum(tex.albedo(at(&w, sid, s, c)[0], at(&w, sid, s, c)[1], 0.02)) > 0.38)
                .collect();
            let share = on.iter().filter(|&&x| x).count() as f64 / on.len() as f64;
            if st.class == StreetClass::Arterial {
                assert!(share > 0.97, "solid line on {sid}: {share}");
            } else {
                // Manholes or repairs may hide bits of a dash.
                assert!((0.25..0.42).contains(&share), "dashed line on {sid}: {share}");
            }
            // Between lines: asphalt.
            let mid = -st.lane_width / 2.0 + 0.6;
            let bright = samples
                .iter()
                .filter(|&&s| lum(tex.albedo(at(&w, sid, s, mid)[0], at(&w, sid, s, mid)[1], 0.02)) > 0.38);
            assert!(bright.count() < 12);
        }
    }
}

#[test]
fn zebra_crossings_alternate_with_a_one_metre_period() {
    let w = world(4);
    let tex = Texture::new(&w, Epoch::Mobile);
    let mut found = 0;
    for (sid, st) in w.streets.iter().enumerate().filter(|(_, s)| s.markings) {
        let s = w.junctions[st.from as usize].radius + 1.8;
        let half = st.carriageway() / 2.0;
        let profile: Vec<bool> = (0..400)
            .map(|k| -half + 2.0 * half * f64::from(k) / 400.0)
            .map(|t| lum(tex.albedo(at(&w, sid, s, t)[0], at(&w, sid, s, t)[1], 0.02)) > 0.4)
            .collect();
        let rises = profile.windows(2).filter(|p| !p[0] && p[1]).count();
        if rises as f64 >= 2.0 * half - 2.0 {
            found += 1;
            assert!(rises as f64 <= 2.0 * half + 1.0);
        }
    }
    assert!(found >= 3, "{found}");
}

#[test]
fn aerial_epoch_wears_some_markings_and_keeps_most() {
    let w = world(5);
    let (m, a) = (Texture::new(&w, Epoch::Mobile), Texture::new(&w, Epoch::Aerial));
    let (mut same, mut weaker, mut total) = (0, 0, 0);
    for (sid, st) in w.streets.iter().enumerate().filter(|(_, s)| s.markings) {
        let c = if st.class == StreetClass::Arterial { 0.15 } else { 0.0 };
        for k in 0..200 {
            let s = 20.0 + (st.length() - 40.0) * f64::from(k) / 199.0;
            let p = at(&w, sid, s, c);
            let (lm, la) = (lum(m.albedo(p[0], p[1], 0.02)), lum(a.albedo(p[0], p[1], 0.02)));
            if lm > 0.5 {
                total += 1;
                if (lm - la).abs() < 0.02 {
                    same += 1;
                } else if la < lm - 0.1 {
                    weaker += 1;
                }
            }
        }
    }
    assert!(total > 500, "{total}");
    assert!(same as f64 > 0.4 * total as f64 && weaker > 0, "{same} {weaker} {total}");
}

#[test]
fn some_dashes_were_repainted_at_another_phase() {
    // Samples on dashed centre lines bright in the aerial epoch but bare asphalt at the mobile epoch.
    let mut moved = 0;
    for seed in 5..9 {
        let w = world(seed);
        let (m, a) = (Texture::new(&w, Epoch::Mobile), Texture::new(&w, Epoch::Aerial));
        for (sid, st) in w.streets.iter().enumerate().filter(|(_, s)| s.markings && s.class != StreetClass::Arterial) {
            let (lo, hi) =
                (w.junctions[st.from as usize].radius + 6.0, st.length() - w.junctions[st.to as usize].radius - 6.0);
            for k in 0..300 {
                let p = at(&w, sid, lo + (hi - lo) * f64::from(k) / 299.0, 0.0);
                if lum(a.albedo(p[0], p[1], 0.02)) > 0.5 && lum(m.albedo(p[0], p[1], 0.02)) < 0.3 {
                    moved += 1;
                }
            }
        }
    }
    assert!(moved > 20, "{moved}");
}
