//! Tests of the tile planner: a hand-checked example, input validation, and properties over random
//! trajectory-like campaigns (random walks over a street network, several passes, gaps, negative coordinates).

use std::collections::{BTreeMap, BTreeSet};

use plumbline_geo::tiling::{BBox, ImageId, ImageSite, InvalidPlan, TileId, TilePlan, TilingError, TilingParams, plan};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, RngSeed};
use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn site(id: u64, time: f64, east: f64, north: f64) -> ImageSite {
    ImageSite { id: ImageId(id), time, east, north }
}

fn ids(raw: &[u64]) -> Vec<ImageId> {
    raw.iter().map(|&id| ImageId(id)).collect()
}

fn tid(col: i64, row: i64) -> TileId {
    TileId { col, row }
}

fn bbox(min_east: f64, min_north: f64, max_east: f64, max_north: f64) -> BBox {
    BBox { min_east, min_north, max_east, max_north }
}

/// Eight sites around the origin of a 100 m grid: a pass crossing x = 0 westwards-to-east, a gap,
/// a short hop across y = 0, a site exactly on a border, and one at (-100, -0.0).
fn example_sites() -> Vec<ImageSite> {
    vec![
        site(7, 0.0, -15.0, 50.0),  // c-1_r0 (truncation instead of floor would say c0_r0)
        site(3, 1.0, -5.0, 50.0),   // c-1_r0
        site(9, 2.0, 5.0, 50.0),    // c0_r0: pair (3, 9) crosses the border, goes to c-1_r0
        site(1, 3.0, 15.0, 50.0),   // c0_r0
        site(8, 4.0, 15.0, -5.0),   // c0_r-1: 55 m from the previous site, no pair
        site(2, 5.0, 15.0, 5.0),    // c0_r0: pair (8, 2) crosses y = 0, goes to c0_r-1
        site(6, 6.0, 5.0, 0.0),     // c0_r0 (on the border y = 0), pair (2, 6) at 11.2 m
        site(5, 7.0, -100.0, -0.0), // c-1_r0 (on the border x = -100; -0.0 is row 0), no pair
    ]
}

#[test]
fn hand_checked_example() {
    let plan = plan(&example_sites(), &TilingParams::new(100.0, 10.0)).expect("valid input");
    let tiles = plan.tiles();
    assert_eq!(tiles.iter().map(|t| t.id).collect::<Vec<_>>(), [tid(0, -1), tid(-1, 0), tid(0, 0)]);

    let south = &tiles[0];
    assert_eq!(south.owned, ids(&[8]));
    assert_eq!(south.context, ids(&[2]));
    assert_eq!(south.pairs, [(ImageId(8), ImageId(2))]);
    assert_eq!(south.core, bbox(0.0, -100.0, 100.0, 0.0));
    assert_eq!(south.fetch, bbox(5.0, -15.0, 25.0, 15.0));

    let west = &tiles[1];
    assert_eq!(west.owned, ids(&[7, 3, 5]));
    assert_eq!(west.context, ids(&[9]));
    assert_eq!(west.pairs, [(ImageId(7), ImageId(3)), (ImageId(3), ImageId(9))]);
    assert_eq!(west.core, bbox(-100.0, 0.0, 0.0, 100.0));
    assert_eq!(west.fetch, bbox(-110.0, -10.0, 15.0, 60.0));

    let centre = &tiles[2];
    assert_eq!(centre.owned, ids(&[9, 1, 2, 6]));
    assert!(centre.context.is_empty());
    assert_eq!(centre.pairs, [(ImageId(9), ImageId(1)), (ImageId(2), ImageId(6))]);
    assert_eq!(centre.core, bbox(0.0, 0.0, 100.0, 100.0));
    assert_eq!(centre.fetch, bbox(-5.0, -10.0, 25.0, 60.0));

    assert_eq!(plan.tile_of(ImageId(5)), Some(&tid(-1, 0)));
    assert_eq!(plan.tile_of(ImageId(8)), Some(&tid(0, -1)));
    assert_eq!(plan.tile_of(ImageId(4)), None);
    assert_eq!(plan.tile(&tid(0, 0)).map(|t| t.owned.len()), Some(4));
    assert!(plan.tile(&tid(1, 0)).is_none());
}

