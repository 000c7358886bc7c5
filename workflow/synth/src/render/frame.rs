//! Images of the world through a camera: panoramas (with the vehicle body masked), depth images, aerial
//! frames, and the ground-truth surface point under a pixel. Rows render in parallel; every pixel is a pure
//! function of its inputs, so the output does not depend on the thread count.

use image::{GrayImage, ImageBuffer, Luma, RgbImage};
use nalgebra::Vector3;
use plumbline_geo::camera::{CameraModel, Equirectangular, Pinhole, Pixel};
use plumbline_geo::{Map, MapFromBody, MapFromCamera, Point3};
use rayon::prelude::*;

use super::realism::{Radiometry, Realism, gaussian};
use super::shade::{FAR, Scene};
use crate::world::{Epoch, Surface, World};

/// The vehicle's own body as a box in the body frame (x forward, y right, z down), metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VehicleBody {
    /// Smallest corner.
    pub min: [f64; 3],
    /// Largest corner.
    pub max: [f64; 3],
}

impl VehicleBody {
    /// A van around an IMU 1 m above the road: 4.6 m × 1.9 m, roof 0.5 m above the IMU, floor 0.8 m below.
    pub fn van() -> Self {
        Self { min: [-1.2, -0.95, -0.5], max: [3.4, 0.95, 0.8] }
    }

