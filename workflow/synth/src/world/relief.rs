//! Terrain relief: rolling hills under the streets, carriageways recessed below the sidewalks by a kerb and
//! crowned with a cross-fall, and the ray–terrain intersection the ray caster uses.
//!
//! The hills are two perpendicular sine waves, 350–600 m long, in directions drawn from the seed; each wave's
//! steepest slope is `grade / √2`, so the terrain's steepest slope is `grade` and a straight street along one
//! wave climbs at most that. Streets follow the hills: a street across a wave leans with it (a hillside
//! street), with the carriageway's crown on top. Heights are relative to the world's origin, so every window
//! of the unbounded city has the same hills.
//!
//! Carriageway (and junction area) height: the hills − `kerb_m` + `cross_fall` × (distance from the carriageway
//! edge), so the crown is at the centreline and the gutters a kerb below the sidewalk. Sidewalks, yards and
//! everything off the street are on the hills.

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::World;

/// The shape of the ground: hills, cross-fall and kerbs. [`Relief::FLAT`] is the flat ground at
/// `ground_height` every earlier figure was made on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relief {
    /// Steepest slope of the hills, rise per metre (0: flat).
    pub grade: f64,
    /// Cross-fall of the carriageway from its crown to the gutters, rise per metre.
    pub cross_fall: f64,
    /// Height of the kerb between gutter and sidewalk, metres.
    pub kerb_m: f64,
}

impl Relief {
    /// Flat ground at `ground_height`, no kerbs.
    pub const FLAT: Self = Self { grade: 0.0, cross_fall: 0.0, kerb_m: 0.0 };

    /// True for [`Relief::FLAT`].
    pub fn is_flat(&self) -> bool {
        self.grade == 0.0 && self.cross_fall == 0.0 && self.kerb_m == 0.0
    }
}

/// The hills of a world: two perpendicular waves around its origin.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Hills {
    origin: [f64; 2],
    /// Per wave: unit direction, wavenumber (rad/m), amplitude (m), phase (rad).
    waves: [([f64; 2], f64, f64, f64); 2],
}

impl Hills {
    /// The hills of `grade` for a seed around `origin` (none when `grade` is 0).
    pub(crate) fn new(seed: u64, origin: [f64; 2], grade: f64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5757_0008);
        let angle: f64 = rng.random_range(0.0..std::f64::consts::PI);
        let mut wave = |dir: [f64; 2]| {
            let length: f64 = rng.random_range(350.0..600.0);
            let k = std::f64::consts::TAU / length;
            let amplitude = grade / std::f64::consts::SQRT_2 / k;
            (dir, k, amplitude, rng.random_range(0.0..std::f64::consts::TAU))
        };
        let (c, s) = (angle.cos(), angle.sin());
        Self { origin, waves: [wave([c, s]), wave([-s, c])] }
    }

    /// Height above the world's `ground_height` at (e, n), metres.
    pub(crate) fn height(&self, e: f64, n: f64) -> f64 {
        let (x, y) = (e - self.origin[0], n - self.origin[1]);
        self.waves.iter().map(|&(d, k, a, phase)| a * (k * (x * d[0] + y * d[1]) + phase).sin()).sum()
    }

    /// Gradient (∂h/∂e, ∂h/∂n) at (e, n).
    pub(crate) fn gradient(&self, e: f64, n: f64) -> [f64; 2] {
        let (x, y) = (e - self.origin[0], n - self.origin[1]);
        let mut g = [0.0; 2];
        for &(d, k, a, phase) in &self.waves {
            let c = a * k * (k * (x * d[0] + y * d[1]) + phase).cos();
            g[0] += c * d[0];
            g[1] += c * d[1];
        }
        g
    }

    /// The largest height the hills reach above `ground_height`, metres.
    pub(crate) fn amplitude(&self) -> f64 {
        self.waves.iter().map(|w| w.2).sum()
    }

    /// The steepest slope of the hills.
    pub(crate) fn steepest(&self) -> f64 {
        self.waves.iter().map(|w| w.1 * w.2).map(|g| g * g).sum::<f64>().sqrt()
    }
}

/// Horizontal step of the fine march through the band the ground can lie in, metres, plus this share of the
/// horizontal distance travelled (far rays see the ground at a coarser footprint).
const FINE_STEP_M: f64 = 0.03;
const FINE_STEP_SHARE: f64 = 0.004;
/// Steps before a march gives up (a ray almost parallel to the ground far away: reported as no hit).
const MAX_STEPS: usize = 20_000;
/// Bisection steps that pin a crossing down.
const BISECTIONS: usize = 24;

impl World {
    /// Height of the ground (road, kerb, sidewalk, yards) at map point (e, n), metres.
    pub fn ground_at(&self, e: f64, n: f64) -> f64 {
        let r = &self.config.relief;
        if r.is_flat() {
            return self.config.ground_height;
        }
        self.config.ground_height + self.hills.height(e, n) + self.street_profile(e, n)
    }

    /// Height of the ground at the base of pole `id`, metres.
    pub fn pole_ground(&self, id: u32) -> f64 {
        self.pole_ground.get(id as usize).copied().unwrap_or(self.config.ground_height)
    }

    /// Height of the hills at (e, n): the ground off the carriageways (sidewalks, yards), metres.
    pub fn hill_height(&self, e: f64, n: f64) -> f64 {
        self.config.ground_height + self.hills.height(e, n)
    }

