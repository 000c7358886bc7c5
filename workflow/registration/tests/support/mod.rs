//! A synthetic campaign for the registration tests and the benchmark: a `plumbline_synth` world, a drive
//! with DG errors, panoramas rendered with the TRUE poses (DG poses for processing), the aerial frames
//! covering them (AT-reported orientations for processing), and the truth to score tie points against. With a
//! `realism` other than ideal, the images are rendered through its rig and radiometry and pass through JPEG at
//! its quality and the pipeline's decoder.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod markings;

use std::sync::Arc;

use plumbline_geo::angle::wrap;
use plumbline_geo::camera::{CameraModel, Equirectangular, Pinhole};
use plumbline_geo::dg::intersect_height;
use plumbline_geo::{MapFromBody, Point3};
use plumbline_imaging::decode::{Bounds, decode_gray};
use plumbline_imaging::{GrayImage, ImagePart, Mask};
use plumbline_registration::TileResultV1;
use plumbline_registration::aerial::{AerialFrame, AerialReference, Terrain};
use plumbline_registration::mm::{Panorama, PanoramaRig, SubCameras};
use plumbline_synth::aerial::{block, small_format};
use plumbline_synth::motion::dg::{self, DgConfig};
use plumbline_synth::motion::routes::{DEEP_CANYON, URBAN_STREET};
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::ortho::{OrthoGrid, terrain_model};
use plumbline_synth::render::{
    AerialOptics, AtErrors, BlockSpec, Radiometry, Realism, RealismLevel, RgbImage, Scene, VehicleBody, encode_jpeg,
    render_aerial_with, render_panorama, render_panorama_with,
};
use plumbline_synth::route::{Canyon, Route};
use plumbline_synth::sensors::{self, Mount, Shot};
use plumbline_synth::world::{self, Epoch, World, WorldConfig};
use rayon::prelude::*;

/// Aerial frame size (the simulator's small format) and GSD.
const FRAME_PX: (u32, u32) = (1000, 750);
pub const AERIAL_GSD: f64 = 0.12;

/// GNSS environment of the whole drive (`None`: the world's own streets decide).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Profile {
    Open,
    Urban,
    Canyon,
    Mixed,
}

/// What to simulate.
#[derive(Clone, Copy, Debug)]
pub struct Spec {
    pub preset: world::Preset,
    pub seed: u64,
    pub profile: Profile,
    /// Route length, metres.
    pub length: f64,
    /// Distance between panoramas, metres.
    pub spacing: f64,
    /// Panorama width, pixels.
    pub width: u32,
    /// Keep only this many consecutive panoramas centred on a junction (None = all).
    pub window: Option<usize>,
    /// What the cameras add to the images.
    pub realism: Realism,
}

/// An image through JPEG at `quality` and the pipeline's decoder, as luma.
fn through_jpeg(id: &str, rgb: &RgbImage, quality: u8) -> GrayImage {
    let bytes = encode_jpeg(rgb, quality).expect("JPEG");
    decode_gray(id, &bytes, &Bounds::budget(u64::MAX)).expect("decoded JPEG")
}

/// The world's terrain model (1 m cells) over the shots' positions and 60 m around them.
fn terrain_under(world: &World, shots: &[Shot]) -> Terrain {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for s in shots {
        let p = s.truth.position;
        lo = [lo[0].min(p.x() - 60.0), lo[1].min(p.y() - 60.0)];
        hi = [hi[0].max(p.x() + 60.0), hi[1].max(p.y() + 60.0)];
    }
    let (width, height) = ((hi[0] - lo[0]).ceil() as u32, (hi[1] - lo[1]).ceil() as u32);
    let grid = OrthoGrid { west: lo[0], north: hi[1], gsd: 1.0, width, height };
    let heights = terrain_model(world, &grid);
    Terrain { heights, width: width as usize, height: height as usize, geotransform: grid.geotransform() }
}

/// A campaign ready for `register_tile`, with its truth.
pub struct Campaign {
    pub panoramas: Vec<Panorama>,
    pub rig: PanoramaRig,
    pub reference: AerialReference,
    /// True vehicle pose per panorama id.
    pub truth: Vec<(String, MapFromBody)>,
    pub ground_height: f64,
    /// Horizontal DG error per panorama, metres.
    pub dg_error: Vec<f64>,
    /// The synthetic world (ground truth for the markings census).
    pub world: World,
}

