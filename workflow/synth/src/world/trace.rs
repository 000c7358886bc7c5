//! Ray casting against the world: the ground (flat, or the relief's, `relief.rs`), building blocks, parked cars and pedestrians, poles and trunks
//! as cylinders, tree crowns as spheres (ellipsoids spread wider in the aerial epoch, `EpochChanges`). A 2D
//! grid walk (Amanatides–Woo) visits only the cells the ray crosses.

use nalgebra::Vector3;

use super::objects::{BoxShape, Pole};
use super::{Epoch, Item, World};

/// What a ray hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Surface {
    /// The ground (road, sidewalk, yards).
    Ground,
    /// A building's wall.
    Facade(u32),
    /// A building's roof.
    Roof(u32),
    /// A pole or tree trunk.
    Pole(u32),
    /// A tree crown.
    Crown(u32),
    /// A parked car.
    Car(u32),
    /// A pedestrian.
    Pedestrian(u32),
}

/// The first surface along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray, metres.
    pub t: f64,
    /// The mapping-frame point.
    pub point: Vector3<f64>,
    /// Unit surface normal facing the ray.
    pub normal: Vector3<f64>,
    /// What was hit.
    pub surface: Surface,
    /// Surface coordinates: on facades (along the wall, height above base), metres; otherwise zero.
    pub uv: [f64; 2],
}

impl World {
    /// The first surface along the ray `origin + t·dir` (dir unit) with 1e-6 < t ≤ `t_max`, as seen at `epoch`.
    pub fn trace(&self, origin: &Vector3<f64>, dir: &Vector3<f64>, t_max: f64, epoch: Epoch) -> Option<Hit> {
        self.cast(origin, dir, t_max, epoch, false)
    }

    /// Whether anything lies along the ray within `t_max` (stops at the first hit: for shadow rays).
    pub fn occluded(&self, origin: &Vector3<f64>, dir: &Vector3<f64>, t_max: f64, epoch: Epoch) -> bool {
        self.cast(origin, dir, t_max, epoch, true).is_some()
    }

    fn cast(&self, origin: &Vector3<f64>, dir: &Vector3<f64>, t_max: f64, epoch: Epoch, any: bool) -> Option<Hit> {
        let ground = self.ground_hit(origin, dir, 1e-6, t_max);
        let t_ground = ground.map_or(f64::INFINITY, |g| g.0);
        let mut t_end = t_max.min(t_ground);
        let mut t_start = 0.0;
        if origin.z > self.top {
            if dir.z >= 0.0 {
                return None;
            }
            t_start = (self.top - origin.z) / dir.z;
        }
        if dir.z > 1e-12 {
            t_end = t_end.min((self.top - origin.z) / dir.z);
        }
        if let Some(hit) = self.walk(origin, dir, (t_start, t_end), epoch, any) {
            return Some(hit);
        }
        ground.map(|(t, normal)| Hit { t, point: origin + dir * t, normal, surface: Surface::Ground, uv: [0.0; 2] })
    }

    fn walk(&self, o: &Vector3<f64>, d: &Vector3<f64>, span: (f64, f64), epoch: Epoch, any: bool) -> Option<Hit> {
        let (t0, t1) = span;
        let grid = &self.object_grid;
        let (lo, hi) = self.bounds();
        let (mut ta, mut tb) = (t0, t1);
        for k in 0..2 {
            if d[k].abs() < 1e-15 {
                if o[k] < lo[k] || o[k] > hi[k] {
                    return None;
                }
            } else {
                let (a, b) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
                ta = ta.max(a.min(b));
                tb = tb.min(a.max(b));
            }
        }
        if ta > tb {
            return None;
        }
        let p = o + d * ta;
        let cell = |v: f64, m: f64, n: usize| (((v - m) / grid.cell).floor().max(0.0) as usize).min(n - 1);
        let (mut ix, mut iy) = (cell(p.x, lo[0], grid.nx), cell(p.y, lo[1], grid.ny));
        let step = |dk: f64| if dk > 0.0 { 1i64 } else { -1 };
        let next = |i: usize, m: f64, ok: f64, dk: f64| {
            if dk.abs() < 1e-15 {
                f64::INFINITY
            } else {
                let edge = m + (i as f64 + if dk > 0.0 { 1.0 } else { 0.0 }) * grid.cell;
                (edge - ok) / dk
            }
        };
        let (mut tx, mut ty) = (next(ix, lo[0], o.x, d.x), next(iy, lo[1], o.y, d.y));
        let (dtx, dty) = (grid.cell / d.x.abs(), grid.cell / d.y.abs());
        let mut best: Option<Hit> = None;
        let mut enter = ta;
        loop {
            let exit = tx.min(ty).min(tb);
            // Skip the cell when the ray passes above everything standing in it.
            let low = (o.z + d.z * enter).min(o.z + d.z * exit);
            let items = if low > self.cell_top[iy * grid.nx + ix] { &[][..] } else { grid.items(ix, iy) };
            enter = exit;
            for item in items {
                if let Some(h) = self.hit_item(*item, o, d, epoch)
                    && h.t > 1e-6
                    && h.t <= t1
                    && best.is_none_or(|b| h.t < b.t)
                {
                    if any {
                        return Some(h);
                    }
                    best = Some(h);
                }
            }
            if best.is_some_and(|b| b.t <= exit) || exit >= tb {
                return best.filter(|b| b.t <= tb);
            }
            if tx < ty {
                let n = ix as i64 + step(d.x);
                if n < 0 || n >= grid.nx as i64 {
                    return best;
                }
                ix = n as usize;
                tx += dtx;
            } else {
                let n = iy as i64 + step(d.y);
                if n < 0 || n >= grid.ny as i64 {
                    return best;
                }
                iy = n as usize;
                ty += dty;
            }
        }
    }

