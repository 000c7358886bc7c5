//! The city's aerial block and ortho tiles (`plumbline_synth::city_aerial`): the endless block has the geometry
//! `plan_block` flies (GSD, overlaps, strip directions), every point near a drive is seen by at least two of the
//! frames chosen for it and no frame is chosen that does not reach the drive, AT errors belong to the frame,
//! and a frame or tile rendered from the window made for it is pixel-identical to one rendered from a much
//! larger window of the same city (nothing it shows is missing, shadows cast from outside included).
#![allow(clippy::unwrap_used)]

use plumbline_geo::camera::{CameraModel, Pinhole, Pixel};
use plumbline_geo::{Point3, Vec3};
use plumbline_synth::aerial::small_format_distorted;
use plumbline_synth::city_aerial::{
    CityBlock, FrameKey, TileKey, TileLattice, seen_margin, track_points, window_seeing,
};
use plumbline_synth::ortho::render_orthophoto;
use plumbline_synth::render::{AtErrors, BlockSpec, Scene, ground_truth, plan_block};
use plumbline_synth::world::city::City;
use plumbline_synth::world::{Epoch, Preset, Surface, World, WorldConfig};
use rand::{RngExt, SeedableRng};

fn block(seed: u64) -> (WorldConfig, CityBlock) {
    let config = WorldConfig::new(Preset::City, seed);
    let cam = Pinhole::from_metric(&small_format_distorted(1000, 750)).unwrap();
    let block = CityBlock::new(&config, cam, &BlockSpec::standard());
    (config, block)
}

/// Distance from `p` to the box, largest of the easting and northing gaps (0 inside).
fn box_gap(p: [f64; 2], (lo, hi): ([f64; 2], [f64; 2])) -> f64 {
    let gap = |x: f64, a: f64, b: f64| (a - x).max(x - b).max(0.0);
    gap(p[0], lo[0], hi[0]).max(gap(p[1], lo[1], hi[1]))
}

fn inside(p: [f64; 2], (lo, hi): ([f64; 2], [f64; 2])) -> bool {
    box_gap(p, (lo, hi)) == 0.0
}

#[test]
fn the_endless_block_flies_plan_blocks_geometry() {
    let (config, block) = block(3);
    let cam = *block.camera();
    // plan_block over a tiny world: same flying height, air base and strip spacing.
    let world = World::generate(&WorldConfig::new(Preset::Tiny, 3)).unwrap();
    let planned = plan_block(&world, &cam, &BlockSpec::standard());
    let (a, b) = (block.pose(FrameKey { strip: 0, step: 0 }), block.pose(FrameKey { strip: 0, step: 1 }));
    let base = planned[1].translation.x() - planned[0].translation.x();
    assert!((b.translation.x() - a.translation.x() - base).abs() < 1e-9, "air base {base}");
    let first_of_strip_1 = planned.iter().find(|p| (p.translation.y() - planned[0].translation.y()).abs() > 1.0);
    let spacing = first_of_strip_1.unwrap().translation.y() - planned[0].translation.y();
    let c = block.pose(FrameKey { strip: 1, step: 0 });
    assert!((c.translation.y() - a.translation.y() - spacing).abs() < 1e-9, "strip spacing {spacing}");
    assert!((a.translation.z() - config.ground_height - 0.12 * cam.fx).abs() < 1e-9);
    // The footprint's corners project onto the image corners in eastward and westward strips alike (to the
    // ~1 px of lens distortion), so the footprint is where the frame looks.
    for key in [FrameKey { strip: 0, step: 5 }, FrameKey { strip: -3, step: -2 }] {
        let pose = block.pose(key).inverse();
        let (lo, hi) = block.footprint(key);
        let mut us = Vec::new();
        for corner in [lo, hi, [lo[0], hi[1]], [hi[0], lo[1]]] {
            let v: Vec3<_> =
                pose.transform_point(&Point3::new(corner[0], corner[1], config.ground_height)) - Point3::origin();
            let px: Pixel = cam.project(&v).unwrap();
            us.push((px.u, px.v));
        }
        for (u, v) in us {
            let near = |x: f64, edge: f64| (x - edge).abs() < 2.0;
            assert!((near(u, 0.0) || near(u, 1000.0)) && (near(v, 0.0) || near(v, 750.0)), "{key:?}: ({u}, {v})");
        }
    }
}

