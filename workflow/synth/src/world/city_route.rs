//! Drives through the unbounded city in legs: a walk over the lattice that prefers streets not yet driven,
//! cut into legs of about `leg_length` metres, each ending halfway along a straight street where the next leg
//! starts, so consecutive legs join without a jump in position or heading. Each leg comes with the city window
//! around it; nothing of earlier legs is kept but the set of driven edges.

use std::collections::HashSet;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::city::{City, CityWindow, EdgeKey, Node};
use crate::route::{Route, Waypoint};

/// Context around a leg's junctions in its window, metres (what the cameras see beyond the driven streets).
const MARGIN: f64 = 120.0;

/// One leg of a city drive.
#[derive(Clone, Debug)]
pub struct Leg {
    /// Number of the leg, from 0.
    pub index: usize,
    /// The waypoints, in the window's world.
    pub route: Route,
    /// The city around the leg.
    pub window: CityWindow,
}

/// A walk through the city that yields legs.
#[derive(Debug)]
pub struct CityWalk {
    city: City,
    rng: ChaCha8Rng,
    node: Node,
    came: Option<EdgeKey>,
    visited: HashSet<EdgeKey>,
    carry: Option<(EdgeKey, bool)>,
    leg_length: f64,
    index: usize,
}

impl CityWalk {
    /// A walk from the lattice node at the city's origin; legs of about `leg_length` metres.
    pub fn new(city: City, seed: u64, leg_length: f64) -> Self {
        let rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5757_0C17);
        Self { city, rng, node: (0, 0), came: None, visited: HashSet::new(), carry: None, leg_length, index: 0 }
    }

    /// The next leg.
    pub fn next_leg(&mut self) -> Leg {
        let plan = self.plan();
        let nodes: Vec<Node> = plan.iter().flat_map(|(e, _)| [e.ends().0, e.ends().1]).collect();
        let pts: Vec<[f64; 2]> = nodes.iter().map(|&n| self.city.node(n)).collect();
        let lo = pts.iter().fold([f64::INFINITY; 2], |a, p| [a[0].min(p[0]), a[1].min(p[1])]);
        let hi = pts.iter().fold([f64::NEG_INFINITY; 2], |a, p| [a[0].max(p[0]), a[1].max(p[1])]);
        let window = self.city.window_box([lo[0] - MARGIN, lo[1] - MARGIN], [hi[0] + MARGIN, hi[1] + MARGIN]);
        let starts_inside = self.carry.take().is_some();
        let mut waypoints: Vec<Waypoint> = Vec::new();
        let last = plan.len() - 1;
        for (k, &(e, forward)) in plan.iter().enumerate() {
            let Ok(id) = window.edges.binary_search(&e) else { continue };
            let mut w = window.world.drive(&window.world.streets[id], forward);
            let mid = w.len() / 2;
            if k == last {
                w.truncate(mid + 1);
                self.carry = Some((e, forward));
            }
            if k == 0 && starts_inside {
                w.drain(..mid);
            }
            waypoints.extend(w);
        }
        let index = self.index;
        self.index += 1;
        Leg { index, route: Route { waypoints }, window }
    }

    /// The edges of the next leg: the carried half street, then a walk until the length is reached on a
    /// straight street.
    fn plan(&mut self) -> Vec<(EdgeKey, bool)> {
        let mut plan: Vec<(EdgeKey, bool)> = self.carry.into_iter().collect();
        let mut length = if plan.is_empty() { 0.0 } else { 0.5 * self.edge_length(plan[0].0) };
        loop {
            let (e, forward) = self.step();
            plan.push((e, forward));
            length += self.edge_length(e);
            if length >= self.leg_length && self.city.is_straight(e) && plan.len() > 1 {
                return plan;
            }
        }
    }

    fn edge_length(&self, e: EdgeKey) -> f64 {
        let (a, b) = e.ends();
        let (p, q) = (self.city.node(a), self.city.node(b));
        (p[0] - q[0]).hypot(p[1] - q[1])
    }

    /// Walk one edge from the current node: not back the way it came; streets not yet driven weigh 4, others 1.
    fn step(&mut self) -> (EdgeKey, bool) {
        let options: Vec<EdgeKey> =
            self.city.incident(self.node).into_iter().filter(|e| Some(*e) != self.came).collect();
        let weights: Vec<f64> = options.iter().map(|e| if self.visited.contains(e) { 1.0 } else { 4.0 }).collect();
        let mut pick = self.rng.random_range(0.0..weights.iter().sum::<f64>());
        let mut chosen = options[0];
        for (o, w) in options.iter().zip(&weights) {
            chosen = *o;
            if pick < *w {
                break;
            }
            pick -= w;
        }
        let (a, b) = chosen.ends();
        let forward = a == self.node;
        self.node = if forward { b } else { a };
        self.came = Some(chosen);
        self.visited.insert(chosen);
        (chosen, forward)
    }
}

/// The first `length` metres (horizontal, along the waypoints) of `route`: the waypoints before that point
/// and a last one there, interpolated in position and ground height, with the speed limit and canyon of its
/// segment and no junction. The whole route if it is not longer; at least its first segment's start.
pub fn cut(route: &Route, length: f64) -> Route {
    let w = &route.waypoints;
    let mut out: Vec<Waypoint> = w.iter().take(1).copied().collect();
    let mut driven = 0.0;
    for pair in w.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let step = (b.east - a.east).hypot(b.north - a.north);
        if driven + step < length {
            driven += step;
            out.push(*b);
            continue;
        }
        let u = if step > 0.0 { ((length - driven) / step).clamp(0.0, 1.0) } else { 0.0 };
        let lerp = |x: f64, y: f64| x + u * (y - x);
        let end = Waypoint {
            east: lerp(a.east, b.east),
            north: lerp(a.north, b.north),
            ground_height: lerp(a.ground_height, b.ground_height),
            bank: lerp(a.bank, b.bank),
            junction: u >= 1.0 && b.junction,
            ..*a
        };
        if u > 0.0 {
            out.push(end);
        }
        break;
    }
    Route { waypoints: out }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{Preset, WorldConfig};

    fn length(route: &Route) -> f64 {
        route.waypoints.windows(2).map(|p| (p[1].east - p[0].east).hypot(p[1].north - p[0].north)).sum()
    }

    #[test]
    fn a_cut_route_is_the_first_metres_of_the_route() {
        let mut walk = CityWalk::new(City::new(&WorldConfig::new(Preset::City, 5)), 5, 400.0);
        let route = walk.next_leg().route;
        let full = length(&route);
        assert!(full > 400.0, "{full} m");
        for want in [3.0, 57.3, 211.0, full - 1.0] {
            let cut = cut(&route, want);
            assert!((length(&cut) - want).abs() < 1e-9, "{want} m: cut to {} m", length(&cut));
            let n = cut.waypoints.len();
            // Every waypoint but the last is the route's own; the last lies on the route's segment after them.
            assert_eq!(cut.waypoints[..n - 1], route.waypoints[..n - 1]);
            let (a, b, end) = (route.waypoints[n - 2], route.waypoints[n - 1], cut.waypoints[n - 1]);
            let cross = (b.east - a.east) * (end.north - a.north) - (b.north - a.north) * (end.east - a.east);
            assert!(cross.abs() < 1e-6 && !end.junction, "{end:?} off the segment {a:?} → {b:?}");
        }
        assert_eq!(cut(&route, full + 10.0), route);
    }
}