#[test]
fn summary_counts_the_example() {
    let summary = plan(&example_sites(), &TilingParams::new(100.0, 10.0)).expect("valid input").summary();
    assert_eq!((summary.tiles, summary.images, summary.pairs, summary.context_images), (3, 8, 5, 2));
    let stats = summary.owned_per_tile.expect("non-empty plan");
    assert_eq!((stats.min, stats.median, stats.max), (1, 3.0, 4));
    assert_eq!(
        summary.to_string(),
        "3 tiles, 8 images, 5 pairs, 2 context images; images per tile min 1 / median 3 / max 4"
    );
    let empty = plan(&[], &TilingParams::new(100.0, 10.0)).expect("empty input is valid");
    assert!(empty.tiles().is_empty());
    assert_eq!(empty.summary().owned_per_tile, None);
}

#[test]
fn max_pair_distance_is_inclusive() {
    let sites = [site(1, 0.0, 0.5, 0.5), site(2, 1.0, 15.5, 0.5), site(3, 2.0, 30.6, 0.5)];
    let plan = plan(&sites, &TilingParams::new(1000.0, 0.0)).expect("valid input");
    assert_eq!(plan.tiles()[0].pairs, [(ImageId(1), ImageId(2))]);
    assert_eq!(plan.tiles()[0].fetch, bbox(0.5, 0.5, 30.6, 0.5));
}

fn check_error(sites: &[ImageSite], params: TilingParams, expected: TilingError) {
    assert_eq!(plan(sites, &params), Err(expected));
}

#[test]
fn invalid_input_names_site_and_field() {
    let ok = TilingParams::new(100.0, 10.0);
    let mut sites = example_sites();
    sites[3].north = f64::NAN;
    sites[5].east = f64::INFINITY;
    let error = plan(&sites, &ok).expect_err("NaN northing");
    assert!(matches!(error, TilingError::NotFinite { index: 3, id: ImageId(1), field: "north", .. }), "{error}");
    assert!(error.to_string().contains("site 3") && error.to_string().contains("`north`"), "{error}");

    let mut sites = example_sites();
    sites[2].time = f64::NEG_INFINITY;
    assert!(matches!(plan(&sites, &ok), Err(TilingError::NotFinite { index: 2, field: "time", .. })));

    let mut sites = example_sites();
    sites[4].time = 0.5;
    let expected = TilingError::TimeNotOrdered { index: 4, id: ImageId(8), time: 0.5, previous: 3.0 };
    check_error(&sites, ok, expected);

    let mut sites = example_sites();
    sites[6].id = ImageId(3);
    sites[7].id = ImageId(1);
    check_error(&sites, ok, TilingError::DuplicateImageId { index: 6, id: ImageId(3), first: 1 });

    let sites = [site(1, 0.0, 1e300, 0.0)];
    assert!(matches!(plan(&sites, &ok), Err(TilingError::OutsideGrid { index: 0, field: "east", .. })));
}

#[test]
fn invalid_params_are_named() {
    let sites = example_sites();
    for (params, field) in [
        (TilingParams::new(0.0, 10.0), "tile_size"),
        (TilingParams::new(-5.0, 10.0), "tile_size"),
        (TilingParams::new(f64::NAN, 10.0), "tile_size"),
        (TilingParams::new(f64::INFINITY, 10.0), "tile_size"),
        (TilingParams::new(100.0, -1.0), "overlap"),
        (TilingParams::new(100.0, f64::NAN), "overlap"),
        (TilingParams { max_pair_distance: -1.0, ..TilingParams::new(100.0, 10.0) }, "max_pair_distance"),
    ] {
        match plan(&sites, &params) {
            Err(TilingError::InvalidParam { field: got, .. }) => assert_eq!(got, field),
            other => panic!("{params:?}: expected an invalid `{field}`, got {other:?}"),
        }
    }
}

#[test]
fn borders_go_east_and_north() {
    // -632.1 / 14.7 evaluates to slightly below -43, yet -632.1 is the west border of cell -43.
    assert_eq!((-632.1f64 / 14.7).floor(), -44.0);
    assert_eq!(TileId::containing(-632.1, 632.1, 14.7), Some(tid(-43, 43)));
    assert_eq!(TileId::containing(-0.0, 0.0, 1.0), Some(tid(0, 0)));
    assert_eq!(TileId::containing(-1e-300, 1.0, 1.0), Some(tid(-1, 1)));
    assert_eq!(TileId::containing(f64::NAN, 0.0, 1.0), None);
    assert_eq!(TileId::containing(0.0, 1e20, 1e-3), None);
    assert_eq!(tid(-43, 43).core(14.7).min_east, -632.1);
    // Just west of a border, v / size may round up to the border's index.
    let size: f64 = 91.59200000000001;
    let west = (2064.0 * size).next_down();
    assert_eq!((west / size).floor(), 2064.0);
    assert_eq!(TileId::containing(west, 0.0, size), Some(tid(2063, 0)));
}

