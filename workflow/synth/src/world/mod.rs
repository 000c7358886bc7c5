//! The procedural city: streets, junctions, buildings, pole-like objects and parked cars, deterministic from a
//! seed, in the campaign's projected CRS around a configurable origin.
//!
//! Streets form a rotated, jittered grid with arterials (20–30 m between facades), residential streets (some
//! curved, some without markings) and alleys (4–6 m), plus diagonals that make acute junctions. Buildings
//! (10–40 m) line the streets; street lights, sign posts and trees stand on the sidewalks, traffic lights and
//! tree groups at junctions; cars park in the parking strips, differently at the two epochs; pedestrians and
//! crowns spreading over the road in the aerial flight are [`EpochChanges`] (none by default). The ground is flat
//! at `ground_height`, or has hills, crowned carriageways and kerbs ([`Relief`], `relief`); everything stands
//! on it. Everything is held in memory with uniform grids for the texture and the ray caster.
//!
//! Sizes: `tiny` (about 700 m of streets, for tests) and `district` (about 2.6 km). The `city` ([`city`]) is
//! unbounded: every random choice is a hash of (seed, lattice node or edge), so any window of it is made on its
//! own and overlapping windows agree on everything they share.

pub mod city;
pub mod city_route;
mod index;
pub mod objects;
mod place;
mod placement;
pub mod polyline;
mod relief;
mod route;
pub mod streets;
mod trace;

pub use index::Grid;
pub use objects::{BoxShape, Building, Car, Pedestrian, Pole, PoleClass};
pub(crate) use place::Place;
pub use relief::Relief;
pub use streets::{Junction, Street, StreetClass};
pub use trace::{Hit, Surface};

use polyline::P2;

/// How big a world to make.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Preset {
    /// 3 × 2 junctions ~85 m apart: about 700 m of streets, for tests.
    Tiny,
    /// 4 × 4 junctions 100 m apart: about 2.6 km of streets, the accuracy benchmark.
    District,
    /// The unbounded city of [`city::City`]; `World::generate` makes its window of 150 m around the origin.
    City,
}

/// Parameters of a world.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldConfig {
    /// Size preset.
    pub preset: Preset,
    /// Seed of every random choice.
    pub seed: u64,
    /// EPSG code of the projected CRS the coordinates are in.
    pub epsg: u32,
    /// Easting of the world's centre, metres.
    pub origin_east: f64,
    /// Northing of the world's centre, metres.
    pub origin_north: f64,
    /// Height of the ground (of the hills' mean with relief), metres.
    pub ground_height: f64,
    /// What differs between the epochs beyond parked cars, paint and light.
    pub changes: EpochChanges,
    /// Hills, cross-fall and kerbs ([`Relief::FLAT`] by default).
    pub relief: Relief,
}

impl WorldConfig {
    /// Defaults: EPSG 25832 around E 565 000, N 5 933 000, flat ground at 8 m, no further epoch changes.
    pub fn new(preset: Preset, seed: u64) -> Self {
        Self {
            preset,
            seed,
            epsg: 25832,
            origin_east: 565_000.0,
            origin_north: 5_933_000.0,
            ground_height: 8.0,
            changes: EpochChanges::NONE,
            relief: Relief::FLAT,
        }
    }
}

/// Changes between the epochs that hide the ground from one of them: tree crowns spreading over the road in
/// the aerial flight (flown in full leaf, the drive after pruning or in spring), and pedestrians on the
/// sidewalks and zebra crossings, different people at each epoch. Parked cars, repainted or worn markings
/// and the sun differ at every level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EpochChanges {
    /// Horizontal growth of every tree crown in the aerial epoch (1: as in the drive). A crown of radius r
    /// becomes an ellipsoid r × spread wide and r tall, over the road beside its tree.
    pub crown_spread: f64,
    /// Pedestrians per 100 m of street at each epoch (on the sidewalks, and a third of them on the zebra
    /// crossings at the street's ends).
    pub pedestrians_per_100m: f64,
}

