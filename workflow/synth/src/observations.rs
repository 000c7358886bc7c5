//! Observations simulated from the truth, standing in for the registration and pole-detection pipelines
//! while those are built: pole coordinate updates (CUPTs) and tie points with aerial coordinates, with the
//! error models the papers state. Plain values; the adjuster's message types are filled by the caller.
//!
//! - **Pole CUPTs** (Meyer et al. 2023 §3.4.2): at depth-image epochs, every listed cadastre object that exists and
//!   lies 3–15 m to the right of the vehicle (inside the side camera's ±45° view) is measured in the body
//!   frame with σ = 8 % of its depth per horizontal axis (the depth-camera error of Meyer et al. 2023), georeferenced
//!   with the DG pose; its cadastre position is the listed one (with the cadastre's own error), σ_pole the
//!   class accuracy. Occlusion and detection failures are not modelled.
//! - **Tie points** (Jende et al. 2017 §3.4–3.9): at each panorama, road-surface points 3–8 m ahead and 2–6 m to
//!   either side, seen from that panorama and the next one as unit rays in the camera frame (true pose,
//!   angular noise `ray_sigma`), with aerial-triangulated coordinates whose horizontal σ is
//!   `aerial_pixels` × `aerial_gsd` (the matching precision in aerial pixels) and twice that in height.

use nalgebra::Vector3;
use plumbline_geo::dg::CameraMount;
use plumbline_geo::{MapFromBody, Point3, PositionInterpolation, Rotation, Trajectory, TrajectoryRecord};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::cadastre::{CadastreObject, Defect};
use crate::motion::Drive;
use crate::sensors::{SensorError, moving_times, spaced_times};

/// Parameters of the simulated observations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObservationConfig {
    /// Depth-image epochs per second while moving (one CUPT per visible pole per epoch).
    pub depth_rate: f64,
    /// Nearest and farthest horizontal distance of a measured pole, m.
    pub pole_range: [f64; 2],
    /// Depth-camera σ as a share of the depth (Meyer et al. 2023: 8 %).
    pub depth_share: f64,
    /// Panorama spacing, m driven.
    pub panorama_spacing: f64,
    /// Tie points started at each panorama.
    pub ties_per_panorama: usize,
    /// Angular σ of a panorama ray, rad.
    pub ray_sigma: f64,
    /// Ground sample distance of the aerial images, m.
    pub aerial_gsd: f64,
    /// Matching precision in aerial pixels (horizontal σ = pixels × GSD).
    pub aerial_pixels: f64,
}

impl Default for ObservationConfig {
    fn default() -> Self {
        Self {
            depth_rate: 1.0,
            pole_range: [3.0, 15.0],
            depth_share: 0.08,
            panorama_spacing: 5.0,
            ties_per_panorama: 4,
            ray_sigma: 1e-3,
            aerial_gsd: 0.12,
            aerial_pixels: 2.0,
        }
    }
}

/// A simulated pole coordinate update.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulatedPole {
    /// The cadastre's id of the object.
    pub cadastre_id: String,
    /// Epoch of the depth image.
    pub time: f64,
    /// The listed (cadastre) position: easting, northing.
    pub cadastre: [f64; 2],
    /// The measured position georeferenced with the DG pose: easting, northing.
    pub observed: [f64; 2],
    /// σ of the measurement (8 % of depth), m.
    pub sigma_camera: f64,
    /// σ of the cadastre position (class accuracy), m.
    pub sigma_pole: f64,
}

/// One panorama ray to a tie point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimulatedRay {
    /// Exposure time.
    pub time: f64,
    /// Unit direction in the camera frame.
    pub direction: [f64; 3],
    /// Angular σ, rad.
    pub sigma: f64,
}

/// A simulated tie point.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulatedTie {
    /// Campaign-unique id.
    pub id: String,
    /// The true ground point.
    pub truth: [f64; 3],
    /// Rays from two panoramas.
    pub rays: Vec<SimulatedRay>,
    /// Aerial-triangulated coordinates and their covariance (diagonal), m and m².
    pub aerial: ([f64; 3], [[f64; 3]; 3]),
}

/// A standard normal draw (Box–Muller).
pub(crate) fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

fn at(trajectory: &Trajectory, time: f64, which: &'static str) -> Result<TrajectoryRecord, SensorError> {
    trajectory.interpolate(time, PositionInterpolation::Cubic).map_err(|e| SensorError::Interpolation {
        trajectory: which,
        id: String::new(),
        time,
        reason: e.to_string(),
    })
}

