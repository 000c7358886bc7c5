//! A tiny analytic scene for detector tests: flat ground, a kerb step, a facade, parked-car boxes and
//! vertical cylinders, ray cast from a depth camera with seeded range noise (σ = share × depth).
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use nalgebra::Vector3;
use plumbline_campaign::manifest::DepthIntrinsics;
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::{Attitude, MapFromBody, Point3};
use plumbline_poles::DepthImage;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// An axis-aligned box [min, max].
#[derive(Clone, Copy, Debug)]
pub struct Aabb {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// A vertical cylinder standing on z = 0.
#[derive(Clone, Copy, Debug)]
pub struct Cylinder {
    pub centre: [f64; 2],
    pub radius: f64,
    pub height: f64,
}

/// The scene.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub boxes: Vec<Aabb>,
    pub cylinders: Vec<Cylinder>,
}

fn hit_box(b: &Aabb, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<f64> {
    let (mut t0, mut t1) = (1e-9f64, f64::INFINITY);
    for k in 0..3 {
        if d[k].abs() < 1e-15 {
            if o[k] < b.min[k] || o[k] > b.max[k] {
                return None;
            }
            continue;
        }
        let (a, c) = ((b.min[k] - o[k]) / d[k], (b.max[k] - o[k]) / d[k]);
        t0 = t0.max(a.min(c));
        t1 = t1.min(a.max(c));
    }
    (t0 <= t1).then_some(t0)
}

fn hit_cylinder(c: &Cylinder, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<f64> {
    let (ox, oy) = (o.x - c.centre[0], o.y - c.centre[1]);
    let a = d.x * d.x + d.y * d.y;
    let b = 2.0 * (ox * d.x + oy * d.y);
    let cc = ox * ox + oy * oy - c.radius * c.radius;
    let disc = b * b - 4.0 * a * cc;
    if a < 1e-15 || disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / (2.0 * a);
    let z = o.z + d.z * t;
    (t > 1e-9 && (0.0..=c.height).contains(&z)).then_some(t)
}

impl Scene {
    /// Distance along the unit ray to the first surface (ground z = 0 included).
    pub fn trace(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<f64> {
        let ground = (d.z < -1e-12).then(|| -o.z / d.z);
        let boxes = self.boxes.iter().filter_map(|b| hit_box(b, o, d));
        let cyl = self.cylinders.iter().filter_map(|c| hit_cylinder(c, o, d));
        ground.into_iter().chain(boxes).chain(cyl).min_by(f64::total_cmp)
    }
}

/// A right-looking depth camera on a vehicle at the origin heading north (camera looks east), 1.4 m up.
pub struct Rig {
    pub intrinsics: DepthIntrinsics,
    pub mount: CameraMount,
    pub body: MapFromBody,
}

impl Rig {
    pub fn new(width: u32, height: u32) -> Self {
        let f = f64::from(width) / 2.0;
        let intrinsics = DepthIntrinsics {
            fx: f,
            fy: f,
            cx: f64::from(width) / 2.0,
            cy: f64::from(height) / 2.0,
            width_px: width,
            height_px: height,
            depth_scale_m: 0.001,
            min_range_m: 0.4,
            max_range_m: 10.0,
        };
        let mount = CameraMount::new([1.2, 1.0, -0.4], &Boresight::from_degrees(0.0, -5.0, 90.0));
        let body = MapFromBody::new(Attitude::new(0.0, 0.0, 0.0).to_rotation(), Point3::new(0.0, 0.0, 1.0));
        Self { intrinsics, mount, body }
    }

    /// The depth image of `scene` with noise σ = `share` × depth (seeded), values outside the range dropped.
    pub fn render(&self, scene: &Scene, share: f64, seed: u64) -> DepthImage {
        let k = &self.intrinsics;
        let pose = self.mount.camera_pose(&self.body);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut depth_m = Vec::with_capacity((k.width_px * k.height_px) as usize);
        for row in 0..k.height_px {
            for col in 0..k.width_px {
                let x = (f64::from(col) + 0.5 - k.cx) / k.fx;
                let y = (f64::from(row) + 0.5 - k.cy) / k.fy;
                let r = pose.rotation.apply(&plumbline_geo::Vec3::new(x, y, 1.0)).v;
                let n = r.norm();
                let (u1, u2): (f64, f64) = (rng.random_range(f64::MIN_POSITIVE..1.0), rng.random_range(0.0..1.0));
                let g = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                let z = scene.trace(&pose.translation.p, &(r / n)).map_or(0.0, |t| t / n);
                let noisy = z * (1.0 + share * g);
                let ok = (k.min_range_m..=k.max_range_m).contains(&noisy) && z > 0.0;
                depth_m.push(if ok { noisy as f32 } else { 0.0 });
            }
        }
        DepthImage { width: k.width_px, height: k.height_px, depth_m }
    }
}