impl EpochChanges {
    /// Nothing beyond cars, paint and light.
    pub const NONE: Self = Self { crown_spread: 1.0, pedestrians_per_100m: 0.0 };
}

/// The two acquisition times a campaign mixes: the mobile-mapping drive and the (older) aerial flight.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Epoch {
    /// When the vehicle drove.
    Mobile,
    /// When the aerial block was flown.
    Aerial,
}

/// A world configuration that cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum WorldError {
    /// A field is not finite or out of its range.
    #[error("world config field `{field}` = {value}: {reason}")]
    InvalidConfig { field: &'static str, value: f64, reason: &'static str },
}

/// An item an object-grid cell refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Item {
    /// Index into `buildings`.
    Building(u32),
    /// Index into `poles`.
    Pole(u32),
    /// Index into `cars`.
    Car(u32),
    /// Index into `pedestrians`.
    Pedestrian(u32),
}

/// What a world holds before it is indexed.
#[derive(Clone, Debug, Default)]
pub(crate) struct Content {
    pub junctions: Vec<Junction>,
    pub streets: Vec<Street>,
    pub buildings: Vec<Building>,
    pub poles: Vec<Pole>,
    pub cars: Vec<Car>,
    pub pedestrians: Vec<Pedestrian>,
}

/// The generated world.
#[derive(Clone, Debug, PartialEq)]
pub struct World {
    /// What it was made from.
    pub config: WorldConfig,
    /// Junction nodes.
    pub junctions: Vec<Junction>,
    /// Streets between junctions.
    pub streets: Vec<Street>,
    /// Building blocks.
    pub buildings: Vec<Building>,
    /// Pole-like objects (the true positions a cadastre is derived from).
    pub poles: Vec<Pole>,
    /// Parked cars of both epochs.
    pub cars: Vec<Car>,
    /// Pedestrians of both epochs.
    pub pedestrians: Vec<Pedestrian>,
    /// Street segments (street, segment) near each cell, for texture queries.
    pub(crate) street_grid: Grid<(u32, u32)>,
    /// Junctions near each cell.
    pub(crate) junction_grid: Grid<u32>,
    /// Objects overlapping each cell, for ray casting.
    pub(crate) object_grid: Grid<Item>,
    /// Tallest object top, metres.
    pub(crate) top: f64,
    /// Tallest object top per object-grid cell, metres (rays above it skip the cell).
    pub(crate) cell_top: Vec<f64>,
    /// The hills under everything (none on flat ground).
    pub(crate) hills: relief::Hills,
    /// Ground height at each pole's base, metres.
    pub(crate) pole_ground: Vec<f64>,
}

const CELL: f64 = 8.0;
/// How far a building on relief reaches below the lowest ground under it, metres.
const FOUNDATION_M: f64 = 0.3;

