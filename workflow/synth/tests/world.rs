//! The generated world: deterministic, with the street classes, objects and sizes the issue asks for, and
//! geometrically sane (nothing stands on the carriageway, no building in a street), checked by brute force;
//! the changes between the epochs (crowns spreading over the road in the aerial flight, pedestrians).
#![allow(clippy::unwrap_used)]

use nalgebra::Vector3;
use plumbline_synth::world::polyline::{self, P2};
use plumbline_synth::world::{
    Epoch, EpochChanges, PoleClass, Preset, Street, StreetClass, Surface, World, WorldConfig,
};

fn world(preset: Preset, seed: u64) -> World {
    World::generate(&WorldConfig::new(preset, seed)).unwrap()
}

/// Offset of `p` from the centreline of every street, brute force over all segments.
fn offsets(w: &World, p: P2) -> Vec<(&Street, f64)> {
    w.streets.iter().map(|s| (s, polyline::nearest(&s.points, &s.cum, p).t.abs())).collect()
}

#[test]
fn same_seed_same_world_other_seed_other_world() {
    assert_eq!(world(Preset::Tiny, 7), world(Preset::Tiny, 7));
    assert_ne!(world(Preset::Tiny, 7).poles, world(Preset::Tiny, 8).poles);
}

#[test]
fn sizes_of_the_presets() {
    for seed in 0..4 {
        let (t, d) = (world(Preset::Tiny, seed), world(Preset::District, seed));
        let (lt, ld) = (t.street_length(), d.street_length());
        assert!((400.0..1000.0).contains(&lt), "tiny {lt}");
        assert!((2000.0..3500.0).contains(&ld), "district {ld}");
        let c = t.config.clone();
        let (lo, hi) = t.bounds();
        assert!(lo[0] < c.origin_east && hi[0] > c.origin_east && lo[1] < c.origin_north && hi[1] > c.origin_north);
    }
}

#[test]
fn street_classes_widths_and_shapes() {
    for seed in 0..6 {
        let w = world(Preset::District, seed);
        let widths = |c: StreetClass| w.streets.iter().filter(move |s| s.class == c).map(|s| 2.0 * s.half_corridor());
        assert!(widths(StreetClass::Alley).count() >= 1);
        assert!(widths(StreetClass::Alley).all(|x| (4.0..=6.0).contains(&x)));
        assert!(widths(StreetClass::Arterial).count() >= 2);
        assert!(
            widths(StreetClass::Arterial).all(|x| (20.0..=30.0).contains(&x)),
            "{:?}",
            widths(StreetClass::Arterial).collect::<Vec<_>>()
        );
        assert!(w.streets.iter().any(|s| s.points.len() > 2), "a curved street");
        assert!(w.streets.iter().any(|s| s.class != StreetClass::Alley && !s.markings), "a street without markings");
        // A diagonal: its direction differs from both grid directions by more than 20°.
        let dirs: Vec<f64> = w
            .streets
            .iter()
            .map(|s| {
                let (a, b) = (s.points[0], s.points[s.points.len() - 1]);
                (b[1] - a[1]).atan2(b[0] - a[0]).rem_euclid(std::f64::consts::FRAC_PI_2)
            })
            .collect();
        let base = dirs[0];
        assert!(dirs.iter().any(|d| {
            let diff = (d - base).rem_euclid(std::f64::consts::FRAC_PI_2);
            diff.min(std::f64::consts::FRAC_PI_2 - diff) > 20f64.to_radians()
        }));
    }
}

