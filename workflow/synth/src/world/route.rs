//! Drives through the world: a random walk over the street graph that prefers streets not yet driven but
//! passes some twice, on the right-hand lane, with junction flags, speed limits and the urban canyon.

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::polyline::{self, P2};
use super::trace::hit_box;
use super::{Street, World};
use crate::route::{Canyon, Route, Waypoint};

/// Waypoint spacing along a street, metres.
const STEP: f64 = 4.0;
/// How far the canyon probe looks sideways, metres.
const PROBE: f64 = 50.0;

impl World {
    /// A drive of at least `target_length_m` metres (or until the walk has visited each street 3 times).
    pub fn route(&self, seed: u64, target_length_m: f64) -> Route {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5757_0005);
        let mut visits = vec![0u32; self.streets.len()];
        let mut waypoints: Vec<Waypoint> = Vec::new();
        let mut length = 0.0;
        if self.streets.is_empty() {
            return Route::default();
        }
        let (mut street, mut forward) = (rng.random_range(0..self.streets.len()), rng.random_bool(0.5));
        let cap = 3 * self.streets.len() as u32 + 3;
        while length < target_length_m && visits.iter().sum::<u32>() < cap {
            visits[street] += 1;
            for w in self.drive(&self.streets[street], forward) {
                if let Some(last) = waypoints.last() {
                    length += polyline::dist([last.east, last.north], [w.east, w.north]);
                }
                waypoints.push(w);
            }
            let st = &self.streets[street];
            let node = if forward { st.to } else { st.from };
            (street, forward) = self.next_street(&mut rng, node, street, &visits);
        }
        Route { waypoints }
    }

    fn next_street(&self, rng: &mut ChaCha8Rng, node: u32, came: usize, visits: &[u32]) -> (usize, bool) {
        let options: Vec<usize> =
            self.junctions[node as usize].streets.iter().map(|&s| s as usize).filter(|&s| s != came).collect();
        if options.is_empty() {
            let st = &self.streets[came];
            return (came, st.from == node);
        }
        // Unvisited streets weigh 4, visited ones 1: most streets are driven once, some twice or more.
        let weights: Vec<f64> = options.iter().map(|&s| if visits[s] == 0 { 4.0 } else { 1.0 }).collect();
        let mut pick = rng.random_range(0.0..weights.iter().sum::<f64>());
        let mut chosen = options[0];
        for (o, w) in options.iter().zip(&weights) {
            chosen = *o;
            if pick < *w {
                break;
            }
            pick -= w;
        }
        (chosen, self.streets[chosen].from == node)
    }

    /// Waypoints along one street in one direction, on the right-hand driving lane.
    pub(crate) fn drive(&self, st: &Street, forward: bool) -> Vec<Waypoint> {
        let mut pts = st.points.clone();
        let (mut j0, mut j1) = (st.from, st.to);
        if !forward {
            pts.reverse();
            std::mem::swap(&mut j0, &mut j1);
        }
        let cum = polyline::cumulative(&pts);
        let (s0, s1) = (self.junctions[j0 as usize].radius, st.length() - self.junctions[j1 as usize].radius);
        let n = (((s1 - s0) / STEP).ceil() as usize).max(1);
        (0..=n)
            .map(|k| {
                let s = s0 + (s1 - s0) * k as f64 / n as f64;
                let (p, tan) = polyline::point_at(&pts, &cum, s);
                let t = st.drive_offset();
                let pos = [p[0] - tan[1] * t, p[1] + tan[0] * t];
                Waypoint {
                    east: pos[0],
                    north: pos[1],
                    ground_height: self.ground_at(pos[0], pos[1]),
                    bank: {
                        let g = self.hill_gradient(pos[0], pos[1]);
                        -tan[1] * g[0] + tan[0] * g[1]
                    },
                    speed_limit: st.class.speed_limit(),
                    junction: k == 0 || k == n,
                    canyon: self.canyon(pos, tan),
                }
            })
            .collect()
    }

    /// Street width between the building fronts across `tangent` and their mean height, by horizontal probes
    /// 2 m above the road (the enclosure that decides GNSS quality, Cazzaniga et al. 2007 §1.2, Meyer et al. 2023 §3).
    pub fn canyon(&self, p: P2, tangent: P2) -> Canyon {
        let o = Vector3::new(p[0], p[1], self.ground_at(p[0], p[1]) + 2.0);
        let mut width = 0.0;
        let mut heights = 0.0;
        let mut found = 0;
        for side in [1.0, -1.0] {
            let d = Vector3::new(-tangent[1] * side, tangent[0] * side, 0.0);
            let hit = self
                .buildings
                .iter()
                .filter(|b| polyline::dist(b.shape.center, p) < PROBE + b.shape.radius())
                .filter_map(|b| hit_box(&b.shape, &o, &d).map(|h| (h.t, b.shape.height)))
                .filter(|(t, _)| *t <= PROBE)
                .min_by(|a, b| a.0.total_cmp(&b.0));
            match hit {
                Some((t, h)) => {
                    width += t;
                    heights += h;
                    found += 1;
                }
                None => width += PROBE,
            }
        }
        if found == 0 {
            return Canyon::OPEN;
        }
        Canyon { street_width: width, building_height: heights / 2.0 }
    }
}