    /// Distance along a body-frame ray to the box, if it is hit in front of the origin.
    pub(crate) fn hit(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<f64> {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for k in 0..3 {
            if d[k].abs() < 1e-15 {
                if o[k] < self.min[k] || o[k] > self.max[k] {
                    return None;
                }
                continue;
            }
            let (a, b) = ((self.min[k] - o[k]) / d[k], (self.max[k] - o[k]) / d[k]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 <= t1).then_some(t0)
    }
}

/// A rendered panorama and its validity mask (255 = scene, 0 = the vehicle's own body).
#[derive(Clone, Debug)]
pub struct Panorama {
    /// The colour image.
    pub image: RgbImage,
    /// The mask.
    pub mask: GrayImage,
}

fn ray<C: CameraModel>(cam: &C, pose: &MapFromCamera, col: u32, row: u32) -> Option<Vector3<f64>> {
    let d = cam.unproject(Pixel::new(f64::from(col) + 0.5, f64::from(row) + 0.5))?;
    Some(pose.rotation.apply(&d).v)
}

/// An equirectangular panorama from a camera mounted on the vehicle at `body`.
pub fn render_panorama(
    scene: &Scene,
    cam: &Equirectangular,
    mount: &plumbline_geo::dg::CameraMount,
    body: &MapFromBody,
    vehicle: &VehicleBody,
) -> Panorama {
    let pose = mount.camera_pose(body);
    let (w, h) = (cam.width, cam.height);
    let pixel_angle = std::f64::consts::TAU / f64::from(w);
    let to_body = body.inverse();
    let o_body = to_body.transform_point(&pose.translation).p;
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    let mut mask = vec![0u8; (w * h) as usize];
    rgb.par_chunks_mut(w as usize * 3).zip(mask.par_chunks_mut(w as usize)).enumerate().for_each(|(row, (line, m))| {
        for col in 0..w {
            let Some(d) = ray(cam, &pose, col, row as u32) else { continue };
            let d_body = to_body.rotation.quaternion() * d;
            let c = if vehicle.hit(&o_body, &d_body).is_some() {
                [40, 40, 44]
            } else {
                m[col as usize] = 255;
                scene.tone(scene.radiance(&pose.translation.p, &d, pixel_angle))
            };
            line[col as usize * 3..col as usize * 3 + 3].copy_from_slice(&c);
        }
    });
    Panorama {
        image: RgbImage::from_raw(w, h, rgb).unwrap_or_default(),
        mask: GrayImage::from_raw(w, h, mask).unwrap_or_default(),
    }
}

/// [`render_panorama`] as a rig of sub-cameras with a real sensor's radiometry sees it while the vehicle moves
/// at `velocity` (map frame, m/s): each sub-camera looks from its own centre `radius_m` out along its axis
/// (parallax at the seams) with its own exposure gain; rows are read out over `readout_s` while the rig moves
/// (rolling shutter); a surface point smears along its image path over the exposure (motion blur, from its
/// range); then white balance, vignetting per sub-camera, the S-curve and noise (`seed`). With
/// [`Realism::of`]`(Ideal)` it is [`render_panorama`].
#[allow(clippy::too_many_arguments)]
pub fn render_panorama_with(
    scene: &Scene,
    cam: &Equirectangular,
    mount: &plumbline_geo::dg::CameraMount,
    body: &MapFromBody,
    vehicle: &VehicleBody,
    velocity: &Vector3<f64>,
    realism: &Realism,
    seed: u64,
) -> Panorama {
    let (rig, radio) = (&realism.rig, &realism.street);
    if rig.is_ideal() && radio.is_ideal() {
        return render_panorama(scene, cam, mount, body, vehicle);
    }
    let pose = mount.camera_pose(body);
    let (w, h) = (cam.width, cam.height);
    let pixel_angle = std::f64::consts::TAU / f64::from(w);
    let to_body = body.inverse();
    let o_body = to_body.transform_point(&pose.translation).p;
    let centres: Vec<Vector3<f64>> = (0..rig.count())
        .map(|k| {
            let axis = cam.unproject(Pixel::new(rig.axis_column(k, w), f64::from(h) / 2.0));
            let axis = axis.map_or(Vector3::zeros(), |a| pose.rotation.apply(&a).v);
            pose.translation.p + axis * rig.radius_m
        })
        .collect();
    let gains: Vec<f32> = (0..rig.count()).map(|k| rig.gain(k, seed)).collect();
    let origin = |col: u32, row: u32| centres[rig.sector(col, w) as usize] + velocity * rig.row_time(row, h);
    let (mut levels, mut range) = (vec![0f32; (w * h * 3) as usize], vec![f64::INFINITY; (w * h) as usize]);
    let mut mask = vec![0u8; (w * h) as usize];
    levels
        .par_chunks_mut(w as usize * 3)
        .zip(range.par_chunks_mut(w as usize))
        .zip(mask.par_chunks_mut(w as usize))
        .enumerate()
        .for_each(|(row, ((line, ranges), m))| {
            let row = row as u32;
            for col in 0..w {
                let Some(d) = ray(cam, &pose, col, row) else { continue };
                let d_body = to_body.rotation.quaternion() * d;
                let c = if vehicle.hit(&o_body, &d_body).is_some() {
                    [40.0, 40.0, 44.0]
                } else {
                    m[col as usize] = 255;
                    let (radiance, t) = scene.radiance_range(&origin(col, row), &d, pixel_angle);
                    ranges[col as usize] = t;
                    let gain = gains[rig.sector(col, w) as usize] * radio.vignette(rig.edge_share(col, row, w, h));
                    scene.tone_levels(radio.balance(radiance, gain)).map(|v| radio.curve(v))
                };
                line[col as usize * 3..col as usize * 3 + 3].copy_from_slice(&c);
            }
        });
    let smear = velocity * rig.exposure_s;
    if smear.norm() > 0.0 {
        let from_map = pose.inverse().rotation;
        let pixel_of = |p: Vector3<f64>| cam.project(&from_map.apply(&plumbline_geo::Vec3::<Map>::from_vector(p)));
        let sharp = levels.clone();
        levels.par_chunks_mut(w as usize * 3).enumerate().for_each(|(row, line)| {
            let row = row as u32;
            for col in 0..w {
                let i = (row * w + col) as usize;
                let (t, Some(d)) = (range[i], ray(cam, &pose, col, row)) else { continue };
                if !t.is_finite() || mask[i] == 0 {
                    continue;
                }
                let o = origin(col, row);
                let point = o + d * t;
                let (Some(a), Some(b)) = (pixel_of(point - (o - smear / 2.0)), pixel_of(point - (o + smear / 2.0)))
                else {
                    continue;
                };
                let mut du = b.u - a.u;
                if du.abs() > f64::from(w) / 2.0 {
                    du -= du.signum() * f64::from(w);
                }
                let dv = b.v - a.v;
                let steps = (du.hypot(dv).ceil() as u32).clamp(1, 32);
                let (mut sum, mut n) = ([0f32; 3], 0f32);
                for s in 0..=steps {
                    let f = f64::from(s) / f64::from(steps);
                    let u = (a.u + du * f).floor().rem_euclid(f64::from(w)) as u32;
                    let v = (a.v + dv * f).floor().clamp(0.0, f64::from(h - 1)) as u32;
                    let j = (v * w + u) as usize;
                    if mask[j] == 255 {
                        for c in 0..3 {
                            sum[c] += sharp[j * 3 + c];
                        }
                        n += 1.0;
                    }
                }
                if n > 0.0 {
                    for c in 0..3 {
                        line[col as usize * 3 + c] = sum[c] / n;
                    }
                }
            }
        });
    }
    let rgb: Vec<u8> = levels
        .par_iter()
        .enumerate()
        .map(|(i, &v)| {
            let v = if mask[i / 3] == 255 { radio.noisy(v, seed, i as i64) } else { v };
            v.round().clamp(0.0, 255.0) as u8
        })
        .collect();
    Panorama {
        image: RgbImage::from_raw(w, h, rgb).unwrap_or_default(),
        mask: GrayImage::from_raw(w, h, mask).unwrap_or_default(),
    }
}

/// Depth-camera error model (Meyer et al. 2023 §3.1.2: about 8 % of the depth; range 0.4–10 m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthNoise {
    /// Standard deviation as a share of the depth.
    pub share: f64,
    /// Nearest measured depth, metres.
    pub min: f64,
    /// Farthest measured depth, metres.
    pub max: f64,
    /// Seed of the per-pixel noise (use a different one per image).
    pub seed: u64,
}

impl DepthNoise {
    /// The sensor of Meyer et al. (2023): 8 %, 0.4–10 m.
    pub fn realsense(seed: u64) -> Self {
        Self { share: 0.08, min: 0.4, max: 10.0, seed }
    }
}

/// A 16-bit depth image in millimetres (0 = no measurement): depth is the camera-frame z of the first surface.
pub fn render_depth(
    world: &World,
    epoch: Epoch,
    cam: &Pinhole,
    pose: &MapFromCamera,
    noise: &DepthNoise,
) -> ImageBuffer<Luma<u16>, Vec<u16>> {
    let (w, h) = (cam.width, cam.height);
    let axis = pose.rotation.apply(&plumbline_geo::Vec3::new(0.0, 0.0, 1.0)).v;
    let mut px = vec![0u16; (w * h) as usize];
    px.par_chunks_mut(w as usize).enumerate().for_each(|(row, line)| {
        for col in 0..w {
            let Some(d) = ray(cam, pose, col, row as u32) else { continue };
            let Some(hit) = world.trace(&pose.translation.p, &d, noise.max * 3.0, epoch) else { continue };
            let z = hit.t * d.dot(&axis);
            let idx = i64::from(row as u32) * i64::from(w) + i64::from(col);
            // Meyer et al. 2023 §3.1.2: depth error ≈ 8 % of the depth (σ = share · z).
            let noisy = z * (1.0 + noise.share * gaussian(noise.seed, idx));
            if (noise.min..=noise.max).contains(&z) && noisy > 0.0 {
                line[col as usize] = (noisy * 1000.0).round().min(65535.0) as u16;
            }
        }
    });
    ImageBuffer::from_raw(w, h, px).unwrap_or_default()
}

/// Sensor and lens effects of an aerial camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AerialOptics {
    /// Standard deviation of the optical blur (Gaussian point spread), pixels; 0 for none.
    pub blur_px: f64,
    /// Standard deviation of the sensor noise, 8-bit levels.
    pub noise: f32,
    /// Seed of the noise (use a different one per image).
    pub seed: u64,
}