#[test]
fn poles_have_realistic_sizes_and_stand_on_sidewalks() {
    for seed in 0..4 {
        let w = world(Preset::District, seed);
        let count = |c: PoleClass| w.poles.iter().filter(|p| p.class == c).count();
        assert!(count(PoleClass::StreetLight) > 20 && count(PoleClass::SignPost) > 5);
        assert!(count(PoleClass::TrafficLight) >= 4 && count(PoleClass::Tree) > 30);
        for p in &w.poles {
            let ok = match p.class {
                PoleClass::StreetLight | PoleClass::TrafficLight => (0.12..=0.2).contains(&p.diameter),
                PoleClass::SignPost => (0.06..=0.08).contains(&p.diameter),
                PoleClass::Tree => {
                    (0.2..=0.6).contains(&p.diameter) && (1.0..=4.0).contains(&p.lean_angle().to_degrees())
                }
            };
            assert!(ok, "{p:?}");
            if p.class != PoleClass::Tree {
                assert_eq!(p.lean, [0.0, 0.0]);
            }
            for (s, t) in offsets(&w, p.base) {
                assert!(t > s.carriageway() / 2.0 + s.kerb, "pole {} on the carriageway of street {}", p.id, s.id);
            }
            for b in &w.buildings {
                assert!(!b.shape.contains(p.base, p.diameter / 2.0), "pole {} inside a building", p.id);
            }
        }
        // Traffic lights stand near junctions; tree spacing along kerbs is realistic (≥ 1.5 m apart).
        for p in w.poles.iter().filter(|p| p.class == PoleClass::TrafficLight) {
            assert!(w.junctions.iter().any(|j| polyline::dist(j.pos, p.base) < j.radius + 8.0));
        }
        for (i, a) in w.poles.iter().enumerate() {
            for b in &w.poles[i + 1..] {
                assert!(polyline::dist(a.base, b.base) > 1.5);
            }
        }
    }
}

#[test]
fn buildings_stay_out_of_the_streets_and_have_city_heights() {
    for seed in 0..3 {
        let w = world(Preset::District, seed);
        assert!(w.buildings.len() > 50);
        for b in &w.buildings {
            assert!((10.0..=40.0).contains(&b.shape.height));
            // Dense sampling of the whole footprint: no sample lies inside any street corridor.
            let c = b.shape.corners();
            for i in 0..=10 {
                for j in 0..=10 {
                    let (u, v) = (f64::from(i) / 10.0, f64::from(j) / 10.0);
                    let p = [
                        c[0][0] + u * (c[1][0] - c[0][0]) + v * (c[3][0] - c[0][0]),
                        c[0][1] + u * (c[1][1] - c[0][1]) + v * (c[3][1] - c[0][1]),
                    ];
                    for (s, t) in offsets(&w, p) {
                        assert!(t > s.half_corridor() - 0.6, "building in street {} ({t} m)", s.id);
                    }
                }
            }
        }
    }
}

#[test]
fn parked_cars_differ_between_epochs_and_leave_the_lanes_free() {
    let w = world(Preset::District, 3);
    let both = w.cars.iter().filter(|c| c.in_mobile && c.in_aerial).count();
    let only_mobile = w.cars.iter().filter(|c| c.in_mobile && !c.in_aerial).count();
    let only_aerial = w.cars.iter().filter(|c| !c.in_mobile && c.in_aerial).count();
    assert!(both > 10 && only_mobile > 10 && only_aerial > 10, "{both} {only_mobile} {only_aerial}");
    for c in &w.cars {
        let (s, t) = offsets(&w, c.shape.center).into_iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        let lanes = f64::from(s.lanes) * s.lane_width;
        assert!(
            t - c.shape.half[1] >= lanes - 1e-9 && t + c.shape.half[1] <= s.carriageway() / 2.0 + 1e-9,
            "{c:?} street {} t {t} lanes {lanes} cw {}",
            s.id,
            s.carriageway()
        );
    }
}

#[test]
fn bad_config_is_rejected_naming_the_field() {
    let mut c = WorldConfig::new(Preset::Tiny, 1);
    c.origin_north = f64::NAN;
    let e = World::generate(&c).unwrap_err().to_string();
    assert!(e.contains("origin_north"), "{e}");
}

/// A world of `preset` and `seed` with `changes`.
fn changed(preset: Preset, seed: u64, changes: EpochChanges) -> World {
    World::generate(&WorldConfig { changes, ..WorldConfig::new(preset, seed) }).unwrap()
}

