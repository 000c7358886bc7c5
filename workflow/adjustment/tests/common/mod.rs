//! Seeded synthetic streets for the adjustment tests: a true trajectory, a DG trajectory that is the truth
//! minus a known correction, and observations of poles, tie points and GNSS made from the truth.
#![allow(dead_code, clippy::unwrap_used)]

use nalgebra::{Rotation3, Vector3, Vector6};
use plumbline_adjustment::{GnssPosition, PoleUpdate, TiePoint, TiePointId, TieRay};
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::{Attitude, Point3, PoseStd, Rotation, Trajectory, TrajectoryRecord, ValidationLimits};
use rand::{Rng, RngExt};

/// A drive with its truth.
pub struct Scene {
    pub truth: Vec<TrajectoryRecord>,
    pub dg: Trajectory,
    /// The correction taking DG to truth at each record: [δp; δθ], R_true = Exp(δθ) R_dg.
    pub correction: Vec<Vector6<f64>>,
}

pub fn mount() -> CameraMount {
    CameraMount::new([0.5, 0.0, -2.0], &Boresight::from_degrees(0.1, -0.2, 0.3))
}

pub fn gauss(rng: &mut impl Rng) -> f64 {
    // Box–Muller.
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Truth pose at time t: out along a gently curving street at 10 m/s, or out and back (`return_at`).
pub fn truth_pose(t: f64, return_at: Option<f64>) -> (Vector3<f64>, f64) {
    let dir = 30f64.to_radians();
    let (s, lane, back) = match return_at {
        Some(r) if t > r => (10.0 * (2.0 * r - t), -3.0, true),
        _ => (10.0 * t, 0.0, false),
    };
    let lateral = 3.0 * (s / 150.0).sin() + lane;
    let (fwd, left) = (Vector3::new(dir.cos(), dir.sin(), 0.0), Vector3::new(-dir.sin(), dir.cos(), 0.0));
    let p = fwd * s + left * lateral + Vector3::new(500_000.0, 5_400_000.0, 50.0);
    let slope = (3.0 / 150.0) * (s / 150.0).cos();
    let v = (fwd + left * slope) * if back { -1.0 } else { 1.0 };
    (p, v.x.atan2(v.y).rem_euclid(std::f64::consts::TAU))
}

/// Build a scene from a correction function and the DG σ the trajectory reports.
pub fn scene(duration: f64, rate: f64, return_at: Option<f64>, corr: impl Fn(f64) -> Vector6<f64>, std: f64) -> Scene {
    let n = (duration * rate) as usize + 1;
    let (mut truth, mut dg, mut correction) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let t = i as f64 / rate;
        let (p, heading) = truth_pose(t, return_at);
        let att = Attitude::new(0.01, -0.005, heading);
        let rec = TrajectoryRecord { time: t, position: Point3::from_vector(p), attitude: att, std: None };
        let d = corr(t);
        let r_true = att.to_rotation().matrix();
        let r_dg = Rotation3::new(-d.fixed_rows::<3>(3).into_owned()).into_inner() * r_true;
        let std = PoseStd { east: std, north: std, height: std, roll: 3e-4, pitch: 3e-4, heading: 8e-4 };
        dg.push(TrajectoryRecord {
            time: t,
            position: Point3::from_vector(p - d.fixed_rows::<3>(0).into_owned()),
            attitude: Attitude::from_rotation(&Rotation::from_matrix(&r_dg)),
            std: Some(std),
        });
        truth.push(rec);
        correction.push(d);
    }
    Scene { truth, dg: Trajectory::new(dg, &ValidationLimits::default()).unwrap(), correction }
}

/// Smooth drift (decimetres) plus a 0.3 m east jump at t = `jump_at`, and a slow heading drift.
pub fn drift_and_jump(jump_at: f64) -> impl Fn(f64) -> Vector6<f64> {
    move |t| {
        let jump = if t >= jump_at { 0.3 } else { 0.0 };
        Vector6::new(
            0.25 * (t / 25.0).sin() + jump,
            0.15 * (t / 40.0).cos() - 0.1,
            0.05 * (t / 10.0).sin(),
            2e-4,
            -1e-4,
            5e-4 * (t / 30.0).sin(),
        )
    }
}

