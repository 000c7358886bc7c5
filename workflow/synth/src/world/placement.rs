//! Placing furniture along the streets: poles and trees on the sidewalks, parked cars, building blocks,
//! pedestrians.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::Epoch;
use super::objects::{BoxShape, Building, Car, Pedestrian, Pole, PoleClass};
use super::polyline::{self, P2};
use super::streets::{Junction, Street, StreetClass};

/// Where on a street a thing goes: station, side (+1 left, −1 right) and offset from the centreline.
fn at(street: &Street, s: f64, t: f64) -> (P2, P2) {
    let (p, tan) = polyline::point_at(&street.points, &street.cum, s);
    ([p[0] - tan[1] * t, p[1] + tan[0] * t], tan)
}

/// Usable station range between the junction areas at both ends.
fn span(street: &Street, junctions: &[Junction], margin: f64) -> (f64, f64) {
    let r0 = junctions[street.from as usize].radius + margin;
    let r1 = junctions[street.to as usize].radius + margin;
    (r0, street.length() - r1)
}

/// Distance to the nearest street centreline minus that street's half width `half(street)`.
pub fn clearance(streets: &[Street], p: P2, half: impl Fn(&Street) -> f64) -> f64 {
    streets.iter().map(|s| polyline::nearest(&s.points, &s.cum, p).t.abs() - half(s)).fold(f64::INFINITY, f64::min)
}

fn on_sidewalk(streets: &[Street], p: P2) -> bool {
    clearance(streets, p, |s| s.carriageway() / 2.0 + s.kerb) > 0.1
}

fn push_pole(poles: &mut Vec<Pole>, streets: &[Street], mut pole: Pole) {
    let free = poles.iter().all(|q| polyline::dist(q.base, pole.base) > 1.5);
    if free && on_sidewalk(streets, pole.base) {
        pole.id = poles.len() as u32;
        poles.push(pole);
    }
}

fn pole(class: PoleClass, base: P2, diameter: f64, height: f64) -> Pole {
    Pole { id: 0, class, base, diameter, height, lean: [0.0, 0.0], crown: 0.0 }
}

fn tree(rng: &mut ChaCha8Rng, base: P2) -> Pole {
    let (lean, azimuth) =
        (rng.random_range(1.0f64..4.0).to_radians().tan(), rng.random_range(0.0..std::f64::consts::TAU));
    Pole {
        id: 0,
        class: PoleClass::Tree,
        base,
        diameter: rng.random_range(0.2..0.6),
        height: rng.random_range(2.5..3.5),
        lean: [lean * azimuth.sin(), lean * azimuth.cos()],
        crown: rng.random_range(2.0..3.5),
    }
}

/// Street lights, sign posts and trees along the kerbs, traffic lights and tree groups at junctions.
pub fn poles(seed: u64, streets: &[Street], junctions: &[Junction]) -> Vec<Pole> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5757_0002);
    let mut out = Vec::new();
    for j in junctions {
        junction_poles(&mut rng, &mut out, streets, j);
    }
    for st in streets.iter().filter(|s| s.class != StreetClass::Alley) {
        street_poles(&mut rng, &mut out, st, streets, junctions);
    }
    out
}

/// The poles of one street (none in alleys), drawn from `rng`, kept off `out`'s and onto the sidewalks of `streets`.
pub(crate) fn street_poles(
    rng: &mut ChaCha8Rng,
    out: &mut Vec<Pole>,
    st: &Street,
    streets: &[Street],
    junctions: &[Junction],
) {
    if st.class == StreetClass::Alley {
        return;
    }
    let (s0, s1) = span(st, junctions, 3.0);
    let kerb_t = st.carriageway() / 2.0 + st.kerb;
    let both = st.class == StreetClass::Arterial;
    let mut s = s0 + rng.random_range(0.0..10.0);
    let mut side = 1.0;
    while s < s1 {
        for sd in if both { vec![1.0, -1.0] } else { vec![side] } {
            let (p, _) = at(st, s, sd * (kerb_t + 0.5));
            let light = pole(PoleClass::StreetLight, p, rng.random_range(0.12..0.2), rng.random_range(6.0..9.0));
            push_pole(out, streets, light);
        }
        side = -side;
        s += rng.random_range(26.0..36.0);
    }
    let mut s = s0 + rng.random_range(5.0..30.0);
    while s < s1 {
        let sd = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        let (p, _) = at(st, s, sd * (kerb_t + 0.35));
        push_pole(out, streets, pole(PoleClass::SignPost, p, rng.random_range(0.06..0.08), rng.random_range(2.5..3.2)));
        s += rng.random_range(25.0..60.0);
    }
    if st.sidewalk >= 2.4 && (both || rng.random_bool(0.5)) {
        let mut s = s0 + rng.random_range(2.0..6.0);
        while s < s1 {
            for sd in [1.0, -1.0] {
                let (p, _) = at(st, s, sd * (kerb_t + 1.0));
                let t = tree(rng, p);
                push_pole(out, streets, t);
            }
            s += rng.random_range(8.0..14.0);
        }
    }
}