/// Share of the carriageway (sampled every 0.5 m along and across every street, junction areas aside) that a
/// vertical ray from 500 m finds under a tree crown at `epoch`.
fn carriageway_under_crowns(w: &World, epoch: Epoch) -> f64 {
    let (mut crown, mut all) = (0usize, 0usize);
    for st in &w.streets {
        let half = st.carriageway() / 2.0;
        let mut s = 12.0;
        while s < st.length() - 12.0 {
            let (p, tan) = polyline::point_at(&st.points, &st.cum, s);
            let mut t = -half + 0.25;
            while t < half {
                let (e, n) = (p[0] - tan[1] * t, p[1] + tan[0] * t);
                let top = Vector3::new(e, n, w.config.ground_height + 500.0);
                let hit = w.trace(&top, &-Vector3::z(), 1000.0, epoch).unwrap();
                crown += usize::from(matches!(hit.surface, Surface::Crown(_)));
                all += 1;
                t += 0.5;
            }
            s += 0.5;
        }
    }
    crown as f64 / all as f64
}

#[test]
fn crowns_spread_over_the_road_in_the_aerial_flight_only() {
    let spread = EpochChanges { crown_spread: 1.6, ..EpochChanges::NONE };
    let (plain, wide) = (world(Preset::Tiny, 2), changed(Preset::Tiny, 2, spread));
    assert_eq!((&plain.poles, &plain.cars, &plain.buildings), (&wide.poles, &wide.cars, &wide.buildings));
    let before = carriageway_under_crowns(&plain, Epoch::Aerial);
    let after = carriageway_under_crowns(&wide, Epoch::Aerial);
    // The drive sees the same crowns as before.
    assert_eq!(carriageway_under_crowns(&wide, Epoch::Mobile), carriageway_under_crowns(&plain, Epoch::Mobile));
    assert!(after > 2.0 * before && after > 0.02, "carriageway under crowns: {before:.4} → {after:.4}");
    // One tree exactly: the crown's edge moves out by (spread − 1) × r at the crown's widest height.
    let tree = wide.poles.iter().find(|p| p.crown > 0.0).unwrap();
    let centre = tree.crown_center(wide.config.ground_height);
    let at = |w: &World, reach: f64| {
        let from = Vector3::new(centre.x + reach, centre.y, centre.z + 100.0);
        let hit = w.trace(&from, &-Vector3::z(), 1000.0, Epoch::Aerial).map(|h| h.surface);
        hit == Some(Surface::Crown(tree.id))
    };
    let r = tree.crown;
    assert!(at(&plain, 0.95 * r) && !at(&plain, 1.05 * r), "sphere of r = {r}");
    assert!(at(&wide, 1.55 * r) && !at(&wide, 1.65 * r), "ellipsoid 1.6 r wide");
}

#[test]
fn pedestrians_are_there_at_one_epoch_at_their_rate_and_on_crossings() {
    let rate = 12.0;
    let w = changed(Preset::District, 3, EpochChanges { pedestrians_per_100m: rate, ..EpochChanges::NONE });
    assert_eq!(w.poles, world(Preset::District, 3).poles, "the rest of the world does not move");
    assert!(world(Preset::District, 3).pedestrians.is_empty());
    let per_100m = |epoch| w.pedestrians.iter().filter(|p| p.epoch == epoch).count() as f64 / w.street_length() * 100.0;
    for epoch in [Epoch::Mobile, Epoch::Aerial] {
        // Junction areas take part of each street's length.
        assert!((0.6 * rate..1.1 * rate).contains(&per_100m(epoch)), "{epoch:?}: {:.1} per 100 m", per_100m(epoch));
    }
    let on_carriageway = w
        .pedestrians
        .iter()
        .filter(|p| offsets(&w, p.shape.center).iter().any(|(s, t)| *t < s.carriageway() / 2.0))
        .count() as f64;
    let share = on_carriageway / w.pedestrians.len() as f64;
    // A third on crossings, and every one in streets without sidewalks (alleys).
    assert!((0.25..0.6).contains(&share), "on the carriageway (crossings): {share:.2}");
    // A ray at a person hits them at their epoch only.
    for p in w.pedestrians.iter().take(20) {
        let c = p.shape.center;
        let from = Vector3::new(c[0], c[1], w.config.ground_height + 50.0);
        let surface = |epoch| w.trace(&from, &-Vector3::z(), 100.0, epoch).map(|h| h.surface);
        let other = if p.epoch == Epoch::Mobile { Epoch::Aerial } else { Epoch::Mobile };
        assert!(matches!(surface(p.epoch), Some(Surface::Pedestrian(_))), "{p:?}");
        assert!(!matches!(surface(other), Some(Surface::Pedestrian(_))), "{p:?}");
    }
}
