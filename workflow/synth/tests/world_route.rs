//! Routes through the world: long enough, on the right-hand lane, repeating some streets, with junction
//! flags, speed limits by class and canyons that agree with the buildings.
#![allow(clippy::unwrap_used)]

use plumbline_synth::world::polyline;
use plumbline_synth::world::{Preset, StreetClass, World, WorldConfig};

fn world(preset: Preset, seed: u64) -> World {
    World::generate(&WorldConfig::new(preset, seed)).unwrap()
}

#[test]
fn route_is_long_enough_dense_and_on_the_right_lane() {
    for seed in 0..4 {
        let w = world(Preset::District, seed);
        let route = w.route(seed, 3000.0);
        let wp = &route.waypoints;
        let len: f64 = wp.windows(2).map(|p| polyline::dist([p[0].east, p[0].north], [p[1].east, p[1].north])).sum();
        assert!(len >= 3000.0, "{len}");
        assert_eq!(route, w.route(seed, 3000.0));
        for pair in wp.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            let d = polyline::dist([a.east, a.north], [b.east, b.north]);
            // Within a street ≤ 4 m on the centreline (a little more on the outside of a bend); a junction crossing ≤ twice the widest junction radius.
            assert!(d <= 4.2 || (a.junction && b.junction && d < 40.0), "{d}");
            let mid = [(a.east + b.east) / 2.0, (a.north + b.north) / 2.0];
            let clear_of_junctions = w.junctions.iter().all(|j| polyline::dist(j.pos, mid) > j.radius + 12.0);
            if d > 0.5 && clear_of_junctions {
                let dir = [(b.east - a.east) / d, (b.north - a.north) / d];
                // The lane is right of the centreline: the nearest street's signed offset, taken along travel.
                let (s, st) = w
                    .streets
                    .iter()
                    .map(|s| (s, polyline::nearest(&s.points, &s.cum, mid)))
                    .min_by(|x, y| x.1.t.abs().total_cmp(&y.1.t.abs()))
                    .unwrap();
                let along = st.tangent[0] * dir[0] + st.tangent[1] * dir[1];
                let t_travel = st.t * along.signum();
                assert!((t_travel - s.drive_offset()).abs() < 0.3, "offset {t_travel} vs {}", s.drive_offset());
                assert!((a.speed_limit - s.class.speed_limit()).abs() < 1e-9);
            }
        }
        assert!(wp.iter().filter(|p| p.junction).count() >= 10);
        let speeds: std::collections::BTreeSet<u64> = wp.iter().map(|p| (p.speed_limit * 1000.0) as u64).collect();
        assert!(speeds.len() >= 2);
    }
}

#[test]
fn some_streets_are_driven_more_than_once() {
    let w = world(Preset::District, 5);
    let route = w.route(9, 4000.0);
    // Count passes per street by the waypoints nearest to each street's midpoint.
    let passes: Vec<usize> = w
        .streets
        .iter()
        .map(|s| {
            let (mid, _) = polyline::point_at(&s.points, &s.cum, s.length() / 2.0);
            let near: Vec<usize> = route
                .waypoints
                .iter()
                .enumerate()
                .filter(|(_, p)| polyline::dist([p.east, p.north], mid) < 4.0)
                .map(|(i, _)| i)
                .collect();
            near.windows(2).filter(|k| k[1] - k[0] > 3).count() + usize::from(!near.is_empty())
        })
        .collect();
    assert!(passes.iter().filter(|&&p| p >= 2).count() >= 2, "{passes:?}");
    assert!(passes.iter().filter(|&&p| p >= 1).count() >= w.streets.len() / 2, "{passes:?}");
}

#[test]
fn canyon_matches_the_buildings_beside_the_road() {
    let w = world(Preset::District, 2);
    let route = w.route(2, 2500.0);
    let mut deep = 0;
    for p in &route.waypoints {
        let c = p.canyon;
        assert!(c.building_height == 0.0 || (5.0..=40.0).contains(&c.building_height), "{c:?}");
        if c.building_height > 0.0 {
            // At least the street's carriageway lies between the fronts (the vehicle is on it).
            let s = w
                .streets
                .iter()
                .min_by(|a, b| {
                    let ta = polyline::nearest(&a.points, &a.cum, [p.east, p.north]).t.abs();
                    let tb = polyline::nearest(&b.points, &b.cum, [p.east, p.north]).t.abs();
                    ta.total_cmp(&tb)
                })
                .unwrap();
            if !p.junction && c.street_width < 100.0 {
                assert!(c.street_width >= 2.0 * s.half_corridor() - 0.5, "{c:?} vs {}", s.half_corridor());
            }
            if c.ratio() > 1.0 {
                deep += 1;
            }
            if s.class == StreetClass::Alley && c.street_width < 7.0 {
                assert!(c.ratio() > 1.4);
            }
        }
    }
    assert!(deep > 5, "deep canyons exist: {deep}");
}