#[test]
fn tile_id_text_form() {
    assert_eq!(tid(12, -3).to_string(), "c12_r-3");
    assert_eq!("c-1_r0".parse(), Ok(tid(-1, 0)));
    for bad in ["", "c1", "c1_r", "r1_c2", "c+1_r0", "c01_r0", "c1_r-0", "C1_R2", "c1_r2 ", "c1_r99999999999999999999"]
    {
        assert!(bad.parse::<TileId>().is_err(), "{bad:?} parsed");
    }
}

#[test]
fn from_tiles_rejects_inconsistent_plans() {
    let tiles = plan(&example_sites(), &TilingParams::new(100.0, 10.0)).expect("valid input").into_tiles();
    let mut unsorted = tiles.clone();
    unsorted.swap(0, 1);
    assert!(matches!(TilePlan::from_tiles(unsorted), Err(InvalidPlan::TilesNotSorted { .. })));
    let mut twice = tiles.clone();
    twice[0].owned.push(ImageId(5));
    let expected = InvalidPlan::OwnedTwice { image: ImageId(5), first: tid(0, -1), second: tid(-1, 0) };
    assert_eq!(TilePlan::from_tiles(twice), Err(expected));
    let rebuilt = TilePlan::from_tiles(tiles).expect("consistent tiles");
    assert_eq!(rebuilt, plan(&example_sites(), &TilingParams::new(100.0, 10.0)).expect("valid input"));
}

#[test]
fn schema_shows_only_the_tiles() {
    let schema = schemars::schema_for!(TilePlan).as_value().to_string();
    assert!(schema.contains("\"tiles\"") && !schema.contains("owners"), "{schema}");
}

#[test]
fn bbox_operations() {
    let a = bbox(0.0, 0.0, 10.0, 5.0);
    let b = bbox(10.0, 5.0, 20.0, 8.0);
    assert!(a.intersects(&b) && b.intersects(&a));
    assert!(!a.intersects(&bbox(10.5, 0.0, 20.0, 5.0)));
    assert_eq!(a.union(&b), bbox(0.0, 0.0, 20.0, 8.0));
    assert!(a.contains(10.0, 5.0) && !a.contains(10.0, 5.000001));
    assert_eq!(a.expand(2.0), bbox(-2.0, -2.0, 12.0, 7.0));
    assert_eq!(a.expand(0.0), a);
    // In f64, -6.99 − (-6.99 − 0.1) < 0.1: the box must reach one ulp further out than the plain sum.
    let (v, margin) = (6.99f64, 0.1f64);
    assert!(-v - (-v - margin) < margin && (v + margin) - v < margin);
    let tight = bbox(-6.99, -6.99, 6.99, 6.99).expand(0.1);
    assert!(tight.min_east < -6.99 - 0.1 && tight.max_east > 6.99 + 0.1, "{tight:?}");
    let margins = [-6.99 - tight.min_east, tight.max_east - 6.99, -6.99 - tight.min_north, tight.max_north - 6.99];
    assert!(margins.iter().all(|&m| m >= 0.1), "{margins:?}");
}

// ---- properties over random campaigns ----