    fn hit_item(&self, item: Item, o: &Vector3<f64>, d: &Vector3<f64>, epoch: Epoch) -> Option<Hit> {
        match item {
            Item::Building(i) => {
                let h = hit_box(&self.buildings[i as usize].shape, o, d)?;
                let surface = if h.normal.z > 0.5 { Surface::Roof(i) } else { Surface::Facade(i) };
                Some(Hit { surface, ..h })
            }
            Item::Car(i) => {
                let car = &self.cars[i as usize];
                let present = match epoch {
                    Epoch::Mobile => car.in_mobile,
                    Epoch::Aerial => car.in_aerial,
                };
                if !present {
                    return None;
                }
                hit_box(&car.shape, o, d).map(|h| Hit { surface: Surface::Car(i), ..h })
            }
            Item::Pedestrian(i) => {
                let person = &self.pedestrians[i as usize];
                if person.epoch != epoch {
                    return None;
                }
                hit_box(&person.shape, o, d).map(|h| Hit { surface: Surface::Pedestrian(i), ..h })
            }
            Item::Pole(i) => {
                let spread = if epoch == Epoch::Aerial { self.config.changes.crown_spread } else { 1.0 };
                hit_pole(&self.poles[i as usize], self.pole_ground[i as usize], spread, o, d)
            }
        }
    }
}

