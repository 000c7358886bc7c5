//! A synthetic drive for the pole tests and the benchmark: world, drive, DG solution, depth images rendered
//! with the TRUE pose (as `plumbline simulate` does) and back-projected with the DG pose, and the cadastre.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use plumbline_campaign::manifest::{DepthIntrinsics, PoleClass};
use plumbline_campaign::{CadastreFeature, CadastreFeatureId};
use plumbline_geo::MapFromBody;
use plumbline_geo::camera::CameraModel;
use plumbline_geo::camera::Pinhole;
use plumbline_geo::dg::CameraMount;
use plumbline_poles::{FramePoints, decode_depth_png, depth_points};
use plumbline_synth::cadastre::{CadastreErrors, CadastreObject, cadastre};
use plumbline_synth::motion::dg::{self, DgConfig, DgSolution};
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::render::{DepthNoise, encode_png_gray16, ground_truth, render_depth};
use plumbline_synth::sensors::{self, Mount, Shot};
use plumbline_synth::world::{Epoch, Preset, Surface, World, WorldConfig};

pub mod eval;
pub mod scene;

/// The depth camera's range error share (Meyer et al. 2023 §3.1.2), as the synth renders it.
pub const SHARE: f64 = 0.08;

/// A drive with depth frames.
pub struct Scenario {
    pub seed: u64,
    pub world: World,
    pub drive: Drive,
    pub dg: DgSolution,
    pub shots: Vec<Shot>,
    pub cam: Pinhole,
    pub intrinsics: DepthIntrinsics,
    pub mount: CameraMount,
    pub cadastre: Vec<CadastreObject>,
    pub errors: CadastreErrors,
}

impl Scenario {
    /// `length` metres of route through a `preset` world; depth images of `size` at `rate` Hz.
    pub fn new(preset: Preset, seed: u64, length: f64, size: (u32, u32), rate: f64) -> Self {
        let world = World::generate(&WorldConfig::new(preset, seed)).unwrap();
        let route = world.route(seed, length);
        let drive = Drive::simulate(&route, &DriveConfig::default(), seed).unwrap();
        let dg = dg::simulate(&drive, &DgConfig::default(), seed).unwrap();
        let times = sensors::moving_times(&drive, rate).unwrap();
        let shots = sensors::shots("depth", &times, &drive.trajectory, &dg.trajectory).unwrap();
        let (w, h) = size;
        let f = f64::from(w) / 2.0;
        let (cx, cy) = (f64::from(w) / 2.0, f64::from(h) / 2.0);
        let cam = Pinhole::new(w, h, f, f, cx, cy, 0.0, 0.0).unwrap();
        let intrinsics = DepthIntrinsics {
            fx: f,
            fy: f,
            cx,
            cy,
            width_px: w,
            height_px: h,
            depth_scale_m: 0.001,
            min_range_m: 0.4,
            max_range_m: 10.0,
        };
        let errors = CadastreErrors::typical();
        let cadastre = cadastre(&world, &errors, seed);
        Self { seed, world, drive, dg, shots, cam, intrinsics, mount: Mount::DEPTH.camera_mount(), cadastre, errors }
    }

    /// The 16-bit PNG of frame `i`, rendered with the true pose (8 % range noise, as `plumbline simulate`).
    pub fn png(&self, i: usize) -> Vec<u8> {
        self.png_with_share(i, SHARE)
    }

    /// The same with range noise σ = `share` × depth.
    pub fn png_with_share(&self, i: usize, share: f64) -> Vec<u8> {
        let mut noise = DepthNoise::realsense(self.seed.wrapping_mul(1_000_003).wrapping_add(i as u64));
        noise.share = share;
        let pose = self.mount.camera_pose(&self.shots[i].truth.pose());
        encode_png_gray16(&render_depth(&self.world, Epoch::Mobile, &self.cam, &pose, &noise)).unwrap()
    }

    /// Frame `i` decoded and georeferenced with `body` (the DG or the true pose).
    pub fn points(&self, i: usize, png: &[u8], body: &MapFromBody) -> FramePoints {
        let depth = decode_depth_png(&self.shots[i].id, png, &self.intrinsics).unwrap();
        depth_points(&depth, &self.intrinsics, SHARE, &self.mount, body)
    }

    /// The listed cadastre as the services deliver it, accuracies as the synth's errors.
    pub fn features(&self) -> Vec<CadastreFeature> {
        self.cadastre
            .iter()
            .filter_map(|o| {
                let (Some([e, n]), Some(id)) = (o.listed, o.cadastre_id) else { return None };
                let (class, accuracy) = match o.class {
                    "tree" => (PoleClass::Tree, self.errors.tree_sigma_m),
                    "light" => (PoleClass::Light, self.errors.pole_sigma_m),
                    _ => (PoleClass::Sign, self.errors.pole_sigma_m),
                };
                Some(CadastreFeature {
                    id: CadastreFeatureId { layer: 0, fid: id as u64, part: 0 },
                    class,
                    easting: e,
                    northing: n,
                    accuracy_m: accuracy,
                    diameter_m: Some(o.diameter_m),
                })
            })
            .collect()
    }

    /// World poles observable in frame `i` (the denominator of recall): within `max_range` of the true camera
    /// centre horizontally, at depth < 10 m, inside the frustum (2° margin), and with at least 1.2 m of shaft
    /// unoccluded between 0.3 and 3.1 m above ground (the detector needs 0.8 m of it in front of a background:
    /// 4 slices of 0.2 m; the margin covers the slices cut by a car roof or the shaft's top),
    /// checked by ray casting against the world every 0.1 m of height.
    pub fn visible(&self, i: usize, max_range: f64) -> Vec<u32> {
        let pose = self.mount.camera_pose(&self.shots[i].truth.pose());
        let c = pose.translation.p;
        let ground = self.world.config.ground_height;
        let margin = 2f64.to_radians().tan();
        self.world
            .poles
            .iter()
            .filter(|p| {
                if (p.base[0] - c.x).hypot(p.base[1] - c.y) > max_range {
                    return false;
                }
                let hits = (3..31)
                    .filter(|k| {
                        let h = f64::from(*k) * 0.1;
                        let target = nalgebra::Vector3::new(p.base[0], p.base[1], ground) + p.axis() * h;
                        let v = pose.inverse().transform_point(&plumbline_geo::Point3::from_vector(target)).p;
                        let inside = v.z > 0.0
                            && v.z < 10.0
                            && (v.x / v.z).abs() < 1.0 - margin
                            && (v.y / v.z).abs() < 0.5625 - margin;
                        // What the renderer sees at the pixel the axis point images to.
                        let pixel = self.cam.project(&plumbline_geo::Vec3::new(v.x, v.y, v.z));
                        inside
                            && pixel
                                .and_then(|px| ground_truth(&self.world, Epoch::Mobile, &self.cam, &pose, px))
                                .is_some_and(|(_, surface)| surface == Surface::Pole(p.id))
                    })
                    .count();
                hits >= 12
            })
            .map(|p| p.id)
            .collect()
    }
}