impl World {
    /// Generate a world; the same config gives the same world.
    pub fn generate(config: &WorldConfig) -> Result<World, WorldError> {
        for (field, value) in [
            ("origin_east", config.origin_east),
            ("origin_north", config.origin_north),
            ("ground_height", config.ground_height),
            ("changes.crown_spread", config.changes.crown_spread),
            ("changes.pedestrians_per_100m", config.changes.pedestrians_per_100m),
            ("relief.grade", config.relief.grade),
            ("relief.cross_fall", config.relief.cross_fall),
            ("relief.kerb_m", config.relief.kerb_m),
        ] {
            if !value.is_finite() {
                return Err(WorldError::InvalidConfig { field, value, reason: "must be finite" });
            }
        }
        let c = config.changes;
        if !(1.0..=3.0).contains(&c.crown_spread) {
            let (field, value) = ("changes.crown_spread", c.crown_spread);
            return Err(WorldError::InvalidConfig { field, value, reason: "must be within 1–3" });
        }
        if !(0.0..=100.0).contains(&c.pedestrians_per_100m) {
            let (field, value) = ("changes.pedestrians_per_100m", c.pedestrians_per_100m);
            return Err(WorldError::InvalidConfig { field, value, reason: "must be within 0–100" });
        }
        let r = config.relief;
        for (field, value, max) in [
            ("relief.grade", r.grade, 0.15),
            ("relief.cross_fall", r.cross_fall, 0.05),
            ("relief.kerb_m", r.kerb_m, 0.3),
        ] {
            if !(0.0..=max).contains(&value) {
                return Err(WorldError::InvalidConfig {
                    field,
                    value,
                    reason: "must be within 0 and its maximum (grade 0.15, cross-fall 0.05, kerb 0.3 m)",
                });
            }
        }
        if config.preset == Preset::City {
            return Ok(city::City::new(config).window([config.origin_east, config.origin_north], 150.0));
        }
        let (junctions, streets) = streets::generate(config);
        let poles = placement::poles(config.seed, &streets, &junctions);
        let cars = placement::cars(config.seed, &streets, &junctions, config.ground_height);
        let buildings = placement::buildings(config.seed, &streets, &junctions, &poles, config.ground_height);
        let pedestrians = placement::pedestrians(config, &streets, &junctions);
        Ok(World::assemble(config, Content { junctions, streets, buildings, poles, cars, pedestrians }))
    }

    /// A world of the given content, indexed for texture queries and ray casting.
    pub(crate) fn assemble(config: &WorldConfig, content: Content) -> World {
        let Content { junctions, streets, buildings, poles, cars, pedestrians } = content;
        let (min, max) = bounds(&streets);
        let mut world = World {
            config: config.clone(),
            street_grid: Grid::new(min, max, CELL),
            junction_grid: Grid::new(min, max, CELL),
            object_grid: Grid::new(min, max, CELL),
            top: config.ground_height,
            cell_top: Vec::new(),
            hills: relief::Hills::new(config.seed, [config.origin_east, config.origin_north], config.relief.grade),
            pole_ground: Vec::new(),
            junctions,
            streets,
            buildings,
            poles,
            cars,
            pedestrians,
        };
        world.build_index();
        world
    }

    /// South-west and north-east corners of the area the world's content covers.
    pub fn bounds(&self) -> (P2, P2) {
        let g = &self.object_grid;
        (g.min, [g.min[0] + g.cell * g.nx as f64, g.min[1] + g.cell * g.ny as f64])
    }

    /// Total length of all street centrelines, metres.
    pub fn street_length(&self) -> f64 {
        self.streets.iter().map(Street::length).sum()
    }

    fn cell_tops(&self) -> Vec<f64> {
        let g = &self.object_grid;
        let ground = self.config.ground_height;
        let mut tops = vec![ground; g.nx * g.ny];
        for iy in 0..g.ny {
            for ix in 0..g.nx {
                let top = g.items(ix, iy).iter().map(|item| self.item_top(*item)).fold(ground, f64::max);
                tops[iy * g.nx + ix] = top + 0.01;
            }
        }
        tops
    }

    fn item_top(&self, item: Item) -> f64 {
        match item {
            Item::Building(i) => self.buildings[i as usize].shape.base + self.buildings[i as usize].shape.height,
            Item::Car(i) => self.cars[i as usize].shape.base + self.cars[i as usize].shape.height,
            Item::Pedestrian(i) => {
                let s = &self.pedestrians[i as usize].shape;
                s.base + s.height
            }
            Item::Pole(i) => {
                let p = &self.poles[i as usize];
                let g = self.pole_ground[i as usize];
                (g + p.height * p.axis().z + p.diameter).max(p.crown_center(g).z + p.crown)
            }
        }
    }

    fn build_index(&mut self) {
        self.index_streets();
        self.settle();
        self.index_objects();
    }

