//! The generated world: deterministic, with its street classes, objects and sizes, and
//! geometrically sane (nothing stands on the carriageway, no building in a street), checked by brute force;
//! the changes between the epochs (crowns spreading over the road in the aerial flight, pedestrians); the
//! relief (hills, cross-fall, kerbs), rays landing on it, objects and the drive standing on it.
#![allow(clippy::unwrap_used)]

use nalgebra::Vector3;
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::ortho::{OrthoGrid, terrain_model};
use plumbline_synth::world::polyline::{self, P2};
use plumbline_synth::world::{
    BoxShape, Epoch, EpochChanges, PoleClass, Preset, Relief, Street, StreetClass, Surface, World, WorldConfig,
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

/// The harsh level's relief (`Realism::of(Harsh).relief`).
const HILLY: Relief = Relief { grade: 0.08, cross_fall: 0.025, kerb_m: 0.15 };

fn hilly(preset: Preset, seed: u64) -> World {
    World::generate(&WorldConfig { relief: HILLY, ..WorldConfig::new(preset, seed) }).unwrap()
}

#[test]
fn the_ground_has_its_grade_its_cross_fall_and_its_kerbs() {
    let w = hilly(Preset::District, 1);
    // The hills reach their steepest slope inside the district and never exceed it.
    let (lo, hi) = w.bounds();
    let mut steepest: f64 = 0.0;
    for i in 0..=100 {
        for j in 0..=100 {
            let e = lo[0] + (hi[0] - lo[0]) * f64::from(i) / 100.0;
            let n = lo[1] + (hi[1] - lo[1]) * f64::from(j) / 100.0;
            let g = w.hill_gradient(e, n);
            steepest = steepest.max(g[0].hypot(g[1]));
        }
    }
    assert!(steepest <= HILLY.grade + 1e-9 && steepest > 0.85 * HILLY.grade, "steepest slope {steepest}");
    let range = |f: &dyn Fn(f64, f64) -> f64| {
        let hs: Vec<f64> = (0..=50).map(|i| f(lo[0] + (hi[0] - lo[0]) * f64::from(i) / 50.0, lo[1])).collect();
        hs.iter().copied().fold(f64::NEG_INFINITY, f64::max) - hs.iter().copied().fold(f64::INFINITY, f64::min)
    };
    assert!(range(&|e, n| w.ground_at(e, n)) > 3.0, "hills of some metres along the district's south edge");
    // Across every street, half way along it: the kerb's step and the crown above its gutters.
    let mut checked = 0;
    for st in w.streets.iter().filter(|s| s.length() > 40.0) {
        let (p, tan) = polyline::point_at(&st.points, &st.cum, st.length() / 2.0);
        let at = |t: f64| w.ground_at(p[0] - tan[1] * t, p[1] + tan[0] * t);
        let cw = st.carriageway() / 2.0;
        for side in [1.0, -1.0] {
            let step = at(side * (cw + 0.03)) - at(side * (cw - 0.03));
            assert!((step - HILLY.kerb_m).abs() < 0.01, "street {}: kerb step {step}", st.id);
        }
        // Relative to the hills under each point (the hills curve by centimetres across a wide street).
        let above_hills = |t: f64| at(t) - w.hill_height(p[0] - tan[1] * t, p[1] + tan[0] * t);
        let gutters = (above_hills(cw - 0.03) + above_hills(-(cw - 0.03))) / 2.0;
        assert!((gutters + HILLY.kerb_m).abs() < 0.001, "street {}: gutters {gutters} under the hills", st.id);
        let crown = above_hills(0.0) - gutters;
        assert!((crown - HILLY.cross_fall * (cw - 0.03)).abs() < 0.005, "street {}: crown {crown}", st.id);
        checked += 1;
    }
    assert!(checked > 20, "{checked} streets checked");
}

#[test]
fn rays_land_on_the_relief_and_never_pass_through_it() {
    let w = hilly(Preset::Tiny, 2);
    let route = w.route(2, 300.0);
    let (mut ground, mut faces, mut slivers) = (0, 0, 0);
    let under = |q: Vector3<f64>| q.z < w.ground_at(q.x, q.y) - 1e-3;
    for wp in route.waypoints.iter().step_by(9) {
        let o = Vector3::new(wp.east, wp.north, wp.ground_height + 2.5);
        for k in 0..72 {
            let azimuth = f64::from(k) * 5f64.to_radians();
            for depression in [1.5f64, 4.0, 10.0, 30.0, 70.0] {
                let (s, c) = depression.to_radians().sin_cos();
                let d = Vector3::new(c * azimuth.cos(), c * azimuth.sin(), -s);
                let Some(hit) = w.trace(&o, &d, 200.0, Epoch::Mobile) else { continue };
                // Nothing along the ray before its hit lies under the ground, but for strips narrower than the
                // march's step (the kerb of a junction's corner): the ray is above ground again within 10 cm.
                for i in 1..100 {
                    let t = hit.t * f64::from(i) / 100.0;
                    if under(o + d * t) {
                        let horizontal = d.x.hypot(d.y);
                        let emerges = (1..=10).any(|k| !under(o + d * (t + 0.01 * f64::from(k) / horizontal)));
                        assert!(emerges, "ray {d:?} from {o:?} passes under the ground at t {t}");
                        slivers += 1;
                        break;
                    }
                }
                if hit.surface != Surface::Ground {
                    continue;
                }
                let below = hit.point.z - w.ground_at(hit.point.x, hit.point.y);
                if hit.normal.z.abs() < 1e-9 {
                    // A kerb's face: between the gutter and the kerb's top.
                    assert!((-1e-3..=HILLY.kerb_m + 1e-3).contains(&below), "{below} on a kerb face");
                    faces += 1;
                } else {
                    assert!(below.abs() < 2e-3, "hit {below} m off the ground at {:?}", hit.point);
                    ground += 1;
                }
            }
        }
    }
    assert!(ground > 1000 && faces > 0, "{ground} ground hits, {faces} kerb faces");
    assert!(slivers * 200 < ground, "{slivers} rays missed a narrow strip, of {ground}");
}

#[test]
fn objects_stand_on_the_relief_and_the_terrain_model_has_its_slope() {
    let w = hilly(Preset::Tiny, 3);
    let corners = |s: &BoxShape| {
        let (a, n) = (s.axis, [-s.axis[1], s.axis[0]]);
        [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)].map(|(u, v)| {
            let e = s.center[0] + u * s.half[0] * a[0] + v * s.half[1] * n[0];
            let m = s.center[1] + u * s.half[0] * a[1] + v * s.half[1] * n[1];
            w.ground_at(e, m)
        })
    };
    for b in &w.buildings {
        let g = corners(&b.shape);
        // Foundations 0.3 m below the lowest corner; the highest corner up to the grade across the diagonal.
        let rise = 0.3 + HILLY.grade * 2.0 * b.shape.half[0].hypot(b.shape.half[1]) + HILLY.kerb_m;
        assert!(
            g.iter().all(|&h| h >= b.shape.base && h < b.shape.base + rise),
            "building on {g:?}, base {}",
            b.shape.base
        );
    }
    for c in &w.cars {
        let g = corners(&c.shape);
        assert!(g.iter().all(|&h| h >= c.shape.base && h < c.shape.base + 0.3), "car on {g:?}, base {}", c.shape.base);
    }
    for p in &w.poles {
        assert_eq!(w.pole_ground(p.id), w.ground_at(p.base[0], p.base[1]));
    }
    // The terrain model (1 m cells, kerbs averaged) has the hills' slope over 30 m anywhere.
    let (lo, hi) = w.bounds();
    let grid = OrthoGrid {
        west: lo[0],
        north: hi[1],
        gsd: 1.0,
        width: (hi[0] - lo[0]) as u32,
        height: (hi[1] - lo[1]) as u32,
    };
    let dtm = terrain_model(&w, &grid);
    let at = |col: u32, row: u32| f64::from(dtm[(row * grid.width + col) as usize]);
    let mut worst: f64 = 0.0;
    for row in (0..grid.height - 30).step_by(37) {
        for col in (0..grid.width - 30).step_by(41) {
            let [e, n] = grid.centre(col + 15, row + 15);
            let g = w.hill_gradient(e, n);
            let east = (at(col + 30, row + 15) - at(col, row + 15)) / 30.0;
            let north = (at(col + 15, row) - at(col + 15, row + 30)) / 30.0;
            worst = worst.max((east - g[0]).abs()).max((north - g[1]).abs());
        }
    }
    // A kerb between the ends changes a 30 m slope by 0.15 / 30; the crown by less.
    assert!(worst < 0.012, "terrain model slope off by {worst}");
}

