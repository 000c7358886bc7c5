//! Simple hand-made routes for tests and benchmarks: straight streets with junctions, a block driven
//! several times, and the canyons of typical streets. Campaigns drive `World::route` instead.

use crate::route::{Canyon, Route, Waypoint};

/// Speed limit of city streets, m/s (50 km/h).
pub const CITY_LIMIT: f64 = 50.0 / 3.6;

/// A deep canyon: 30 m buildings on a 15 m street (ratio 2).
pub const DEEP_CANYON: Canyon = Canyon { street_width: 15.0, building_height: 30.0 };
/// A typical inner-city street: 18 m buildings on a 24 m street (ratio 0.75).
pub const URBAN_STREET: Canyon = Canyon { street_width: 24.0, building_height: 18.0 };

/// A waypoint at (east, north) on flat ground at the city speed limit.
pub fn waypoint(east: f64, north: f64, canyon: Canyon) -> Waypoint {
    Waypoint { east, north, ground_height: 0.0, bank: 0.0, speed_limit: CITY_LIMIT, junction: false, canyon }
}

/// A straight street from `origin` heading east for `length` metres, with a junction every `block` metres.
pub fn straight(origin: (f64, f64), length: f64, block: f64, canyon: Canyon) -> Route {
    let n = (length / block).round().max(1.0) as usize;
    let waypoints = (0..=n)
        .map(|i| {
            let mut w = waypoint(origin.0 + length * i as f64 / n as f64, origin.1, canyon);
            w.junction = i > 0 && i < n;
            w
        })
        .collect();
    Route { waypoints }
}

/// `passes` times around a rectangular block of `width` × `height` metres (counter-clockwise, left turns),
/// starting at its south-west corner; every corner is a junction.
pub fn block_loop(origin: (f64, f64), width: f64, height: f64, passes: usize, canyon: Canyon) -> Route {
    let corners = [(width, 0.0), (width, height), (0.0, height), (0.0, 0.0)];
    let mut waypoints = vec![waypoint(origin.0, origin.1, canyon)];
    for _ in 0..passes {
        for (e, n) in corners {
            let mut w = waypoint(origin.0 + e, origin.1 + n, canyon);
            w.junction = true;
            waypoints.push(w);
        }
    }
    if let Some(last) = waypoints.last_mut() {
        last.junction = false;
    }
    Route { waypoints }
}
