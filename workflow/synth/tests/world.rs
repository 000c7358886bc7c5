//! The generated world: deterministic, with the street classes, objects and sizes the issue asks for, and
//! geometrically sane (nothing stands on the carriageway, no building in a street), checked by brute force.
#![allow(clippy::unwrap_used)]

use plumbline_synth::world::polyline::{self, P2};
use plumbline_synth::world::{PoleClass, Preset, Street, StreetClass, World, WorldConfig};

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