/// CUPTs of the listed, existing cadastre objects along `drive` (DG trajectory `dg`).
pub fn pole_updates(
    drive: &Drive,
    dg: &Trajectory,
    objects: &[CadastreObject],
    config: &ObservationConfig,
    seed: u64,
) -> Result<Vec<SimulatedPole>, SensorError> {
    let mut rng = rng(seed, 101);
    let listed: Vec<(&CadastreObject, [f64; 2], i64)> = objects
        .iter()
        .filter(|o| o.defect == Defect::None)
        .filter_map(|o| Some((o, o.listed?, o.cadastre_id?)))
        .collect();
    let mut out = Vec::new();
    for time in moving_times(drive, config.depth_rate)? {
        let (truth, pose) = (at(&drive.trajectory, time, "true")?, at(dg, time, "DG")?);
        let r_true = truth.attitude.to_rotation().matrix();
        let r_dg = pose.attitude.to_rotation().matrix();
        for (o, listed, id) in &listed {
            let d = Vector3::new(o.truth[0] - truth.position.x(), o.truth[1] - truth.position.y(), 0.0);
            let range = d.norm();
            if range < config.pole_range[0] || range > config.pole_range[1] {
                continue;
            }
            let body = r_true.transpose() * d;
            if body.y <= body.x.abs() {
                continue;
            }
            let sigma = config.depth_share * body.y;
            let measured = Vector3::new(body.x + sigma * normal(&mut rng), body.y + sigma * normal(&mut rng), body.z);
            let observed = pose.position.p + r_dg * measured;
            let sigma_pole = if o.class == "tree" { 0.5 } else { 0.1 };
            out.push(SimulatedPole {
                cadastre_id: id.to_string(),
                time,
                cadastre: *listed,
                observed: [observed.x, observed.y],
                sigma_camera: sigma,
                sigma_pole,
            });
        }
    }
    Ok(out)
}

/// Tie points along `drive` seen by the panoramic camera `mount`, with aerial coordinates.
pub fn tie_points(
    drive: &Drive,
    mount: &CameraMount,
    config: &ObservationConfig,
    seed: u64,
) -> Result<Vec<SimulatedTie>, SensorError> {
    let mut rng = rng(seed, 102);
    let times = spaced_times(drive, config.panorama_spacing)?;
    let sh = config.aerial_pixels * config.aerial_gsd;
    let covariance = [[sh * sh, 0.0, 0.0], [0.0, sh * sh, 0.0], [0.0, 0.0, 4.0 * sh * sh]];
    let mut out = Vec::new();
    for (i, w) in times.windows(2).enumerate() {
        let (a, b) = (at(&drive.trajectory, w[0], "true")?, at(&drive.trajectory, w[1], "true")?);
        let r = a.attitude.to_rotation().matrix();
        for k in 0..config.ties_per_panorama {
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            let body = Vector3::new(3.0 + 5.0 * rng.random::<f64>(), side * (2.0 + 4.0 * rng.random::<f64>()), 1.0);
            let x = a.position.p + r * body;
            let rays = [(w[0], &a), (w[1], &b)].map(|(t, rec)| ray(rec, mount, &x, t, config.ray_sigma, &mut rng));
            let noise = Vector3::new(sh * normal(&mut rng), sh * normal(&mut rng), 2.0 * sh * normal(&mut rng));
            let aerial = x + noise;
            out.push(SimulatedTie {
                id: format!("tie-{i:06}-{k}"),
                truth: [x.x, x.y, x.z],
                rays: rays.to_vec(),
                aerial: ([aerial.x, aerial.y, aerial.z], covariance),
            });
        }
    }
    Ok(out)
}

/// The unit ray from the camera at the true pose `rec` to `x`, perturbed by `sigma` in the tangent plane.
fn ray(
    rec: &TrajectoryRecord,
    mount: &CameraMount,
    x: &Vector3<f64>,
    time: f64,
    sigma: f64,
    rng: &mut ChaCha8Rng,
) -> SimulatedRay {
    let body = MapFromBody::new(Rotation::from_matrix(&rec.attitude.to_rotation().matrix()), rec.position);
    let u = mount.to_camera(&body, &Point3::from_vector(*x)).v.normalize();
    let helper = if u.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let b1 = u.cross(&helper).normalize();
    let b2 = u.cross(&b1);
    let d = (u + b1 * (sigma * normal(rng)) + b2 * (sigma * normal(rng))).normalize();
    SimulatedRay { time, direction: [d.x, d.y, d.z], sigma }
}