fn luma(rgb: &[u8]) -> f32 {
    0.299 * f32::from(rgb[0]) + 0.587 * f32::from(rgb[1]) + 0.114 * f32::from(rgb[2])
}

fn with_profile(route: Route, profile: Profile) -> Route {
    match profile {
        Profile::Open => route.with_canyon(Canyon::OPEN),
        Profile::Urban => route.with_canyon(URBAN_STREET),
        Profile::Canyon => route.with_canyon(DEEP_CANYON),
        Profile::Mixed => route,
    }
}

/// `window` consecutive shots centred on the shot nearest to a junction of the route.
fn around_junction(shots: Vec<Shot>, route: &Route, window: usize) -> Vec<Shot> {
    let junctions: Vec<[f64; 2]> = route.waypoints.iter().filter(|w| w.junction).map(|w| [w.east, w.north]).collect();
    let dist = |s: &Shot| {
        let p = s.truth.position;
        junctions.iter().map(|j| (p.x() - j[0]).hypot(p.y() - j[1])).fold(f64::INFINITY, f64::min)
    };
    // Skip the first shots: the drive starts standing still at a junction.
    let skip = window.min(shots.len() / 3);
    let best = (skip..shots.len()).min_by(|&a, &b| dist(&shots[a]).total_cmp(&dist(&shots[b]))).unwrap_or(0);
    let start = best.saturating_sub(window / 2).min(shots.len().saturating_sub(window));
    shots.into_iter().skip(start).take(window).collect()
}

impl Campaign {
    /// Simulate and render.
    pub fn build(spec: &Spec) -> Campaign {
        let config = WorldConfig {
            changes: spec.realism.world,
            relief: spec.realism.relief,
            ..WorldConfig::new(spec.preset, spec.seed)
        };
        let world = World::generate(&config).expect("world");
        let route = with_profile(world.route(spec.seed, spec.length), spec.profile);
        let drive_config = DriveConfig::default();
        let drive = Drive::simulate(&route, &drive_config, spec.seed).expect("drive");
        let dg = dg::simulate(&drive, &DgConfig::default(), spec.seed).expect("dg");
        let times = sensors::spaced_times(&drive, spec.spacing).expect("times");
        let mut shots = sensors::shots("pano", &times, &drive.trajectory, &dg.trajectory).expect("shots");
        if let Some(w) = spec.window {
            shots = around_junction(shots, &route, w);
        }
        let camera = Equirectangular::new(spec.width, spec.width / 2).expect("camera");
        let mount = Mount::PANORAMA.camera_mount();
        // Calibration: the IMU rides imu_height above the road, the camera 1.85 m above the IMU.
        let camera_height = drive_config.imu_height - Mount::PANORAMA.lever_arm_m[2];
        let scene = Scene::mobile(&world);
        let ideal = spec.realism.level == RealismLevel::Ideal;
        let rendered: Vec<_> = shots
            .iter()
            .enumerate()
            .map(|(i, s)| {
                if ideal {
                    return render_panorama(&scene, &camera, &mount, &s.truth.pose(), &VehicleBody::van());
                }
                let velocity = sensors::velocity(&drive.trajectory, s.time);
                let (body, van) = (s.truth.pose(), VehicleBody::van());
                render_panorama_with(&scene, &camera, &mount, &body, &van, &velocity, &spec.realism, i as u64 + 1)
            })
            .collect();
        let (w, h) = (camera.width as usize, camera.height as usize);
        let vehicle_mask = rendered.first().map(|p| Mask::from_fn(w, h, |c, r| p.mask.as_raw()[r * w + c] == 0));
        let panoramas = shots
            .iter()
            .zip(&rendered)
            .map(|(s, p)| {
                let raw = p.image.as_raw();
                let image = if ideal {
                    GrayImage::from_fn(w, h, |c, r| luma(&raw[(r * w + c) * 3..(r * w + c) * 3 + 3]))
                } else {
                    through_jpeg(&s.id, &p.image, spec.realism.street.jpeg_quality)
                };
                let std = s.dg.std.expect("DG σ");
                Panorama {
                    id: s.id.clone(),
                    time: s.time,
                    image,
                    part: ImagePart::whole(w as u32, h as u32),
                    pose: s.dg.pose(),
                    position_sigma: std.east.max(std.north),
                }
            })
            .collect();
        // The rig the panoramas were rendered through, as a manifest's `[panoramas.rig]` would give it.
        let r = spec.realism.rig;
        let sub_cameras = (r.sub_cameras > 1).then_some(SubCameras { count: r.sub_cameras, radius_m: r.radius_m });
        // On relief, the terrain model an orthophoto's [aerial.orthophoto] terrain would give (1 m cells).
        let terrain = (!spec.realism.relief.is_flat()).then(|| Arc::new(terrain_under(&world, &shots)));
        let rig = PanoramaRig { camera, mount, vehicle_mask, camera_height, sub_cameras, terrain };
        let reference = aerial_frames(&world, spec.seed, &shots, &spec.realism.aerial, ideal);
        let truth = shots.iter().map(|s| (s.id.clone(), s.truth.pose())).collect();
        let dg_error = shots
            .iter()
            .map(|s| (s.dg.position.x() - s.truth.position.x()).hypot(s.dg.position.y() - s.truth.position.y()))
            .collect();
        Campaign { panoramas, rig, reference, truth, ground_height: world.config.ground_height, dg_error, world }
    }