/// A campaign-like site sequence: several passes along a random street polyline, with jitter,
/// occasional jumps (gaps), reversed passes, and a street network that straddles negative coordinates.
/// Some sites are snapped onto grid lines of `tile_size`, where ownership is decided by the half-open rule.
fn random_campaign(seed: u64, n_target: usize, tile_size: f64) -> Vec<ImageSite> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let street = random_street(&mut rng);
    let id_key = rng.random::<u64>();
    let passes = rng.random_range(1..=5);
    let mut sites = Vec::new();
    let mut time = rng.random_range(-1000.0..1000.0);
    for _ in 0..passes {
        let mut along: Vec<(f64, f64)> = street.clone();
        if rng.random_bool(0.5) {
            along.reverse();
        }
        let mut k = rng.random_range(0..along.len());
        while k < along.len() && sites.len() < n_target {
            let (e, n) = along[k];
            // A bijection of the index keeps ids unique but unrelated to capture order.
            let id = (sites.len() as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ id_key;
            let (mut e, mut n) = (e + rng.random_range(-1.0..1.0), n + rng.random_range(-1.0..1.0));
            if rng.random_bool(0.05) {
                e = (e / tile_size).round() * tile_size;
            }
            if rng.random_bool(0.05) {
                n = (n / tile_size).round() * tile_size;
            }
            sites.push(site(id, time, e, n));
            time += rng.random_range(0.2..2.0);
            k += if rng.random_bool(0.05) { rng.random_range(2..40) } else { 1 };
        }
        time += rng.random_range(10.0..600.0);
    }
    sites
}

/// A random walk with steps of up to 20 m and slowly turning heading, starting anywhere in ±400 m.
fn random_street(rng: &mut ChaCha8Rng) -> Vec<(f64, f64)> {
    let (mut e, mut n) = (rng.random_range(-400.0..400.0), rng.random_range(-400.0..400.0));
    let mut heading: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    (0..rng.random_range(2..2000))
        .map(|_| {
            heading += rng.random_range(-0.4..0.4);
            let step = rng.random_range(0.0..20.0);
            e += step * heading.cos();
            n += step * heading.sin();
            (e, n)
        })
        .collect()
}

fn random_params(rng_seed: u64) -> TilingParams {
    let mut rng = ChaCha8Rng::seed_from_u64(rng_seed);
    TilingParams {
        tile_size: rng.random_range(3.0..300.0),
        overlap: if rng.random_bool(0.2) { 0.0 } else { rng.random_range(0.0..60.0) },
        max_pair_distance: rng.random_range(0.5..30.0),
    }
}

fn check_ownership(sites: &[ImageSite], plan: &TilePlan, params: &TilingParams) {
    let mut owner: BTreeMap<ImageId, TileId> = BTreeMap::new();
    for tile in plan.tiles() {
        assert!(!tile.owned.is_empty(), "{} is empty", tile.id);
        assert_eq!(tile.core, bbox_of_cell(tile.id, params.tile_size));
        for id in &tile.owned {
            assert!(owner.insert(*id, tile.id).is_none(), "{id} owned twice");
        }
    }
    assert_eq!(owner.len(), sites.len());
    for s in sites {
        let tile = owner[&s.id];
        assert_eq!(plan.tile_of(s.id), Some(&tile));
        // Half-open cell: the image must lie in its owner's core, west/south borders inclusive.
        let core = tile.core(params.tile_size);
        let inside =
            core.min_east <= s.east && s.east < core.max_east && core.min_north <= s.north && s.north < core.max_north;
        assert!(inside, "image {} at ({}, {}) is not in the core {core:?} of its owner {tile}", s.id, s.east, s.north);
    }
}

fn bbox_of_cell(id: TileId, size: f64) -> BBox {
    bbox(id.col as f64 * size, id.row as f64 * size, (id.col + 1) as f64 * size, (id.row + 1) as f64 * size)
}

fn check_pairs(sites: &[ImageSite], plan: &TilePlan, params: &TilingParams) {
    let mut found: BTreeMap<(ImageId, ImageId), TileId> = BTreeMap::new();
    for tile in plan.tiles() {
        let readable: BTreeSet<ImageId> = tile.owned.iter().chain(&tile.context).copied().collect();
        for &(a, b) in &tile.pairs {
            assert!(found.insert((a, b), tile.id).is_none(), "pair ({a}, {b}) in two tiles");
            assert!(tile.owned.contains(&a), "{}: first image {a} not owned", tile.id);
            assert!(readable.contains(&b), "{}: second image {b} not readable", tile.id);
        }
        for c in &tile.context {
            assert!(!tile.owned.contains(c), "{}: context image {c} is also owned", tile.id);
            assert!(tile.pairs.iter().any(|&(_, b)| b == *c), "{}: context image {c} is in no pair", tile.id);
        }
    }
    let expected: Vec<(ImageId, ImageId)> = sites
        .windows(2)
        .filter(|w| (w[1].east - w[0].east).hypot(w[1].north - w[0].north) <= params.max_pair_distance)
        .map(|w| (w[0].id, w[1].id))
        .collect();
    assert_eq!(found.len(), expected.len(), "pairs planned vs. consecutive close sites");
    for pair in expected {
        assert!(found.contains_key(&pair), "pair ({}, {}) missing", pair.0, pair.1);
    }
}