    /// Slope of the hills at (e, n): rise per metre east and north.
    pub fn hill_gradient(&self, e: f64, n: f64) -> [f64; 2] {
        self.hills.gradient(e, n)
    }

    /// The carriageway's recess (kerb and crown) at (e, n) relative to the hills; 0 off the carriageways.
    fn street_profile(&self, e: f64, n: f64) -> f64 {
        let r = &self.config.relief;
        let Some(place) = self.place([e, n]) else { return 0.0 };
        let inside = place.street.carriageway() / 2.0 - place.station.t.abs();
        if inside > 0.0 || place.in_junction { r.cross_fall * inside.max(0.0) - r.kerb_m } else { 0.0 }
    }

    /// Highest the crown of any carriageway rises above the hills (0 when the kerbs are taller), metres.
    fn crown_above_hills(&self) -> f64 {
        let r = &self.config.relief;
        let widest = self.streets.iter().map(|s| s.carriageway() / 2.0).fold(0.0, f64::max);
        (r.cross_fall * widest - r.kerb_m).max(0.0)
    }

    /// Highest the ground rises anywhere, metres.
    pub(crate) fn ground_top(&self) -> f64 {
        self.config.ground_height + self.hills.amplitude() + self.crown_above_hills()
    }

    /// The first crossing of the ray `o + t·d` (unit d) with the ground for `t_min < t ≤ t_max`: its distance and
    /// the ground's normal there (upward, or facing the ray on a kerb's face).
    pub(crate) fn ground_hit(
        &self,
        o: &Vector3<f64>,
        d: &Vector3<f64>,
        t_min: f64,
        t_max: f64,
    ) -> Option<(f64, Vector3<f64>)> {
        let g = self.config.ground_height;
        if self.config.relief.is_flat() {
            let t = if d.z < -1e-12 && o.z > g { (g - o.z) / d.z } else { f64::INFINITY };
            return (t <= t_max).then_some((t, Vector3::z()));
        }
        let (band_hi, band_lo) = (self.crown_above_hills(), -self.config.relief.kerb_m);
        let horizontal = d.x.hypot(d.y);
        // How fast the height above the highest possible ground can fall per metre along the ray.
        let fall = -d.z + self.hills.steepest() * horizontal;
        let top = self.ground_top();
        let above = |t: f64| {
            let p = o + d * t;
            p.z - (g + self.hills.height(p.x, p.y) + band_hi)
        };
        let below_ground = |t: f64| {
            let p = o + d * t;
            p.z - self.ground_at(p.x, p.y)
        };
        let (mut t, mut last_above, mut seen_above) = (t_min, t_min, false);
        for _ in 0..MAX_STEPS {
            if t > t_max {
                return None;
            }
            let p = o + d * t;
            if d.z >= 0.0 && p.z > top {
                return None;
            }
            let clearance = above(t);
            if clearance > 0.01 {
                if fall <= 0.0 {
                    return None;
                }
                (last_above, seen_above) = (t, true);
                t += (clearance / fall).max(1e-4);
                continue;
            }
            if below_ground(t) > 0.0 {
                (last_above, seen_above) = (t, true);
            } else if seen_above {
                return self.pin(o, d, last_above, t, band_lo);
            }
            // A ray starting on the ground (a shadow ray) is above it once it has left it.
            let step_h = FINE_STEP_M + FINE_STEP_SHARE * horizontal * t;
            let step = if horizontal > 1e-9 { step_h / horizontal } else { f64::INFINITY };
            let step_v = if d.z.abs() > 1e-9 { 0.02 / d.z.abs() } else { f64::INFINITY };
            t += step.min(step_v).min(1.0);
        }
        None
    }

    /// Bisect the crossing between `a` (above the ground) and `b` (at or below it), keeping the side above;
    /// the normal from the ground's slope, or facing the ray where the crossing is a kerb's face.
    fn pin(&self, o: &Vector3<f64>, d: &Vector3<f64>, a: f64, b: f64, band_lo: f64) -> Option<(f64, Vector3<f64>)> {
        let below = |t: f64| {
            let p = o + d * t;
            p.z - self.ground_at(p.x, p.y)
        };
        let (mut a, mut b) = (a, b);
        for _ in 0..BISECTIONS {
            let m = 0.5 * (a + b);
            if below(m) > 0.0 { a = m } else { b = m }
        }
        let (pa, pb) = (o + d * a, o + d * b);
        let jump = (self.ground_at(pa.x, pa.y) - self.ground_at(pb.x, pb.y)).abs();
        if jump > 0.25 * band_lo.abs().max(0.01) {
            let face = Vector3::new(-d.x, -d.y, 0.0);
            return Some((a, if face.norm() > 1e-12 { face.normalize() } else { Vector3::z() }));
        }
        Some((a, self.ground_normal(pa.x, pa.y)))
    }

    /// Upward unit normal of the ground at (e, n) from central differences over 2 cm (slopes steeper than
    /// 1:2, a kerb between the samples, count as level).
    pub(crate) fn ground_normal(&self, e: f64, n: f64) -> Vector3<f64> {
        let h = 0.02;
        let slope = |a: f64, b: f64| {
            let s = (a - b) / (2.0 * h);
            if s.abs() > 0.5 { 0.0 } else { s }
        };
        let gx = slope(self.ground_at(e + h, n), self.ground_at(e - h, n));
        let gy = slope(self.ground_at(e, n + h), self.ground_at(e, n - h));
        Vector3::new(-gx, -gy, 1.0).normalize()
    }
}