/// Truth correction as a realisation of the model's own random walk (DG σ 0.05 m, τ = 10 s).
pub fn random_walk_truth(seed: u64) -> impl Fn(f64) -> Vector6<f64> {
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(seed);
    let cfg = plumbline_adjustment::AdjustmentConfig::default().random_walk;
    let pos = (cfg.position_floor.powi(2) + 0.05f64.powi(2) / cfg.correlation_time).sqrt();
    let mut state = Vector6::new(0.2, -0.1, 0.05, 0.0, 0.0, 0.0);
    let mut path = vec![state];
    for _ in 0..1300 {
        // 0.1 s steps; attitude held constant so only position carries the walk.
        for c in 0..3 {
            state[c] += gauss(&mut rng) * pos * 0.1f64.sqrt();
        }
        path.push(state);
    }
    move |t: f64| path[((t * 10.0).round() as usize).min(path.len() - 1)]
}

/// Poles seen every `every` records, alternately left and right, 8 m ahead and 6 m aside, measured with
/// noise σ_cam (cadastre exact, reported σ_pole).
pub fn poles(s: &Scene, every: usize, sigma_cam: f64, sigma_pole: f64, rng: &mut impl Rng) -> Vec<PoleUpdate> {
    (every / 2..s.truth.len())
        .step_by(every)
        .enumerate()
        .map(|(j, i)| {
            let side = if j % 2 == 0 { 6.0 } else { -6.0 };
            let b = Vector3::new(8.0, side, 0.0);
            let (tr, dg) = (&s.truth[i], &s.dg.records()[i]);
            let c = tr.position.p + tr.attitude.to_rotation().matrix() * b;
            let noise = Vector3::new(gauss(rng), gauss(rng), 0.0) * sigma_cam;
            let o = dg.position.p + dg.attitude.to_rotation().matrix() * b + noise;
            PoleUpdate {
                cadastre_id: format!("pole-{j}"),
                time: tr.time,
                cadastre: [c.x, c.y],
                observed: [o.x, o.y],
                sigma_camera: sigma_cam.max(1e-3),
                sigma_pole,
            }
        })
        .collect()
}

/// A tie point at `x` seen from records `at`, with angular noise σ.
pub fn tie(s: &Scene, id: &str, x: Vector3<f64>, at: &[usize], sigma: f64, rng: &mut impl Rng) -> TiePoint {
    let m = mount();
    let rays = at
        .iter()
        .map(|&i| {
            let tr = &s.truth[i];
            let d = m.to_camera(&tr.pose(), &Point3::from_vector(x)).v.normalize();
            let noisy = (d + Vector3::new(gauss(rng), gauss(rng), gauss(rng)) * sigma).normalize();
            TieRay::new(tr.time, [noisy.x, noisy.y, noisy.z], sigma)
        })
        .collect();
    TiePoint { id: TiePointId(id.into()), rays, aerial: None }
}

/// GNSS antenna positions at records `at` with noise σ.
pub fn gnss(s: &Scene, at: &[usize], sigma: f64, rng: &mut impl Rng) -> Vec<GnssPosition> {
    let lever = Vector3::new(-0.5, 0.2, -1.5);
    at.iter()
        .map(|&i| {
            let tr = &s.truth[i];
            let a = tr.position.p + tr.attitude.to_rotation().matrix() * lever;
            let n = Vector3::new(gauss(rng), gauss(rng), gauss(rng)) * sigma;
            GnssPosition { time: tr.time, position: (a + n).into(), sigma: [sigma; 3], lever_arm: lever.into() }
        })
        .collect()
}

/// Horizontal errors of a trajectory against the truth at every record, metres.
pub fn horizontal_errors(t: &Trajectory, truth: &[TrajectoryRecord]) -> Vec<f64> {
    t.records().iter().zip(truth).map(|(a, b)| (a.position.p - b.position.p).xy().norm()).collect()
}

pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

pub fn max(v: &[f64]) -> f64 {
    v.iter().cloned().fold(0.0, f64::max)
}