#[test]
fn frames_near_a_drive_see_every_point_twice_and_all_reach_it() {
    let (_, block) = block(5);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
    let (reach, mut checked) = (30.0, 0);
    for _ in 0..4 {
        // A random polyline of 6 points spread over 600 m.
        let points: Vec<[f64; 2]> = (0..6)
            .map(|_| [500_000.0 + rng.random_range(-300.0..300.0), 5_400_000.0 + rng.random_range(-300.0..300.0)])
            .collect();
        let dense = track_points(points.iter().copied(), 5.0);
        assert!(dense.windows(2).all(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) <= 5.0 + 1e-9));
        assert_eq!((dense[0], dense[dense.len() - 1]), (points[0], points[5]));
        let chosen = block.frames_near(&dense, reach);
        // Every chosen frame reaches the drive; every frame of the neighbourhood that reaches it is chosen.
        let gap = |k: FrameKey| dense.iter().map(|&p| box_gap(p, block.footprint(k))).fold(f64::INFINITY, f64::min);
        assert!(chosen.iter().all(|&k| gap(k) <= reach + 1e-9));
        let (s0, s1) = (chosen.iter().map(|k| k.strip).min().unwrap(), chosen.iter().map(|k| k.strip).max().unwrap());
        let (k0, k1) = (chosen.iter().map(|k| k.step).min().unwrap(), chosen.iter().map(|k| k.step).max().unwrap());
        for strip in s0 - 2..=s1 + 2 {
            for step in k0 - 2..=k1 + 2 {
                let key = FrameKey { strip, step };
                assert_eq!(chosen.contains(&key), gap(key) <= reach, "{key:?}: gap {}", gap(key));
            }
        }
        // Ground up to `reach` from the drive is in two or more chosen frames (60 % forward overlap).
        for _ in 0..200 {
            let p = dense[rng.random_range(0..dense.len())];
            let q = [p[0] + rng.random_range(-reach..reach), p[1] + rng.random_range(-reach..reach)];
            let n = chosen.iter().filter(|&&k| inside(q, block.footprint(k))).count();
            assert!(n >= 2, "{q:?} in {n} frames");
            checked += 1;
        }
    }
    assert_eq!(checked, 800);
}

#[test]
fn at_errors_belong_to_the_frame_and_ids_are_unique() {
    let (_, block) = block(2);
    let errors = AtErrors::typical();
    let keys = [FrameKey { strip: -1, step: 4 }, FrameKey { strip: 1, step: -4 }, FrameKey { strip: 14, step: 41 }];
    let ids: std::collections::HashSet<String> = keys.iter().map(|k| k.id()).collect();
    assert_eq!(ids.len(), keys.len());
    let mut offsets = Vec::new();
    for key in keys {
        let (a, b) = (block.frame(key, &errors, 9), block.frame(key, &errors, 9));
        // The same frame made twice (by two legs) is the same.
        assert_eq!((a.reported.translation - b.reported.translation).norm(), 0.0);
        assert!(a.reported.rotation.angle_to(&b.reported.rotation) < 1e-12);
        let d = (a.reported.translation - a.truth.translation).norm();
        assert!(d > 1e-4 && d < 0.2, "{key:?}: {d} m");
        assert!(a.reported.rotation.angle_to(&a.truth.rotation) < 30.0 / 206_265.0);
        offsets.push(d);
    }
    assert!(offsets[0] != offsets[1] && offsets[1] != offsets[2], "independent errors per frame: {offsets:?}");
}

/// The kind of a surface, without the window-local object number.
fn kind(s: Surface) -> std::mem::Discriminant<Surface> {
    std::mem::discriminant(&s)
}

