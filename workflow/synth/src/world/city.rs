//! The unbounded city of the `city` preset: a jittered, rotated lattice of junctions 100 m apart whose every
//! random choice is a hash of (seed, node or edge), so any window is made on its own and overlapping windows
//! agree on what they share.
//!
//! Lattice edges run east and north from every node; some blocks have a diagonal (south-west to north-east).
//! Every fourth row and column is an arterial; a fifth of the other edges are alleys. A street's furniture
//! (poles, cars, buildings) is drawn from its own random stream and checked against the streets around its
//! two junctions only; a junction's traffic lights and tree groups likewise. A window ([`City::window_box`])
//! holds the streets at the lattice nodes covering a box, their furniture and that of the nodes.

use std::collections::{BTreeMap, BTreeSet};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::placement::{junction_poles, street_buildings, street_cars, street_pedestrians, street_poles};
use super::polyline::P2;
use super::streets::{Junction, Street, StreetClass, finish_junctions, make_street};
use super::{Building, Car, Content, Pedestrian, Pole, World, WorldConfig};

/// What one street carries: its poles, parked cars, buildings and pedestrians.
type StreetObjects = (Vec<Pole>, Vec<Car>, Vec<Building>, Vec<Pedestrian>);

/// Distance between neighbouring junctions, metres.
const SPACING: f64 = 100.0;
/// Largest shift of a junction from its lattice place, metres.
const JITTER: f64 = 7.0;
/// Every this many rows and columns is an arterial.
const ARTERIAL_EVERY: i32 = 4;
/// Share of the non-arterial edges that are alleys.
const ALLEY_SHARE: f64 = 0.2;
/// Share of the blocks with a diagonal street.
const DIAGONAL_SHARE: f64 = 0.08;

/// A lattice node.
pub type Node = (i32, i32);

/// A lattice edge: from node (`i`, `j`) east (`dir` 0), north (1) or north-east (2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct EdgeKey {
    /// Column of the start node.
    pub i: i32,
    /// Row of the start node.
    pub j: i32,
    /// Direction.
    pub dir: u8,
}

impl EdgeKey {
    /// Start and end node.
    pub fn ends(self) -> (Node, Node) {
        let (i, j) = (self.i, self.j);
        match self.dir {
            0 => ((i, j), (i + 1, j)),
            1 => ((i, j), (i, j + 1)),
            _ => ((i, j), (i + 1, j + 1)),
        }
    }

    /// A stable 32-bit identity (texture choices).
    pub fn key(self) -> u32 {
        (mix(0x57EE7, i64::from(self.i), i64::from(self.j), u64::from(self.dir)) >> 32) as u32
    }
}

/// Stable identity of a node (texture choices).
fn node_key(n: Node) -> u32 {
    (mix(0x40DE, i64::from(n.0), i64::from(n.1), 7) >> 32) as u32
}

/// Which object a pole came from, and its number there: the pole's identity across windows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PoleOwner {
    /// Along a street.
    Street(EdgeKey, u32),
    /// At a junction.
    Junction(Node, u32),
}

/// A window of the city: the world to render and ray-cast, and each pole's identity.
#[derive(Clone, Debug)]
pub struct CityWindow {
    /// The window's world (local ids).
    pub world: World,
    /// `owners[k]` made `world.poles[k]`.
    pub owners: Vec<PoleOwner>,
    /// The lattice edge of each street of `world`.
    pub edges: Vec<EdgeKey>,
}

/// The unbounded city of one seed.
#[derive(Clone, Debug)]
pub struct City {
    config: WorldConfig,
    sin_cos: (f64, f64),
}

