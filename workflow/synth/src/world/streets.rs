//! The street network: a rotated, jittered grid with arterials, alleys, curved and diagonal streets.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::polyline::{self, P2};
use super::{Preset, WorldConfig};

/// Width of a kerbstone, metres.
pub const KERB: f64 = 0.15;

/// What kind of street, deciding width, speed, markings and furniture.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StreetClass {
    /// Narrow lane between facades, 4–6 m, no sidewalks or markings.
    Alley,
    /// Two-lane street with parking and sidewalks.
    Residential,
    /// Multi-lane road, 20–30 m between facades.
    Arterial,
}

impl StreetClass {
    /// Speed limit, m/s (20, 30, 50 km/h).
    pub fn speed_limit(self) -> f64 {
        match self {
            StreetClass::Alley => 20.0 / 3.6,
            StreetClass::Residential => 30.0 / 3.6,
            StreetClass::Arterial => 50.0 / 3.6,
        }
    }
}

/// One street between two junctions.
#[derive(Clone, Debug, PartialEq)]
pub struct Street {
    /// Index in [`super::World::streets`].
    pub id: u32,
    /// The street's class.
    pub class: StreetClass,
    /// Centreline from `from` to `to`, map easting/northing.
    pub points: Vec<P2>,
    /// Cumulative arc length of `points`.
    pub cum: Vec<f64>,
    /// Junction at the start.
    pub from: u32,
    /// Junction at the end.
    pub to: u32,
    /// Driving lanes in each direction.
    pub lanes: u32,
    /// Width of a driving lane, metres.
    pub lane_width: f64,
    /// Width of the parking strip on each side (0 when none), metres.
    pub parking: f64,
    /// Kerbstone width (0 for alleys), metres.
    pub kerb: f64,
    /// Sidewalk width on each side, metres.
    pub sidewalk: f64,
    /// Whether lane lines and crossings are painted (test area 1 of Jende et al. 2017 has a street without).
    pub markings: bool,
    /// Stable identity for texture choices: `id` in a preset world, the lattice edge's key in a city window.
    pub key: u32,
    /// Stable identities of the junctions at the start and the end (`from`, `to` in a preset world).
    pub end_keys: [u32; 2],
}

impl Street {
    /// Width of the carriageway between the kerbs, metres.
    pub fn carriageway(&self) -> f64 {
        2.0 * (f64::from(self.lanes) * self.lane_width + self.parking)
    }
    /// Half the distance between the building lines, metres.
    pub fn half_corridor(&self) -> f64 {
        self.carriageway() / 2.0 + self.kerb + self.sidewalk
    }
    /// Length of the centreline, metres.
    pub fn length(&self) -> f64 {
        self.cum.last().copied().unwrap_or(0.0)
    }
    /// Offset of the rightmost driving lane's centre (negative: right of travel from `from` to `to`).
    pub fn drive_offset(&self) -> f64 {
        -(self.parking + self.lane_width / 2.0)
    }
}

/// A junction node.
#[derive(Clone, Debug, PartialEq)]
pub struct Junction {
    /// Index in [`super::World::junctions`].
    pub id: u32,
    /// Position, map easting/northing.
    pub pos: P2,
    /// Radius of the junction area (no lane lines inside), metres.
    pub radius: f64,
    /// Streets meeting here.
    pub streets: Vec<u32>,
    /// Traffic lights stand at its corners.
    pub traffic_lights: bool,
}

fn grid_size(preset: Preset) -> (usize, usize, f64) {
    match preset {
        Preset::Tiny => (3, 2, 85.0),
        Preset::District => (4, 4, 100.0),
        Preset::City => (0, 0, 100.0),
    }
}

/// Generate junctions and streets.
pub fn generate(cfg: &WorldConfig) -> (Vec<Junction>, Vec<Street>) {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x5757_0001);
    let (nx, ny, spacing) = grid_size(cfg.preset);
    let angle = rng.random_range(-0.35..0.35f64);
    let (sa, ca) = angle.sin_cos();
    let mut junctions = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let x = (i as f64 - (nx - 1) as f64 / 2.0) * spacing + rng.random_range(-7.0..7.0);
            let y = (j as f64 - (ny - 1) as f64 / 2.0) * spacing + rng.random_range(-7.0..7.0);
            let pos = [cfg.origin_east + ca * x - sa * y, cfg.origin_north + sa * x + ca * y];
            let id = junctions.len() as u32;
            junctions.push(Junction { id, pos, radius: 0.0, streets: Vec::new(), traffic_lights: false });
        }
    }
    let node = |i: usize, j: usize| (j * nx + i) as u32;
    let mut edges: Vec<(u32, u32, bool)> = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            if i + 1 < nx {
                edges.push((node(i, j), node(i + 1, j), j == ny / 2));
            }
            if j + 1 < ny {
                edges.push((node(i, j), node(i, j + 1), i == nx / 2));
            }
        }
    }
    // Diagonals cut through blocks, as older radial roads do.
    let diagonals = if cfg.preset == Preset::Tiny { 1 } else { 2 };
    for k in 0..diagonals {
        let (i, j) = (k * 2 % (nx - 1), k % (ny - 1));
        edges.push((node(i, j), node(i + 1, j + 1), false));
    }
    let mut streets: Vec<Street> = Vec::new();
    for (n, &(a, b, arterial)) in edges.iter().enumerate() {
        let street = make_street(&mut rng, n as u32, &junctions, (a, b), arterial, n % 5 == 3);
        streets.push(street);
    }
    finish_junctions(&mut junctions, &streets);
    (junctions, streets)
}

pub(crate) fn make_street(
    rng: &mut ChaCha8Rng,
    id: u32,
    nodes: &[Junction],
    ends: (u32, u32),
    arterial: bool,
    alley: bool,
) -> Street {
    let (a, b) = (nodes[ends.0 as usize].pos, nodes[ends.1 as usize].pos);
    let class = if arterial {
        StreetClass::Arterial
    } else if alley {
        StreetClass::Alley
    } else {
        StreetClass::Residential
    };
    let (lanes, lane_width, parking, kerb, sidewalk, markings) = match class {
        StreetClass::Alley => (1, rng.random_range(2.0..3.0), 0.0, 0.0, 0.0, false),
        StreetClass::Residential => {
            let parking = if rng.random_bool(0.7) { 2.0 } else { 0.0 };
            (
                1,
                rng.random_range(2.9..3.3),
                parking,
                KERB,
                rng.random_range(2.0..3.2),
                id % 3 != 1 && rng.random_bool(0.7),
            )
        }
        StreetClass::Arterial => (2, rng.random_range(3.0..3.4), 2.0, KERB, rng.random_range(2.5..3.5), true),
    };
    let points = if class == StreetClass::Residential && rng.random_bool(0.3) {
        let bow = rng.random_range(6.0..11.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        polyline::bowed(a, b, bow, 4.0)
    } else {
        vec![a, b]
    };
    let cum = polyline::cumulative(&points);
    let (from, to) = ends;
    let (key, end_keys) = (id, [from, to]);
    Street { id, class, points, cum, from, to, lanes, lane_width, parking, kerb, sidewalk, markings, key, end_keys }
}

pub(crate) fn finish_junctions(junctions: &mut [Junction], streets: &[Street]) {
    for s in streets {
        for end in [s.from, s.to] {
            let j = &mut junctions[end as usize];
            j.streets.push(s.id);
            j.radius = j.radius.max(s.half_corridor() - s.sidewalk + 1.0);
            j.traffic_lights |= s.class == StreetClass::Arterial;
        }
    }
}