    /// Stand every object on the ground: poles and pedestrians where they stand, cars and buildings at the
    /// lowest ground under their footprint (buildings [`FOUNDATION_M`] lower, as tall above it). Nothing moves on
    /// flat ground.
    fn settle(&mut self) {
        self.pole_ground = self.poles.iter().map(|p| self.ground_at(p.base[0], p.base[1])).collect();
        if self.config.relief.is_flat() {
            return;
        }
        let lowest = |s: &BoxShape| {
            let (a, n) = (s.axis, [-s.axis[1], s.axis[0]]);
            [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0), (0.0, 0.0)]
                .iter()
                .map(|(u, v)| {
                    let e = s.center[0] + u * s.half[0] * a[0] + v * s.half[1] * n[0];
                    let n_ = s.center[1] + u * s.half[0] * a[1] + v * s.half[1] * n[1];
                    self.ground_at(e, n_)
                })
                .fold(f64::INFINITY, f64::min)
        };
        let cars: Vec<f64> = self.cars.iter().map(|c| lowest(&c.shape)).collect();
        let people: Vec<f64> =
            self.pedestrians.iter().map(|c| self.ground_at(c.shape.center[0], c.shape.center[1])).collect();
        let buildings: Vec<f64> = self.buildings.iter().map(|b| lowest(&b.shape) - FOUNDATION_M).collect();
        for (c, base) in self.cars.iter_mut().zip(cars) {
            c.shape.base = base;
        }
        for (c, base) in self.pedestrians.iter_mut().zip(people) {
            c.shape.base = base;
        }
        for (b, base) in self.buildings.iter_mut().zip(buildings) {
            b.shape.height += FOUNDATION_M;
            b.shape.base = base;
        }
    }

    fn index_streets(&mut self) {
        for st in &self.streets {
            let m = st.half_corridor() + 1.0;
            for (k, w) in st.points.windows(2).enumerate() {
                let lo = [w[0][0].min(w[1][0]) - m, w[0][1].min(w[1][1]) - m];
                let hi = [w[0][0].max(w[1][0]) + m, w[0][1].max(w[1][1]) + m];
                self.street_grid.insert_box(lo, hi, (st.id, k as u32));
            }
        }
        for j in &self.junctions {
            let r = j.radius + 16.0;
            self.junction_grid.insert_box([j.pos[0] - r, j.pos[1] - r], [j.pos[0] + r, j.pos[1] + r], j.id);
        }
    }

    fn index_objects(&mut self) {
        let mut top = self.ground_top();
        for (i, b) in self.buildings.iter().enumerate() {
            let s = &b.shape;
            self.object_grid.insert_rect(s.center, s.axis, s.half, Item::Building(i as u32));
            top = top.max(s.base + s.height);
        }
        for (i, c) in self.cars.iter().enumerate() {
            let s = &c.shape;
            self.object_grid.insert_rect(s.center, s.axis, s.half, Item::Car(i as u32));
        }
        for (i, c) in self.pedestrians.iter().enumerate() {
            let s = &c.shape;
            self.object_grid.insert_rect(s.center, s.axis, s.half, Item::Pedestrian(i as u32));
        }
        let spread = self.config.changes.crown_spread.max(1.0);
        for (i, p) in self.poles.iter().enumerate() {
            let top_c = p.crown_center(self.pole_ground[i]);
            let r = p.diameter / 2.0 + p.crown * spread + p.height * p.lean[0].hypot(p.lean[1]) + 0.1;
            let (cx, cy) = ((p.base[0] + top_c.x) / 2.0, (p.base[1] + top_c.y) / 2.0);
            self.object_grid.insert_box([cx - r, cy - r], [cx + r, cy + r], Item::Pole(i as u32));
            top = top.max(top_c.z + p.crown);
        }
        self.top = top + 0.5;
        self.cell_top = self.cell_tops();
    }
}

fn bounds(streets: &[Street]) -> (P2, P2) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in streets.iter().flat_map(|s| s.points.iter()) {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    let m = 60.0;
    ([lo[0] - m, lo[1] - m], [hi[0] + m, hi[1] + m])
}