    /// Road paint visible at both epochs (m²) in the square of half-size `half` around each panorama's TRUE
    /// position, in panorama order ([`markings::paint_area`]).
    pub fn paint_areas(&self, half: f64) -> Vec<f64> {
        self.truth
            .iter()
            .map(|(_, pose)| {
                let p = pose.translation;
                markings::paint_area(&self.world, [p.x(), p.y()], half)
            })
            .collect()
    }

    /// For each tie with aerial coordinates: its aerial position minus the true ground point of its first
    /// ray (the panorama's TRUE pose intersected with the true ground), and the reported σ of each axis.
    pub fn aerial_errors(&self, result: &TileResultV1) -> Vec<([f64; 3], [f64; 3])> {
        result
            .ties
            .iter()
            .filter_map(|t| {
                let a = t.aerial.as_ref()?;
                let g = self.true_ground(t)?;
                let p = Point3::new(a.position[0], a.position[1], a.position[2]);
                let e = p - g;
                let sigma = [0, 1, 2].map(|k| a.covariance[k][k].sqrt());
                Some(([e.x(), e.y(), e.z()], sigma))
            })
            .collect()
    }

    /// The true point of a tie: the first surface of the MM epoch (ground, car, pole, …) along its first
    /// ray from the panorama's TRUE pose; the true ground plane when the ray hits nothing within 200 m.
    pub fn true_ground(&self, t: &plumbline_adjustment::TiePoint) -> Option<Point3<plumbline_geo::Map>> {
        let image = t.id.0.split(':').next()?;
        let (_, pose) = self.truth.iter().find(|(id, _)| id == image)?;
        let cam = self.rig.mount.camera_pose(pose);
        let d = plumbline_geo::Vec3::new(t.rays[0].direction[0], t.rays[0].direction[1], t.rays[0].direction[2]);
        let dir = cam.rotation.apply(&d);
        match self.world.trace(&cam.translation.p, &dir.v, 200.0, Epoch::Mobile) {
            Some(hit) => Some(Point3::from_vector(hit.point)),
            None => intersect_height(&cam.translation, &dir, self.ground_height),
        }
    }

    /// Where a mapping point lies in aerial frame `id` (its AT-reported orientation: 3 cm / 3″, a fifth of
    /// a pixel), full-image pixel.
    pub fn aerial_pixel(&self, id: &str, p: &Point3<plumbline_geo::Map>) -> Option<[f64; 2]> {
        let AerialReference::Frames(frames) = &self.reference else { return None };
        let f = frames.iter().find(|f| f.id == id)?;
        let c = f.pose.inverse().transform_point(p);
        let px = f.camera.project(&plumbline_geo::Vec3::new(c.x(), c.y(), c.z()))?;
        Some([px.u, px.v])
    }
}

/// One pair's image-derived motion scored against the truth.
#[derive(Clone, Copy, Debug)]
pub struct MotionCheck {
    /// Image − true motion: east, north (m), heading change (rad).
    pub error: [f64; 3],
    /// The reported σ of each.
    pub std: [f64; 3],
    /// DG − true motion of the same pair.
    pub dg_error: [f64; 3],
    /// The true motion: east, north (m), heading change (rad).
    pub truth: [f64; 3],
}