/// Slab test against an upright oriented box; `None` when missed or when the origin is inside.
pub fn hit_box(b: &BoxShape, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<Hit> {
    let (a, n) = (Vector3::new(b.axis[0], b.axis[1], 0.0), Vector3::new(-b.axis[1], b.axis[0], 0.0));
    let rel = o - Vector3::new(b.center[0], b.center[1], b.base);
    let lo_ = [rel.dot(&a), rel.dot(&n), rel.z];
    let dl = [d.dot(&a), d.dot(&n), d.z];
    let bounds = [(-b.half[0], b.half[0]), (-b.half[1], b.half[1]), (0.0, b.height)];
    let (mut t_near, mut t_far, mut face) = (f64::NEG_INFINITY, f64::INFINITY, 0usize);
    for k in 0..3 {
        if dl[k].abs() < 1e-15 {
            if lo_[k] < bounds[k].0 || lo_[k] > bounds[k].1 {
                return None;
            }
            continue;
        }
        let (ta, tb) = ((bounds[k].0 - lo_[k]) / dl[k], (bounds[k].1 - lo_[k]) / dl[k]);
        let (tn, tf) = (ta.min(tb), ta.max(tb));
        if tn > t_near {
            t_near = tn;
            face = k;
        }
        t_far = t_far.min(tf);
    }
    if t_near > t_far || t_near <= 0.0 {
        return None;
    }
    let axes = [a, n, Vector3::z()];
    let normal = -axes[face] * dl[face].signum();
    let local = [lo_[0] + t_near * dl[0], lo_[1] + t_near * dl[1], lo_[2] + t_near * dl[2]];
    let along = if face == 0 { local[1] } else { local[0] };
    Some(Hit { t: t_near, point: o + d * t_near, normal, surface: Surface::Ground, uv: [along, local[2]] })
}

/// A leaning cylinder with a top cap, then the crown for trees: a sphere, or with `spread` > 1 an ellipsoid
/// `spread` times as wide as it is tall.
pub fn hit_pole(p: &Pole, ground: f64, spread: f64, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<Hit> {
    let axis = p.axis();
    let base = Vector3::new(p.base[0], p.base[1], ground);
    let r = p.diameter / 2.0;
    let w = o - base;
    let (dp, wp) = (d - axis * d.dot(&axis), w - axis * w.dot(&axis));
    let mut best: Option<Hit> = None;
    let mut take = |h: Hit| {
        if h.t > 1e-9 && best.is_none_or(|b| h.t < b.t) {
            best = Some(h);
        }
    };
    let a2 = dp.dot(&dp);
    if a2 > 1e-18 {
        let (b2, c2) = (2.0 * wp.dot(&dp), wp.dot(&wp) - r * r);
        let disc = b2 * b2 - 4.0 * a2 * c2;
        if disc >= 0.0 {
            let t = (-b2 - disc.sqrt()) / (2.0 * a2);
            let h = (w + d * t).dot(&axis);
            if (0.0..=p.height).contains(&h) {
                let radial = (wp + dp * t).normalize();
                take(Hit { t, point: o + d * t, normal: radial, surface: Surface::Pole(p.id), uv: [0.0, h] });
            }
        }
    }
    let top = base + axis * p.height;
    let da = d.dot(&axis);
    if da.abs() > 1e-12 {
        let t = (top - o).dot(&axis) / da;
        let q = o + d * t;
        if (q - top).norm_squared() <= r * r {
            take(Hit { t, point: q, normal: axis * -da.signum(), surface: Surface::Pole(p.id), uv: [0.0, p.height] });
        }
    }
    if p.crown > 0.0 {
        // In coordinates shrunk horizontally by `spread` the ellipsoid is the crown's sphere; t is unchanged.
        let c = p.crown_center(ground);
        let shrink = |v: Vector3<f64>| Vector3::new(v.x / spread, v.y / spread, v.z);
        let (oc, ds) = (shrink(o - c), shrink(*d));
        let (a, b, cc) = (ds.dot(&ds), oc.dot(&ds), oc.dot(&oc) - p.crown * p.crown);
        let disc = b * b - a * cc;
        if disc >= 0.0 {
            let t = (-b - disc.sqrt()) / a;
            let q = o + d * t;
            let g = q - c;
            let normal = if spread == 1.0 {
                g / p.crown
            } else {
                Vector3::new(g.x / (spread * spread), g.y / (spread * spread), g.z).normalize()
            };
            take(Hit { t, point: q, normal, surface: Surface::Crown(p.id), uv: [0.0; 2] });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::PoleClass;

    #[test]
    fn box_and_cylinder_distances_are_exact() {
        let b = BoxShape { center: [10.0, 0.0], axis: [0.0, 1.0], half: [3.0, 2.0], base: 0.0, height: 5.0 };
        // From the origin along +x: the face across the axis is at x = 10 − 2.
        let h = hit_box(&b, &Vector3::new(0.0, 0.0, 1.0), &Vector3::x()).unwrap();
        assert!((h.t - 8.0).abs() < 1e-12 && (h.normal + Vector3::x()).norm() < 1e-12);
        assert!(hit_box(&b, &Vector3::new(0.0, 0.0, 6.0), &Vector3::x()).is_none(), "over the roof");
        let p = Pole {
            id: 0,
            class: PoleClass::SignPost,
            base: [5.0, 0.0],
            diameter: 0.2,
            height: 3.0,
            lean: [0.0; 2],
            crown: 0.0,
        };
        let h = hit_pole(&p, 0.0, 1.0, &Vector3::new(0.0, 0.0, 1.5), &Vector3::x()).unwrap();
        assert!((h.t - 4.9).abs() < 1e-12);
        // Leaning 0.1 m per metre toward +x: at 2 m height the axis is 0.2 m further.
        let leaning = Pole { lean: [0.1, 0.0], ..p };
        let h = hit_pole(&leaning, 0.0, 1.0, &Vector3::new(0.0, 0.0, 2.0), &Vector3::x()).unwrap();
        let expected = 5.0 + 0.2 - 0.1 / (0.1f64.atan()).cos();
        assert!((h.t - expected).abs() < 1e-9, "{} vs {expected}", h.t);
    }
}