/// Orthophoto pixels of `grid` rendered from `a` and `b` that differ: ground, roofs, cast shadows, cars,
/// crowns and poles.
fn ortho_differences(a: &World, b: &World, grid: &plumbline_synth::ortho::OrthoGrid) -> usize {
    let (ia, ib) = (render_orthophoto(&Scene::aerial(a), grid), render_orthophoto(&Scene::aerial(b), grid));
    ia.enumerate_pixels().filter(|&(c, r, p)| ib.get_pixel(c, r) != p).count()
}

#[test]
fn frames_and_tiles_see_the_same_city_from_their_window_as_from_a_far_larger_one() {
    let (config, block) = block(7);
    let city = City::new(&config);
    let grown = |(lo, hi): ([f64; 2], [f64; 2]), d: f64| ([lo[0] - d, lo[1] - d], [hi[0] + d, hi[1] + d]);
    // A frame some way from the origin: every pixel's first surface and point are those of a 1.3 km window.
    let key = FrameKey { strip: 3, step: -5 };
    let (lo, hi) = grown(block.footprint(key), 600.0);
    let big = city.window_box(lo, hi).world;
    let small = window_seeing(&city, [block.footprint(key)]).unwrap().world;
    assert!(small.poles.len() * 2 < big.poles.len(), "{} vs {} poles", small.poles.len(), big.poles.len());
    // At 60 cm GSD (the frame's footprint, 1/25 of its pixels) to keep the test quick.
    let cam = Pinhole::from_metric(&small_format_distorted(200, 150)).unwrap();
    let pose = block.pose(key);
    let mut surfaces = std::collections::HashSet::new();
    for (c, r) in (0..200).flat_map(|c| (0..150).map(move |r| (c, r))) {
        let px = Pixel::new(f64::from(c) + 0.5, f64::from(r) + 0.5);
        let (a, b) =
            (ground_truth(&small, Epoch::Aerial, &cam, &pose, px), ground_truth(&big, Epoch::Aerial, &cam, &pose, px));
        let (a, b) = (a.unwrap(), b.unwrap());
        assert!((a.0 - b.0).norm() < 1e-9 && kind(a.1) == kind(b.1), "pixel ({c}, {r}): {a:?} vs {b:?}");
        surfaces.insert(kind(a.1));
    }
    assert!(surfaces.len() >= 4, "ground, roofs, crowns, cars… in view: {}", surfaces.len());
    // An orthophoto tile: identical colours, roofs and cast shadows included.
    let lattice = TileLattice { origin: [config.origin_east, config.origin_north], size: 120.0 };
    let tile = TileKey { col: -2, row: 1 };
    let grid = lattice.grid(tile, 300);
    let (lo, hi) = grown(lattice.bounds(tile), 600.0);
    let big = city.window_box(lo, hi).world;
    let small = window_seeing(&city, [lattice.bounds(tile)]).unwrap().world;
    assert_eq!(ortho_differences(&small, &big, &grid), 0);
    assert!(seen_margin() > 57.0, "the longest shadow of a 40 m building at 35° sun is 57 m");
}

#[test]
fn tiles_join_without_gap_and_cover_the_drive() {
    let lattice = TileLattice { origin: [500_000.0, 5_400_000.0], size: 120.0 };
    let a = lattice.grid(TileKey { col: -1, row: 2 }, 1000);
    let b = lattice.grid(TileKey { col: 0, row: 2 }, 1000);
    let c = lattice.grid(TileKey { col: -1, row: 1 }, 1000);
    assert!((a.west + f64::from(a.width) * a.gsd - b.west).abs() < 1e-6 && a.north == b.north);
    assert!((a.north - f64::from(a.height) * a.gsd - c.north).abs() < 1e-6 && a.west == c.west);
    assert!((a.gsd - 0.12).abs() < 1e-12);
    let points = [[500_010.0, 5_400_010.0], [500_250.0, 5_400_010.0]];
    let near = lattice.tiles_near(&points, 30.0);
    // The 30 m reach crosses the tile edges at 0 (both axes) and 240 m (easting).
    let expected: std::collections::BTreeSet<TileKey> =
        (-1..=2).flat_map(|col| (-1..=0).map(move |row| TileKey { col, row })).collect();
    assert_eq!(near, expected);
}