pub(crate) fn junction_poles(rng: &mut ChaCha8Rng, out: &mut Vec<Pole>, streets: &[Street], j: &Junction) {
    for &sid in &j.streets {
        let st = &streets[sid as usize];
        let kerb_t = st.carriageway() / 2.0 + st.kerb;
        // Station just outside the junction area, from this junction's side.
        let s = if st.from == j.id { j.radius + 0.5 } else { st.length() - j.radius - 0.5 };
        let side = if st.from == j.id { -1.0 } else { 1.0 };
        if j.traffic_lights {
            let (p, _) = at(st, s, side * (kerb_t + 0.4));
            out_push(
                out,
                streets,
                pole(PoleClass::TrafficLight, p, rng.random_range(0.14..0.2), rng.random_range(4.0..6.0)),
            );
        } else if st.sidewalk > 0.0 && rng.random_bool(0.35) {
            // A group of trees on the corner plaza.
            for k in 0..rng.random_range(2..5) {
                let ds = if st.from == j.id { 3.0 + 4.0 * f64::from(k) } else { -3.0 - 4.0 * f64::from(k) };
                let (p, _) = at(st, s + ds, -side * (kerb_t + st.sidewalk * 0.5));
                let t = tree(rng, p);
                out_push(out, streets, t);
            }
        }
    }
}

fn out_push(out: &mut Vec<Pole>, streets: &[Street], p: Pole) {
    push_pole(out, streets, p);
}

/// Parked cars in the parking strips, differing between the mobile-mapping and the aerial epoch.
pub fn cars(seed: u64, streets: &[Street], junctions: &[Junction], ground: f64) -> Vec<Car> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5757_0003);
    let mut out = Vec::new();
    for st in streets.iter().filter(|s| s.parking > 0.0) {
        street_cars(&mut rng, &mut out, st, streets, junctions, ground);
    }
    out
}

/// The parked cars of one street (none without parking strips), drawn from `rng`.
pub(crate) fn street_cars(
    rng: &mut ChaCha8Rng,
    out: &mut Vec<Car>,
    st: &Street,
    streets: &[Street],
    junctions: &[Junction],
    ground: f64,
) {
    if st.parking <= 0.0 {
        return;
    }
    let (s0, s1) = span(st, junctions, 6.0);
    let t = st.carriageway() / 2.0 - st.parking / 2.0;
    for side in [1.0, -1.0] {
        let mut s = s0 + 2.8;
        while s + 2.8 < s1 {
            let (p, tan) = at(st, s, side * t);
            let shape = BoxShape { center: p, axis: tan, half: [2.2, 0.9], base: ground, height: 1.45 };
            let mobile = rng.random_bool(0.55);
            let aerial = if mobile { rng.random_bool(0.4) } else { rng.random_bool(0.45) };
            let colour =
                [rng.random_range(0.05..0.8f32), rng.random_range(0.05..0.8f32), rng.random_range(0.05..0.8f32)];
            // At acute junctions a neighbouring street's corridor can reach over the parking strip.
            let others =
                clearance(streets, p, |o| if o.id == st.id { f64::NEG_INFINITY } else { o.half_corridor() + 2.5 });
            if (mobile || aerial) && others > 0.0 {
                // A car there at both epochs is the same car only if both flags are set on one record.
                out.push(Car { shape: shape.clone(), colour, in_mobile: mobile, in_aerial: aerial });
            }
            s += 5.6;
        }
    }
}

/// Building blocks along both sides of each street, kept out of every street corridor and off the poles.
pub fn buildings(seed: u64, streets: &[Street], junctions: &[Junction], poles: &[Pole], ground: f64) -> Vec<Building> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5757_0004);
    let mut out = Vec::new();
    for st in streets {
        street_buildings(&mut rng, &mut out, st, (streets, junctions, poles), ground);
    }
    out
}

