//! Driving the world's routes (part A): the motion and DG models work on dense, junction-flagged waypoints.
#![allow(clippy::unwrap_used)]

use plumbline_synth::motion::dg::{self, DgConfig, Environment};
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::world::{Preset, World, WorldConfig};

#[test]
fn world_routes_drive_at_city_speeds_with_junction_stops() {
    for seed in 0..3 {
        let world = World::generate(&WorldConfig::new(Preset::Tiny, seed)).unwrap();
        let route = world.route(seed, 800.0);
        let config = DriveConfig { rate_hz: 100.0, ..DriveConfig::default() };
        let drive = Drive::simulate(&route, &config, seed).unwrap();
        let k = &drive.kinematics;
        let length = k.last().unwrap().distance;
        let limit = route.waypoints.iter().map(|w| w.speed_limit).fold(0.0, f64::max);
        let vmax = k.iter().map(|e| e.speed).fold(0.0, f64::max);
        let moving: Vec<f64> = k.iter().map(|e| e.speed).filter(|&v| v > 0.5).collect();
        let mean = moving.iter().sum::<f64>() / moving.len() as f64;
        let junctions = route.waypoints.iter().filter(|w| w.junction).count();
        println!(
            "seed {seed}: {length:.0} m, {:.0} s, mean moving speed {mean:.1} m/s, max {vmax:.1} (limit {limit:.1}), {} stops, {junctions} junction waypoints",
            k.last().unwrap().time - k[0].time,
            drive.stops.len()
        );
        assert!(length > 750.0);
        assert!(vmax <= limit * config.cruise_factor + 1e-6);
        // Between junctions (~85 m apart) the vehicle gets up to the cruise speed of the slowest streets.
        let slowest = route.waypoints.iter().map(|w| w.speed_limit).fold(f64::INFINITY, f64::min);
        assert!(vmax >= 0.95 * slowest * config.cruise_factor, "seed {seed}: max speed {vmax}");
        // One stopping chance per junction: the entry and exit waypoints of a crossing do not both stop.
        let mut clusters = 0;
        let mut last = f64::NEG_INFINITY;
        let mut along = 0.0;
        for (i, w) in route.waypoints.iter().enumerate() {
            if i > 0 {
                let p = &route.waypoints[i - 1];
                along += (w.east - p.east).hypot(w.north - p.north);
            }
            if w.junction && along - std::mem::replace(&mut last, along) >= 30.0 {
                clusters += 1;
            }
        }
        assert!(drive.stops.len() <= clusters + 2, "seed {seed}: {} stops at {clusters} junctions", drive.stops.len());
        let dg = dg::simulate(&drive, &DgConfig::default(), seed).unwrap();
        let enclosed = dg.errors.iter().filter(|e| e.environment != Environment::Open).count();
        println!(
            "seed {seed}: {} faults, {:.0} % of epochs enclosed",
            dg.faults.len(),
            100.0 * enclosed as f64 / k.len() as f64
        );
    }
}