impl AerialOptics {
    /// A typical large-format camera: 0.7 px blur, 2 levels of noise.
    pub fn typical(seed: u64) -> Self {
        Self { blur_px: 0.7, noise: 2.0, seed }
    }
}

/// An aerial frame image (central perspective with K1/K2) from the exterior orientation `pose`, blurred and
/// with sensor noise as `optics` says. Any pinhole colour camera renders this way (e.g. the colour stream of
/// a depth camera: `Scene::mobile` and no blur).
pub fn render_aerial(scene: &Scene, cam: &Pinhole, pose: &MapFromCamera, optics: &AerialOptics) -> RgbImage {
    render_aerial_with(scene, cam, pose, optics, &Radiometry::IDEAL)
}

/// [`render_aerial`] through a sensor's radiometry: white balance, S-curve, vignetting (radial, the image
/// corners at the field's edge) and its noise on top of the optics'.
pub fn render_aerial_with(
    scene: &Scene,
    cam: &Pinhole,
    pose: &MapFromCamera,
    optics: &AerialOptics,
    radiometry: &Radiometry,
) -> RgbImage {
    let (w, h) = (cam.width, cam.height);
    let pixel_angle = 1.0 / cam.fx;
    let corner = (f64::from(w) / 2.0).hypot(f64::from(h) / 2.0);
    let mut lin = vec![0f32; (w * h * 3) as usize];
    lin.par_chunks_mut(w as usize * 3).enumerate().for_each(|(row, line)| {
        for col in 0..w {
            let Some(d) = ray(cam, pose, col, row as u32) else { continue };
            let radiance = scene.radiance(&pose.translation.p, &d, pixel_angle);
            let c = if radiometry.is_ideal() {
                scene.tone(radiance).map(f32::from)
            } else {
                let r =
                    (f64::from(col) + 0.5 - f64::from(w) / 2.0).hypot(f64::from(row as u32) + 0.5 - f64::from(h) / 2.0);
                let balanced = radiometry.balance(radiance, radiometry.vignette(r / corner));
                scene.tone_levels(balanced).map(|v| radiometry.curve(v))
            };
            line[col as usize * 3..col as usize * 3 + 3].copy_from_slice(&c);
        }
    });
    let lin = super::blur::gaussian_rgb(&lin, w as usize, h as usize, optics.blur_px);
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    rgb.par_chunks_mut(w as usize * 3).enumerate().for_each(|(row, line)| {
        for (i, v) in line.iter_mut().enumerate() {
            let idx = row as i64 * i64::from(w) * 3 + i as i64;
            let n = gaussian(optics.seed, idx) as f32 * optics.noise;
            let sensed = radiometry.noisy(lin[idx as usize], optics.seed ^ 0xA5A5, idx);
            *v = (sensed + n).round().clamp(0.0, 255.0) as u8;
        }
    });
    RgbImage::from_raw(w, h, rgb).unwrap_or_default()
}

/// The first surface under a pixel of a camera at `pose` (the panorama's pose is `mount.camera_pose(body)`):
/// its mapping-frame point and what it is. `None` for the sky and for pixels that form no ray.
pub fn ground_truth<C: CameraModel>(
    world: &World,
    epoch: Epoch,
    cam: &C,
    pose: &MapFromCamera,
    pixel: Pixel,
) -> Option<(Point3<Map>, Surface)> {
    let d = pose.rotation.apply(&cam.unproject(pixel)?).v;
    let hit = world.trace(&pose.translation.p, &d, FAR, epoch)?;
    Some((Point3::from_vector(hit.point), hit.surface))
}