#[test]
fn the_drive_follows_the_relief_and_leans_with_it() {
    let w = hilly(Preset::Tiny, 1);
    let route = w.route(1, 700.0);
    let config = DriveConfig::default();
    let drive = Drive::simulate(&route, &config, 1).unwrap();
    let mut off: Vec<f64> = Vec::new();
    let (mut banks, mut rolls) = (Vec::new(), Vec::new());
    for (r, k) in drive.trajectory.records().iter().zip(&drive.kinematics).step_by(10) {
        let p = r.position;
        off.push((p.z() - config.imu_height - w.ground_at(p.x(), p.y())).abs());
        if k.speed > 3.0 {
            let v = k.velocity;
            let (tan_e, tan_n) = (v.x() / k.speed, v.y() / k.speed);
            let g = w.hill_gradient(p.x(), p.y());
            banks.push(-tan_n * g[0] + tan_e * g[1]);
            rolls.push(r.attitude.roll);
        }
    }
    off.sort_by(f64::total_cmp);
    let (median, p95) = (off[off.len() / 2], off[off.len() * 95 / 100]);
    assert!(median < 0.01 && p95 < 0.05, "IMU height above the road off by {median} (median), {p95} (95 %)");
    let max_bank = banks.iter().map(|b| b.abs()).fold(0.0, f64::max);
    assert!(max_bank > 0.02, "the drive crosses hillsides: bank up to {max_bank}");
    // Roll follows the bank (camber and curve roll on top): their correlation.
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    let (mb, mr) = (mean(&banks), mean(&rolls));
    let cov: f64 = banks.iter().zip(&rolls).map(|(b, r)| (b - mb) * (r - mr)).sum();
    let (vb, vr): (f64, f64) =
        (banks.iter().map(|b| (b - mb).powi(2)).sum(), rolls.iter().map(|r| (r - mr).powi(2)).sum());
    let corr = cov / (vb * vr).sqrt();
    assert!(corr > 0.8, "roll against bank: correlation {corr}");
}