/// The building blocks of one street, drawn from `rng`, kept out of the corridors of `streets` and off `poles`.
pub(crate) fn street_buildings(
    rng: &mut ChaCha8Rng,
    out: &mut Vec<Building>,
    st: &Street,
    (streets, junctions, poles): (&[Street], &[Junction], &[Pole]),
    ground: f64,
) {
    let (s0, s1) = span(st, junctions, 0.0);
    let heights = match st.class {
        StreetClass::Alley => 10.0..22.0,
        StreetClass::Residential => 10.0..28.0,
        StreetClass::Arterial => 18.0..40.0,
    };
    for side in [1.0, -1.0] {
        let mut s = s0;
        while s < s1 {
            let width = rng.random_range(12.0..28.0f64).min(s1 - s);
            let gap = rng.random_bool(0.12);
            if width > 6.0 && !gap {
                let depth = rng.random_range(10.0..16.0);
                let front = st.half_corridor() + if rng.random_bool(0.15) { rng.random_range(1.0..4.0) } else { 0.05 };
                let (p, tan) = at(st, s + width / 2.0, side * (front + depth / 2.0));
                let shape = BoxShape {
                    center: p,
                    axis: tan,
                    half: [width / 2.0, depth / 2.0],
                    base: ground,
                    height: rng.random_range(heights.clone()),
                };
                let wall =
                    [rng.random_range(0.35..0.8f32), rng.random_range(0.3..0.7f32), rng.random_range(0.25..0.6f32)];
                if !fits(&shape, streets, poles) {
                    s += 3.0;
                    continue;
                }
                out.push(Building { shape, wall, storey: rng.random_range(2.9..3.6) });
            }
            s += width;
        }
    }
}

fn fits(shape: &BoxShape, streets: &[Street], poles: &[Pole]) -> bool {
    let mut probes: Vec<P2> = shape.corners().to_vec();
    probes.push(shape.center);
    let c = shape.corners();
    for k in 0..4 {
        let (a, b) = (c[k], c[(k + 1) % 4]);
        probes.extend((1..8).map(|i| {
            let f = f64::from(i) / 8.0;
            [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]
        }));
    }
    probes.iter().all(|&p| clearance(streets, p, Street::half_corridor) > 0.0)
        && poles.iter().all(|p| !shape.contains(p.base, p.crown.max(0.5)))
}

/// Pedestrians of both epochs ([`super::EpochChanges::pedestrians_per_100m`]; none at 0), from their own
/// random stream so that the rest of the world does not change with them.
pub fn pedestrians(config: &super::WorldConfig, streets: &[Street], junctions: &[Junction]) -> Vec<Pedestrian> {
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed ^ 0x5757_0007);
    let mut out = Vec::new();
    for st in streets {
        street_pedestrians(&mut rng, &mut out, st, junctions, config);
    }
    out
}

/// The pedestrians of one street at both epochs, drawn from `rng`: two thirds along the sidewalks, one third
/// on the zebra crossing zone at either end (within 3.3 m of the junction area, across the carriageway).
pub(crate) fn street_pedestrians(
    rng: &mut ChaCha8Rng,
    out: &mut Vec<Pedestrian>,
    st: &Street,
    junctions: &[Junction],
    config: &super::WorldConfig,
) {
    let rate = config.changes.pedestrians_per_100m;
    let (s0, s1) = span(st, junctions, 0.0);
    if rate <= 0.0 || s1 <= s0 {
        return;
    }
    let half = st.carriageway() / 2.0;
    let kerb_t = half + st.kerb;
    for epoch in [Epoch::Mobile, Epoch::Aerial] {
        let count = (rate * (s1 - s0) / 100.0 + rng.random_range(0.0..1.0)) as usize;
        for _ in 0..count {
            let crossing = rng.random_bool(1.0 / 3.0);
            let (s, t) = if crossing || st.sidewalk <= 0.6 {
                let end = rng.random_range(0.3..3.3);
                let s = if rng.random_bool(0.5) { s0 + end } else { s1 - end };
                (s, rng.random_range(-half..half))
            } else {
                let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                (rng.random_range(s0..s1), side * (kerb_t + rng.random_range(0.3..st.sidewalk - 0.3)))
            };
            let (p, tan) = at(st, s, t);
            let height = rng.random_range(1.6..1.9);
            let shape = BoxShape { center: p, axis: tan, half: [0.25, 0.18], base: config.ground_height, height };
            let colour =
                [rng.random_range(0.03..0.6f32), rng.random_range(0.03..0.6f32), rng.random_range(0.03..0.6f32)];
            out.push(Pedestrian { shape, colour, epoch });
        }
    }
}