fn check_fetch(sites: &[ImageSite], plan: &TilePlan, params: &TilingParams) {
    let by_id: BTreeMap<ImageId, &ImageSite> = sites.iter().map(|s| (s.id, s)).collect();
    for tile in plan.tiles() {
        let f = &tile.fetch;
        for id in tile.owned.iter().chain(&tile.context) {
            let s = by_id[id];
            let margins = [s.east - f.min_east, f.max_east - s.east, s.north - f.min_north, f.max_north - s.north];
            assert!(margins.iter().all(|&m| m >= params.overlap), "{}: image {id} margins {margins:?}", tile.id);
        }
    }
}

fn check_order(sites: &[ImageSite], plan: &TilePlan) {
    let position: BTreeMap<ImageId, usize> = sites.iter().enumerate().map(|(i, s)| (s.id, i)).collect();
    let in_capture_order = |list: &[ImageId]| list.windows(2).all(|w| position[&w[0]] < position[&w[1]]);
    for w in plan.tiles().windows(2) {
        assert!((w[0].id.row, w[0].id.col) < (w[1].id.row, w[1].id.col), "{} before {}", w[0].id, w[1].id);
    }
    for tile in plan.tiles() {
        assert!(in_capture_order(&tile.owned) && in_capture_order(&tile.context), "{}", tile.id);
        let firsts: Vec<ImageId> = tile.pairs.iter().map(|p| p.0).collect();
        assert!(in_capture_order(&firsts), "{}: pairs out of order", tile.id);
    }
}

fn check_deterministic(sites: &[ImageSite], plan: &TilePlan, params: &TilingParams, seed: u64) {
    let again = plan_ok(sites, params);
    assert_eq!(&again, plan);
    assert_eq!(format!("{again:?}"), format!("{plan:?}"));
    let mut shuffled = sites.to_vec();
    shuffled.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    shuffled.sort_by(|a, b| a.time.total_cmp(&b.time));
    assert_eq!(&plan_ok(&shuffled, params), plan);
}

fn plan_ok(sites: &[ImageSite], params: &TilingParams) -> TilePlan {
    plan(sites, params).expect("generated input is valid")
}

fn config() -> Config {
    Config {
        cases: 96,
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x706c_756d_626c_696e),
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn plans_hold_their_invariants(seed in any::<u64>(), param_seed in any::<u64>(), n in 0usize..1500) {
        let params = random_params(param_seed);
        let sites = random_campaign(seed, n, params.tile_size);
        let plan = plan_ok(&sites, &params);
        check_ownership(&sites, &plan, &params);
        check_pairs(&sites, &plan, &params);
        check_fetch(&sites, &plan, &params);
        check_order(&sites, &plan);
        check_deterministic(&sites, &plan, &params, seed);
        prop_assert_eq!(plan.summary().images, sites.len());
    }

    #[test]
    fn tile_id_round_trips(col in any::<i64>(), row in any::<i64>()) {
        let id = TileId { col, row };
        let text = id.to_string();
        prop_assert!(text.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'), "{}", text);
        prop_assert_eq!(text.parse::<TileId>(), Ok(id));
    }

    #[test]
    fn containing_matches_core(east in -1e7f64..1e7, north in -1e7f64..1e7, size in 0.01f64..1000.0) {
        let id = TileId::containing(east, north, size).expect("inside the grid");
        let core = id.core(size);
        prop_assert!(core.min_east <= east && east < core.max_east, "{:?} {}", core, east);
        prop_assert!(core.min_north <= north && north < core.max_north, "{:?} {}", core, north);
    }

    #[test]
    fn grid_lines_belong_to_the_cell_east_and_north(col in -100_000i64..100_000, row in -100_000i64..100_000, size in 0.01f64..1000.0) {
        let (east, north) = (col as f64 * size, row as f64 * size);
        prop_assert_eq!(TileId::containing(east, north, size), Some(TileId { col, row }));
        let (west, south) = (east.next_down(), north.next_down());
        prop_assert_eq!(TileId::containing(west, south, size), Some(TileId { col: col - 1, row: row - 1 }));
    }
}
