//! The unbounded city and its legs: overlapping windows agree on everything they share, windows hold what a
//! preset world holds, and consecutive legs (true drive and DG error) join without a jump.
#![allow(clippy::unwrap_used)]

use std::collections::HashMap;

use plumbline_synth::motion::dg::{DgConfig, DgStream};
use plumbline_synth::motion::routes::DEEP_CANYON;
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::world::city::{City, PoleOwner};
use plumbline_synth::world::city_route::CityWalk;
use plumbline_synth::world::{Preset, WorldConfig};

fn city(seed: u64) -> City {
    City::new(&WorldConfig::new(Preset::City, seed))
}

#[test]
fn overlapping_windows_agree_on_shared_streets_poles_and_buildings() {
    let c = city(3);
    let o = [c.config().origin_east, c.config().origin_north];
    let a = c.window_box([o[0] - 150.0, o[1] - 150.0], [o[0] + 150.0, o[1] + 150.0]);
    let b = c.window_box([o[0] + 50.0, o[1] - 100.0], [o[0] + 350.0, o[1] + 200.0]);
    let poles_of = |w: &plumbline_synth::world::city::CityWindow| -> HashMap<PoleOwner, _> {
        w.owners.iter().copied().zip(w.world.poles.iter().map(|p| (p.base, p.diameter, p.class, p.lean))).collect()
    };
    let (pa, pb) = (poles_of(&a), poles_of(&b));
    let shared: Vec<_> = pa.keys().filter(|k| pb.contains_key(k)).collect();
    assert!(shared.len() > 30, "{} shared poles", shared.len());
    for k in shared {
        assert_eq!(pa[k], pb[k], "{k:?}");
    }
    // Streets of the same lattice edge are the same street; their buildings too.
    let mut streets = 0;
    for (ka, e) in a.edges.iter().enumerate() {
        let Ok(kb) = b.edges.binary_search(e) else { continue };
        let (sa, sb) = (&a.world.streets[ka], &b.world.streets[kb]);
        assert_eq!(
            (&sa.points, sa.class, sa.lane_width, sa.key, sa.end_keys),
            (&sb.points, sb.class, sb.lane_width, sb.key, sb.end_keys)
        );
        streets += 1;
    }
    assert!(streets >= 8, "{streets} shared streets");
    let centre = |bl: &plumbline_synth::world::Building| (bl.shape.center[0].to_bits(), bl.shape.center[1].to_bits());
    let in_b: std::collections::HashSet<_> = b.world.buildings.iter().map(centre).collect();
    let shared_buildings = a.world.buildings.iter().filter(|bl| in_b.contains(&centre(bl))).count();
    assert!(shared_buildings > 40, "{shared_buildings} shared buildings");
}

#[test]
fn a_window_is_a_city_with_every_kind_of_street_and_object() {
    let c = city(1);
    let o = [c.config().origin_east, c.config().origin_north];
    let w = c.window_box([o[0] - 250.0, o[1] - 250.0], [o[0] + 250.0, o[1] + 250.0]).world;
    use plumbline_synth::world::{PoleClass, StreetClass};
    for class in [StreetClass::Alley, StreetClass::Residential, StreetClass::Arterial] {
        assert!(w.streets.iter().any(|s| s.class == class), "{class:?}");
    }
    for class in [PoleClass::StreetLight, PoleClass::SignPost, PoleClass::TrafficLight, PoleClass::Tree] {
        assert!(w.poles.iter().filter(|p| p.class == class).count() >= 3, "{class:?}");
    }
    assert!(w.buildings.len() > 100 && w.cars.len() > 50, "{} buildings {} cars", w.buildings.len(), w.cars.len());
    assert!(w.street_length() > 3000.0, "{} m of streets", w.street_length());
}

#[test]
fn legs_join_without_a_jump_in_the_true_or_the_dg_trajectory() {
    let seed = 7;
    let mut walk = CityWalk::new(city(seed), seed, 300.0);
    let mut dg = DgStream::new(&DgConfig::default(), seed).unwrap();
    let mut start_time = DriveConfig::default().start_time;
    let mut last: Option<(plumbline_geo::TrajectoryRecord, plumbline_geo::Vec3<plumbline_geo::Map>)> = None;
    let mut joins = 0;
    let mut far = 0.0f64;
    for _ in 0..4 {
        let leg = walk.next_leg();
        let config = DriveConfig { start_time, start_dwell: 5.0, end_dwell: 5.0, ..DriveConfig::default() };
        let drive = Drive::simulate(&leg.route.with_canyon(DEEP_CANYON), &config, seed + leg.index as u64).unwrap();
        let sol = dg.leg(&drive).unwrap();
        let first = drive.trajectory.records()[0];
        if let Some((prev, prev_err)) = last {
            assert!((first.time - prev.time - 1.0 / config.rate_hz).abs() < 1e-9);
            let gap = (first.position.p - prev.position.p).norm();
            let turn = (first.attitude.heading - prev.attitude.heading).abs();
            assert!(gap < 0.005 && turn.min(std::f64::consts::TAU - turn) < 1e-3, "gap {gap} m, turn {turn} rad");
            // Canyon drift σ 5 / 15 cm: a restarted process would jump by centimetres; white noise is 0.5 / 1 mm.
            let jump = (sol.errors[0].position.v - prev_err.v).norm();
            assert!(jump < 0.006, "DG error jumps {jump} m at join {joins}");
            joins += 1;
        }
        far = far.max(sol.errors.iter().map(|e| e.position.v.norm()).fold(0.0, f64::max));
        let (end, err) = (*drive.trajectory.records().last().unwrap(), sol.errors.last().unwrap().position);
        last = Some((end, err));
        start_time = end.time + 1.0 / config.rate_hz;
    }
    assert_eq!(joins, 3);
    // The process is alive (canyon level), so small joins are not from a zero error.
    assert!(far > 0.05, "largest DG error {far} m");
}