impl MotionCheck {
    /// True when every component lies within `k` σ.
    pub fn within(&self, k: f64) -> bool {
        (0..3).all(|i| self.error[i].abs() <= k * self.std[i])
    }
}

/// Body-origin displacement (east, north) and heading change from pose `a` to pose `b`.
fn motion_between(a: &MapFromBody, b: &MapFromBody) -> [f64; 3] {
    let heading = |p: &MapFromBody| plumbline_geo::Attitude::from_rotation(&p.rotation).heading;
    let (ta, tb) = (a.translation, b.translation);
    [tb.x() - ta.x(), tb.y() - ta.y(), wrap(heading(b) - heading(a))]
}

impl Campaign {
    /// For each panorama with an image-derived motion, in image order: its error against the true motion between the TRUE
    /// poses of the pair, its σ, and the DG motion's error.
    pub fn motion_checks(&self, result: &TileResultV1) -> Vec<MotionCheck> {
        let truth = |id: &str| self.truth.iter().find(|(i, _)| i == id).map(|(_, p)| p);
        let dg = |id: &str| self.panoramas.iter().find(|p| p.id == id).map(|p| &p.pose);
        result
            .images
            .iter()
            .filter_map(|d| {
                let m = d.motion?;
                let other = d.neighbour.as_deref().expect("a motion has a neighbour");
                let (first, second) =
                    if m.start == d.time { (d.image.as_str(), other) } else { (other, d.image.as_str()) };
                let want = motion_between(truth(first).expect("truth"), truth(second).expect("truth"));
                let dg_motion = motion_between(dg(first).expect("DG pose"), dg(second).expect("DG pose"));
                let got = [m.displacement[0], m.displacement[1], m.heading_change];
                Some(MotionCheck {
                    error: [got[0] - want[0], got[1] - want[1], wrap(got[2] - want[2])],
                    std: m.std,
                    dg_error: [dg_motion[0] - want[0], dg_motion[1] - want[1], wrap(dg_motion[2] - want[2])],
                    truth: want,
                })
            })
            .collect()
    }
}

/// The frames of the standard block whose image contains a panorama's ground point, rendered with their
/// true orientation; the reference carries the AT-reported one.
fn aerial_frames(world: &World, seed: u64, shots: &[Shot], radiometry: &Radiometry, ideal: bool) -> AerialReference {
    let spec = BlockSpec { gsd: AERIAL_GSD, ..BlockSpec::standard() };
    let interior = small_format(FRAME_PX.0, FRAME_PX.1);
    let (cam, frames) = block(world, &interior, &spec, &AtErrors::typical(), seed).expect("aerial block");
    let sees = |cam: &Pinhole, pose: &plumbline_geo::MapFromCamera| {
        shots.iter().any(|s| {
            let p = s.truth.position;
            let ground = Point3::new(p.x(), p.y(), world.config.ground_height);
            let d = pose.inverse().transform_point(&ground);
            cam.project(&plumbline_geo::Vec3::new(d.x(), d.y(), d.z())).is_some_and(|px| cam.contains(px))
        })
    };
    let scene = Scene::aerial(world);
    let chosen: Vec<_> = frames.iter().enumerate().filter(|(_, f)| sees(&cam, &f.truth)).collect();
    let rendered: Vec<AerialFrame> = chosen
        .par_iter()
        .map(|(i, f)| {
            let optics = AerialOptics::typical(seed.wrapping_mul(7_919).wrapping_add(*i as u64));
            let rgb = render_aerial_with(&scene, &cam, &f.truth, &optics, radiometry);
            let (w, h) = (FRAME_PX.0 as usize, FRAME_PX.1 as usize);
            let raw = rgb.as_raw();
            let image = if ideal {
                GrayImage::from_fn(w, h, |c, r| luma(&raw[(r * w + c) * 3..(r * w + c) * 3 + 3]))
            } else {
                through_jpeg(&f.id, &rgb, radiometry.jpeg_quality)
            };
            AerialFrame { id: f.id.clone(), image, origin: [0, 0], camera: cam, pose: f.reported }
        })
        .collect();
    AerialReference::Frames(rendered)
}
