//! Test support: an analytic ground of road-marking rectangles and panoramas of it rendered by ray casting
//! with a known true pose, so every step can be checked against the exact answer.

use plumbline_geo::camera::{CameraModel, Equirectangular, Pixel};
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::{Attitude, Map, MapFromBody, Point3, Vec3};
use plumbline_imaging::{GrayImage, ImagePart, Mask};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Panorama, PanoramaRig};

/// Grey value of the sky and of the vehicle body.
const SKY: f32 = 30.0;

/// A rotated rectangle of paint: centre, half sizes, angle, grey-value contrast.
#[derive(Clone, Copy, Debug)]
struct Marking {
    centre: [f64; 2],
    half: [f64; 2],
    angle: f64,
    contrast: f64,
}

impl Marking {
    /// Signed distance-like measure: negative inside (exact), positive outside (a lower bound).
    fn signed(&self, e: f64, n: f64) -> f64 {
        let (s, c) = self.angle.sin_cos();
        let (de, dn) = (e - self.centre[0], n - self.centre[1]);
        let (x, y) = (c * de + s * dn, -s * de + c * dn);
        (x.abs() - self.half[0]).max(y.abs() - self.half[1])
    }
}

/// A ground at `height` at its centre, level or tilted by `slope` (rise per metre east and north), with
/// random markings around the centre.
#[derive(Clone, Debug)]
pub(crate) struct Ground {
    pub height: f64,
    pub slope: [f64; 2],
    centre: [f64; 2],
    markings: Vec<Marking>,
}

impl Ground {
    /// About 3 markings per 10 m² within `radius` metres of `centre`.
    pub(crate) fn markings(seed: u64, centre: [f64; 2], radius: f64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let count = (radius * radius * std::f64::consts::PI * 0.3) as usize;
        let markings = (0..count)
            .map(|_| Marking {
                centre: [centre[0] + rng.random_range(-radius..radius), centre[1] + rng.random_range(-radius..radius)],
                half: [rng.random_range(0.1..0.8), rng.random_range(0.08..0.5)],
                angle: rng.random_range(0.0..std::f64::consts::PI),
                contrast: if rng.random_range(0.0..1.0) < 0.7 { 110.0 } else { -45.0 },
            })
            .collect();
        Self { height: 8.0, slope: [0.0; 2], centre, markings }
    }

    /// The ground's height at (e, n).
    pub(crate) fn height_at(&self, e: f64, n: f64) -> f64 {
        self.height + self.slope[0] * (e - self.centre[0]) + self.slope[1] * (n - self.centre[1])
    }

    /// Where the ray `o + t·d` meets the ground (t > 0).
    fn intersect(&self, o: &Point3<Map>, d: &Vec3<Map>) -> Option<Point3<Map>> {
        let level = self.height_at(o.x(), o.y());
        let falls = -d.z() + self.slope[0] * d.x() + self.slope[1] * d.y();
        let t = (o.z() - level) / falls;
        (falls > 1e-9 && t > 0.0).then(|| Point3::new(o.x() + t * d.x(), o.y() + t * d.y(), o.z() + t * d.z()))
    }

    /// Grey value at (e, n) with edges blurred over `blur` metres (at least 3 cm).
    pub(crate) fn value_blurred(&self, e: f64, n: f64, blur: f64) -> f32 {
        let w = blur.max(0.03);
        let base = 90.0 + 10.0 * (e * 0.7).sin() * (n * 0.9).cos();
        let paint: f64 = self.markings.iter().map(|m| m.contrast * (0.5 - m.signed(e, n) / w).clamp(0.0, 1.0)).sum();
        (base + paint).clamp(0.0, 255.0) as f32
    }

    /// Grey value at (e, n).
    pub(crate) fn value(&self, e: f64, n: f64) -> f32 {
        self.value_blurred(e, n, 0.03)
    }

    /// True when no marking edge lies within `r` metres of (e, n).
    pub(crate) fn is_flat_at(&self, e: f64, n: f64, r: f64) -> bool {
        self.markings.iter().all(|m| m.signed(e, n).abs() > r)
    }
}

/// The simulator's panoramic rig: 1024 × 512, camera 1.85 m above the IMU (2.85 m above the road).
pub(crate) fn rig(with_mask: bool) -> PanoramaRig {
    let camera = Equirectangular { width: 1024, height: 512 };
    let mount = CameraMount::new([0.4, 0.02, -1.85], &Boresight::from_degrees(0.12, -0.35, 0.8));
    let vehicle_mask = with_mask.then(|| vehicle_mask(&camera, &mount));
    PanoramaRig { camera, mount, vehicle_mask, camera_height: 2.85, sub_cameras: None, terrain: None, readout_s: 0.0 }
}

/// Pixels whose ray from the camera hits the van (body box −1.2…3.4 × −0.95…0.95 × −0.5…0.8 m).
fn vehicle_mask(cam: &Equirectangular, mount: &CameraMount) -> Mask {
    let (lo, hi) = ([-1.2, -0.95, -0.5], [3.4, 0.95, 0.8]);
    let o = mount.lever_arm;
    Mask::from_fn(cam.width as usize, cam.height as usize, |c, r| {
        let Some(d) = cam.unproject(Pixel::new(c as f64 + 0.5, r as f64 + 0.5)) else { return false };
        let d = mount.boresight.apply(&d);
        let (o, d) = ([o.x(), o.y(), o.z()], [d.x(), d.y(), d.z()]);
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for k in 0..3 {
            if d[k].abs() < 1e-12 {
                continue;
            }
            let (a, b) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
            (t0, t1) = (t0.max(a.min(b)), t1.min(a.max(b)));
        }
        t0 <= t1
    })
}

/// The true vehicle pose at ground position `at` with `heading` (IMU 1 m above the road, level).
pub(crate) fn true_pose(ground: &Ground, at: [f64; 2], heading: f64) -> MapFromBody {
    let attitude = Attitude { roll: 0.0, pitch: 0.0, heading };
    MapFromBody::new(attitude.to_rotation(), Point3::new(at[0], at[1], ground.height_at(at[0], at[1]) + 1.0))
}

/// A panorama rendered with the true pose at `at`; its DG pose is the true one shifted by `dg_offset`.
pub(crate) fn scene_panorama(
    id: &str,
    ground: &Ground,
    rig: &PanoramaRig,
    at: [f64; 2],
    heading: f64,
    dg_offset: [f64; 3],
) -> Panorama {
    let truth = true_pose(ground, at, heading);
    let cam = &rig.camera;
    let pixel_angle = std::f64::consts::TAU / f64::from(cam.width);
    let image = GrayImage::from_fn(cam.width as usize, cam.height as usize, |c, r| {
        if rig.vehicle_mask.as_ref().is_some_and(|m| m.get(c, r)) {
            return SKY;
        }
        let px = Pixel::new(c as f64 + 0.5, r as f64 + 0.5);
        let Some((o, d)) = rig.mount.ray(cam, &truth, px) else { return SKY };
        let Some(g) = ground.intersect(&o, &d) else { return SKY };
        let range = (g - o).norm();
        let footprint = range * pixel_angle / (-d.z()).max(0.05);
        ground.value_blurred(g.x(), g.y(), footprint)
    });
    let t = truth.translation;
    let pose =
        MapFromBody::new(truth.rotation, Point3::new(t.x() + dg_offset[0], t.y() + dg_offset[1], t.z() + dg_offset[2]));
    let part = ImagePart::whole(cam.width, cam.height);
    Panorama { id: id.to_owned(), time: 0.0, image, part, pose, position_sigma: 0.1, velocity: None }
}