fn mix(seed: u64, a: i64, b: i64, c: u64) -> u64 {
    let mut x = seed ^ (a as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (b as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    x ^= c.wrapping_mul(0x1656_67B1_9E37_79F9);
    for _ in 0..2 {
        x ^= x >> 31;
        x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x ^= x >> 29;
    }
    x
}

fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

impl City {
    /// The city of `config.seed` around `config.origin_*` (the preset field is ignored).
    pub fn new(config: &WorldConfig) -> Self {
        let angle = -0.35 + 0.7 * unit(mix(config.seed, 0, 0, 0xA61E));
        Self { config: WorldConfig { preset: super::Preset::City, ..config.clone() }, sin_cos: angle.sin_cos() }
    }

    /// The world configuration of every window.
    pub fn config(&self) -> &WorldConfig {
        &self.config
    }

    /// Position of a lattice node, map easting/northing.
    pub fn node(&self, (i, j): Node) -> P2 {
        let h = mix(self.config.seed, i64::from(i), i64::from(j), 0x40DE);
        let jx = JITTER * (2.0 * unit(h) - 1.0);
        let jy = JITTER * (2.0 * unit(h.rotate_left(21)) - 1.0);
        let (x, y) = (f64::from(i) * SPACING + jx, f64::from(j) * SPACING + jy);
        let (sa, ca) = self.sin_cos;
        [self.config.origin_east + ca * x - sa * y, self.config.origin_north + sa * x + ca * y]
    }

    /// The lattice coordinates (fractional) of a map point.
    fn lattice(&self, p: P2) -> (f64, f64) {
        let (sa, ca) = self.sin_cos;
        let (dx, dy) = (p[0] - self.config.origin_east, p[1] - self.config.origin_north);
        ((ca * dx + sa * dy) / SPACING, (-sa * dx + ca * dy) / SPACING)
    }

    fn has_diagonal(&self, (i, j): Node) -> bool {
        unit(mix(self.config.seed, i64::from(i), i64::from(j), 0xD1A6)) < DIAGONAL_SHARE
    }

    /// The edges at a node, in a fixed order.
    pub fn incident(&self, (i, j): Node) -> Vec<EdgeKey> {
        let mut out = vec![
            EdgeKey { i, j, dir: 0 },
            EdgeKey { i, j, dir: 1 },
            EdgeKey { i: i - 1, j, dir: 0 },
            EdgeKey { i, j: j - 1, dir: 1 },
        ];
        if self.has_diagonal((i, j)) {
            out.push(EdgeKey { i, j, dir: 2 });
        }
        if self.has_diagonal((i - 1, j - 1)) {
            out.push(EdgeKey { i: i - 1, j: j - 1, dir: 2 });
        }
        out
    }

    fn rng(&self, e: EdgeKey, purpose: u64) -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(mix(self.config.seed, i64::from(e.i), i64::from(e.j), u64::from(e.dir) + purpose))
    }

    /// The junctions and streets of `edges` (local ids), junction radii and traffic lights from all their edges.
    fn local(&self, edges: &[EdgeKey]) -> (Vec<Junction>, Vec<Street>, BTreeMap<Node, u32>) {
        let mut nodes: BTreeMap<Node, u32> = BTreeMap::new();
        for n in edges.iter().flat_map(|e| [e.ends().0, e.ends().1]) {
            let next = nodes.len() as u32;
            nodes.entry(n).or_insert(next);
        }
        let mut junctions =
            vec![Junction { id: 0, pos: [0.0; 2], radius: 0.0, streets: vec![], traffic_lights: false }; nodes.len()];
        for (&n, &id) in &nodes {
            junctions[id as usize] =
                Junction { id, pos: self.node(n), radius: 0.0, streets: vec![], traffic_lights: false };
        }
        let streets: Vec<Street> = edges
            .iter()
            .enumerate()
            .map(|(k, &e)| {
                let (a, b) = e.ends();
                self.street(e, k as u32, (nodes[&a], nodes[&b]), &junctions)
            })
            .collect();
        finish_junctions(&mut junctions, &streets);
        for (&n, &id) in &nodes {
            let (radius, lights) = self.junction_shape(n);
            let j = &mut junctions[id as usize];
            (j.radius, j.traffic_lights) = (radius, lights);
        }
        (junctions, streets, nodes)
    }

    /// A street of edge `e` with local id and ends.
    fn street(&self, e: EdgeKey, id: u32, ends: (u32, u32), junctions: &[Junction]) -> Street {
        let arterial = match e.dir {
            0 => e.j.rem_euclid(ARTERIAL_EVERY) == 0,
            1 => e.i.rem_euclid(ARTERIAL_EVERY) == 0,
            _ => false,
        };
        let alley = !arterial
            && unit(mix(self.config.seed, i64::from(e.i), i64::from(e.j), u64::from(e.dir) + 0xA11E)) < ALLEY_SHARE;
        let mut st = make_street(&mut self.rng(e, 0x5757_0001), e.key(), junctions, ends, arterial, alley);
        let (a, b) = e.ends();
        (st.id, st.end_keys) = (id, [node_key(a), node_key(b)]);
        st
    }

    /// Whether the street of edge `e` is straight (a leg may end halfway along it).
    pub fn is_straight(&self, e: EdgeKey) -> bool {
        let (a, b) = e.ends();
        let js = [
            Junction { id: 0, pos: self.node(a), radius: 0.0, streets: vec![], traffic_lights: false },
            Junction { id: 1, pos: self.node(b), radius: 0.0, streets: vec![], traffic_lights: false },
        ];
        self.street(e, 0, (0, 1), &js).points.len() == 2
    }

    /// Radius and traffic lights of a junction, from all its edges.
    fn junction_shape(&self, n: Node) -> (f64, bool) {
        let edges = self.incident(n);
        let mut radius: f64 = 0.0;
        let mut lights = false;
        let pos = [Junction { id: 0, pos: self.node(n), radius: 0.0, streets: vec![], traffic_lights: false }];
        for e in edges {
            let (a, b) = e.ends();
            let other = if a == n { b } else { a };
            let js = [pos[0].clone(), Junction { id: 1, pos: self.node(other), ..pos[0].clone() }];
            let ends = if a == n { (0, 1) } else { (1, 0) };
            let st = self.street(e, 0, ends, &js);
            radius = radius.max(st.half_corridor() - st.sidewalk + 1.0);
            lights |= st.class == StreetClass::Arterial;
        }
        (radius, lights)
    }

    /// The edges at the nodes within one step of `nodes`, sorted: what a street's or junction's furniture is
    /// checked against.
    fn around(&self, nodes: &[Node]) -> Vec<EdgeKey> {
        let mut set = BTreeSet::new();
        for &(i, j) in nodes {
            for di in -1..=1 {
                for dj in -1..=1 {
                    set.extend(self.incident((i + di, j + dj)));
                }
            }
        }
        set.into_iter().collect()
    }

    /// Traffic lights and tree groups of a junction.
    fn node_poles(&self, n: Node) -> Vec<Pole> {
        let edges = self.around(&[n]);
        let (junctions, streets, nodes) = self.local(&edges);
        let mut out = Vec::new();
        let mut rng = self.rng(EdgeKey { i: n.0, j: n.1, dir: 9 }, 0x5757_0002);
        let mut j = junctions[nodes[&n] as usize].clone();
        // Only the junction's own streets, in the lattice's order.
        j.streets = self.incident(n).iter().filter_map(|e| edges.binary_search(e).ok().map(|k| k as u32)).collect();
        junction_poles(&mut rng, &mut out, &streets, &j);
        out
    }

    /// Poles, cars, buildings and pedestrians of one street.
    fn street_objects(&self, e: EdgeKey) -> StreetObjects {
        let (a, b) = e.ends();
        let edges = self.around(&[a, b]);
        let (junctions, streets, _) = self.local(&edges);
        let Ok(k) = edges.binary_search(&e) else { return Default::default() };
        let st = &streets[k];
        let mut poles = Vec::new();
        street_poles(&mut self.rng(e, 0x5757_0002), &mut poles, st, &streets, &junctions);
        let mut cars = Vec::new();
        street_cars(&mut self.rng(e, 0x5757_0003), &mut cars, st, &streets, &junctions, self.config.ground_height);
        let mut keep_off = poles.clone();
        keep_off.extend(self.node_poles(a));
        keep_off.extend(self.node_poles(b));
        let mut buildings = Vec::new();
        let context = (&streets[..], &junctions[..], &keep_off[..]);
        street_buildings(&mut self.rng(e, 0x5757_0004), &mut buildings, st, context, self.config.ground_height);
        let mut pedestrians = Vec::new();
        street_pedestrians(&mut self.rng(e, 0x5757_0007), &mut pedestrians, st, &junctions, &self.config);
        (poles, cars, buildings, pedestrians)
    }

    /// The lattice nodes whose cells cover the box `[lo, hi]`.
    pub fn nodes_covering(&self, lo: P2, hi: P2) -> Vec<Node> {
        let corners = [lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]].map(|p| self.lattice(p));
        let (i0, i1) = corners.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), c| (a.min(c.0), b.max(c.0)));
        let (j0, j1) = corners.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), c| (a.min(c.1), b.max(c.1)));
        let mut out = Vec::new();
        for i in (i0.floor() as i32)..=(i1.ceil() as i32) {
            for j in (j0.floor() as i32)..=(j1.ceil() as i32) {
                out.push((i, j));
            }
        }
        out
    }

    /// The window of everything at the nodes covering `[lo, hi]`: their streets (also those leading out), the
    /// furniture of those streets and of the nodes.
    pub fn window_box(&self, lo: P2, hi: P2) -> CityWindow {
        let inner = self.nodes_covering(lo, hi);
        let edges: Vec<EdgeKey> =
            inner.iter().flat_map(|&n| self.incident(n)).collect::<BTreeSet<_>>().into_iter().collect();
        let (junctions, streets, _) = self.local(&edges);
        let mut content = Content { junctions, streets, ..Content::default() };
        let mut owners = Vec::new();
        for &n in &inner {
            for (k, p) in self.node_poles(n).into_iter().enumerate() {
                owners.push(PoleOwner::Junction(n, k as u32));
                content.poles.push(p);
            }
        }
        for &e in &edges {
            let (poles, cars, buildings, pedestrians) = self.street_objects(e);
            for (k, p) in poles.into_iter().enumerate() {
                owners.push(PoleOwner::Street(e, k as u32));
                content.poles.push(p);
            }
            content.cars.extend(cars);
            content.buildings.extend(buildings);
            content.pedestrians.extend(pedestrians);
        }
        for (k, p) in content.poles.iter_mut().enumerate() {
            p.id = k as u32;
        }
        CityWindow { world: World::assemble(&self.config, content), owners, edges }
    }

    /// The window of the nodes covering the square of half side `half` around `centre`.
    pub fn window(&self, centre: P2, half: f64) -> World {
        self.window_box([centre[0] - half, centre[1] - half], [centre[0] + half, centre[1] + half]).world
    }
}
