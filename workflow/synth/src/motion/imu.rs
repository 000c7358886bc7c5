//! IMU increments (Δθ, Δv in the body frame) from the true motion, with the errors of an IMU grade.
//!
//! Error-free increments over [t_k, t_{k+1}]: Δθ = Log(R_k⁻¹ R_{k+1}) (body-frame rotation vector) and
//! Δv = R_mid⁻¹ (v_{k+1} − v_k − g Δt) with R_mid the rotation half-way (slerp) and g = (0, 0, −`gravity`) in
//! the east-north-up mapping frame: the specific force, so a resting IMU reads Δv = (0, 0, −g Δt) in its
//! x-forward, y-right, z-down body frame. Earth rotation (15°/h) and the variation of gravity are neglected:
//! the increments are those of a flat, non-rotating Earth, which a matching strapdown integration reproduces.
//!
//! Errors per axis: measured = (1 + s)·true + (b + β(t))·Δt + n, with a constant scale-factor error s ~ N(0,
//! σ_s), a turn-on bias b ~ N(0, σ_b), a bias instability β (first-order Gauss–Markov, σ_β, τ_β) and white
//! noise n ~ N(0, (N·√Δt)²) from the angle/velocity random walk N.

use nalgebra::Vector3;
use plumbline_geo::{Body, Map, Rotation, Vec3};
use serde::{Deserialize, Serialize};

use super::rng::{Purpose, Stream};
use super::{Drive, MotionError};

const DEG: f64 = std::f64::consts::PI / 180.0;
const HOUR: f64 = 3600.0;
/// Standard gravity, m/s².
pub const STANDARD_GRAVITY: f64 = 9.806_65;
const MICRO_G: f64 = 1e-6 * STANDARD_GRAVITY;

/// Error parameters of an IMU, per axis (1σ). SI units: rad, m, s.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImuErrors {
    /// Turn-on gyro bias, rad/s.
    pub gyro_bias: f64,
    /// Gyro bias instability (Gauss–Markov σ), rad/s.
    pub gyro_bias_instability: f64,
    /// Angle random walk, rad/√s.
    pub gyro_random_walk: f64,
    /// Gyro scale-factor error (dimensionless).
    pub gyro_scale_factor: f64,
    /// Turn-on accelerometer bias, m/s².
    pub accel_bias: f64,
    /// Accelerometer bias instability (Gauss–Markov σ), m/s².
    pub accel_bias_instability: f64,
    /// Velocity random walk, m/s/√s.
    pub accel_random_walk: f64,
    /// Accelerometer scale-factor error (dimensionless).
    pub accel_scale_factor: f64,
    /// Correlation time of both bias instabilities, s.
    pub bias_correlation_time: f64,
}

impl ImuErrors {
    /// No errors at all.
    pub const PERFECT: Self = Self {
        gyro_bias: 0.0,
        gyro_bias_instability: 0.0,
        gyro_random_walk: 0.0,
        gyro_scale_factor: 0.0,
        accel_bias: 0.0,
        accel_bias_instability: 0.0,
        accel_random_walk: 0.0,
        accel_scale_factor: 0.0,
        bias_correlation_time: 3600.0,
    };

    /// Navigation grade, Litton LN-100 class (Grejner-Brzezinska and Toth 2000 §2.1 call it tactical): gyro bias
    /// 0.003°/h, accelerometer bias 25 µg (Grejner-Brzezinska and Toth 2000 §2.1); ARW 0.001°/√h, VRW 5 µg/√Hz,
    /// instabilities 0.001°/h and 5 µg over 1 h, scale factors 5 and 50 ppm
    /// (typical ring-laser values, not from the paper).
    pub const NAVIGATION: Self = Self {
        gyro_bias: 0.003 * DEG / HOUR,
        gyro_bias_instability: 0.001 * DEG / HOUR,
        gyro_random_walk: 0.001 * DEG / 60.0,
        gyro_scale_factor: 5e-6,
        accel_bias: 25.0 * MICRO_G,
        accel_bias_instability: 5.0 * MICRO_G,
        accel_random_walk: 5.0 * MICRO_G,
        accel_scale_factor: 50e-6,
        bias_correlation_time: 3600.0,
    };

    /// Consumer MEMS, Bosch BMI160 class (Meyer et al. 2023 §3.1.1; Bosch datasheet): zero-rate offset ±3°/s and
    /// zero-g offset ±40 mg taken as 3σ, noise densities 0.007°/s/√Hz and 180 µg/√Hz, sensitivity tolerance
    /// ±1 % as 3σ; bias instability 10°/h and 0.1 mg over 5 min (typical MEMS, not in the datasheet).
    pub const CONSUMER: Self = Self {
        gyro_bias: 1.0 * DEG,
        gyro_bias_instability: 10.0 * DEG / HOUR,
        gyro_random_walk: 0.007 * DEG,
        gyro_scale_factor: 0.01 / 3.0,
        accel_bias: 40e3 * MICRO_G / 3.0,
        accel_bias_instability: 100.0 * MICRO_G,
        accel_random_walk: 180.0 * MICRO_G,
        accel_scale_factor: 0.01 / 3.0,
        bias_correlation_time: 300.0,
    };
}

/// One IMU record: the increments over the interval ending at `time`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuRecord {
    /// End of the interval, s.
    pub time: f64,
    /// Length of the interval, s.
    pub dt: f64,
    /// Angle increment, body frame, rad.
    pub delta_theta: Vec3<Body>,
    /// Velocity increment (specific force × dt), body frame, m/s.
    pub delta_v: Vec3<Body>,
}

/// The drawn constant errors (ground truth for a re-fusion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuErrorDraw {
    /// Turn-on gyro bias per axis, rad/s.
    pub gyro_bias: [f64; 3],
    /// Turn-on accelerometer bias per axis, m/s².
    pub accel_bias: [f64; 3],
    /// Gyro scale-factor errors.
    pub gyro_scale_factor: [f64; 3],
    /// Accelerometer scale-factor errors.
    pub accel_scale_factor: [f64; 3],
}

/// Simulated IMU data of a drive.
#[derive(Clone, Debug)]
pub struct ImuData {
    /// One record per interval between trajectory epochs.
    pub records: Vec<ImuRecord>,
    /// The constant errors that were drawn.
    pub errors: ImuErrorDraw,
    /// Gravity used, m/s².
    pub gravity: f64,
}

/// Simulate the IMU of `drive` with `errors`; noise from `seed`.
pub fn simulate(drive: &Drive, errors: &ImuErrors, seed: u64) -> Result<ImuData, MotionError> {
    Ok(ImuStream::new(errors, seed)?.leg(drive))
}

/// The true state at an epoch that the next increment starts from.
#[derive(Clone, Copy, Debug)]
struct State {
    rotation: Rotation<Map, Body>,
    velocity: Vec3<Map>,
    time: f64,
}

/// The IMU of a drive simulated in legs (the `city` preset): the drawn constant errors, the bias-instability
/// states and the noise continue from leg to leg, and each leg starts with the increment from the previous
/// leg's last epoch, so the joined records are those of one drive; [`simulate`] is one leg.
#[derive(Clone, Debug)]
pub struct ImuStream {
    errors: ImuErrors,
    draw: ImuErrorDraw,
    rng: Stream,
    gyro_gm: [f64; 3],
    accel_gm: [f64; 3],
    last: Option<State>,
}

impl ImuStream {
    /// A new IMU with `errors`; the constant errors and the noise come from `seed`.
    pub fn new(errors: &ImuErrors, seed: u64) -> Result<Self, MotionError> {
        check(errors)?;
        let mut rng = Stream::new(seed, Purpose::Imu);
        let draw3 = |rng: &mut Stream, s: f64| [s * rng.normal(), s * rng.normal(), s * rng.normal()];
        let draw = ImuErrorDraw {
            gyro_bias: draw3(&mut rng, errors.gyro_bias),
            accel_bias: draw3(&mut rng, errors.accel_bias),
            gyro_scale_factor: draw3(&mut rng, errors.gyro_scale_factor),
            accel_scale_factor: draw3(&mut rng, errors.accel_scale_factor),
        };
        let gyro_gm = draw3(&mut rng, errors.gyro_bias_instability);
        let accel_gm = draw3(&mut rng, errors.accel_bias_instability);
        Ok(Self { errors: *errors, draw, rng, gyro_gm, accel_gm, last: None })
    }

    /// The records of the next leg `drive` (epochs after the previous leg's): one per interval, the first
    /// from the previous leg's last epoch when there is one.
    pub fn leg(&mut self, drive: &Drive) -> ImuData {
        let epochs = drive.trajectory.records().iter().zip(&drive.kinematics).map(|(r, k)| State {
            rotation: r.attitude.to_rotation(),
            velocity: k.velocity,
            time: r.time,
        });
        let mut records = Vec::with_capacity(drive.kinematics.len());
        for epoch in epochs {
            if let Some(previous) = self.last.replace(epoch) {
                records.push(self.record(&previous, &epoch));
            }
        }
        ImuData { records, errors: self.draw, gravity: STANDARD_GRAVITY }
    }

    /// The measured increments over [a, b]: the true ones with the errors of the module doc.
    fn record(&mut self, a: &State, b: &State) -> ImuRecord {
        let (errors, draw) = (&self.errors, &self.draw);
        let dt = b.time - a.time;
        let (dtheta, dv) = true_increments(&a.rotation, &b.rotation, &a.velocity, &b.velocity, dt, STANDARD_GRAVITY);
        let phi = (-dt / errors.bias_correlation_time).exp();
        let q = (1.0 - phi * phi).sqrt();
        let mut out_theta = [0.0; 3];
        let mut out_v = [0.0; 3];
        for k in 0..3 {
            let rng = &mut self.rng;
            self.gyro_gm[k] = phi * self.gyro_gm[k] + q * errors.gyro_bias_instability * rng.normal();
            self.accel_gm[k] = phi * self.accel_gm[k] + q * errors.accel_bias_instability * rng.normal();
            let (nt, nv) = (
                errors.gyro_random_walk * dt.sqrt() * rng.normal(),
                errors.accel_random_walk * dt.sqrt() * rng.normal(),
            );
            out_theta[k] =
                (1.0 + draw.gyro_scale_factor[k]) * dtheta[k] + (draw.gyro_bias[k] + self.gyro_gm[k]) * dt + nt;
            out_v[k] = (1.0 + draw.accel_scale_factor[k]) * dv[k] + (draw.accel_bias[k] + self.accel_gm[k]) * dt + nv;
        }
        ImuRecord {
            time: b.time,
            dt,
            delta_theta: Vec3::from_vector(Vector3::from(out_theta)),
            delta_v: Vec3::from_vector(Vector3::from(out_v)),
        }
    }
}

/// Error-free Δθ and Δv between two epochs (see the module doc).
fn true_increments(
    r0: &Rotation<Map, Body>,
    r1: &Rotation<Map, Body>,
    v0: &Vec3<Map>,
    v1: &Vec3<Map>,
    dt: f64,
    gravity: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let rel = r0.quaternion().inverse() * r1.quaternion();
    let dtheta = rel.scaled_axis();
    let mid = r0.slerp(r1, 0.5);
    let g = Vec3::<Map>::new(0.0, 0.0, -gravity);
    let specific = (*v1 - *v0) - g * dt;
    let dv = mid.inverse().apply(&specific);
    (dtheta, dv.v)
}

fn check(e: &ImuErrors) -> Result<(), MotionError> {
    let fields = [
        ("gyro_bias", e.gyro_bias),
        ("gyro_bias_instability", e.gyro_bias_instability),
        ("gyro_random_walk", e.gyro_random_walk),
        ("gyro_scale_factor", e.gyro_scale_factor),
        ("accel_bias", e.accel_bias),
        ("accel_bias_instability", e.accel_bias_instability),
        ("accel_random_walk", e.accel_random_walk),
        ("accel_scale_factor", e.accel_scale_factor),
    ];
    for (field, value) in fields {
        if !(value.is_finite() && value >= 0.0) {
            return Err(MotionError::Config { config: "imu", field, value, expected: "a finite σ >= 0" });
        }
    }
    if !(e.bias_correlation_time.is_finite() && e.bias_correlation_time > 0.0) {
        let value = e.bias_correlation_time;
        return Err(MotionError::Config { config: "imu", field: "bias_correlation_time", value, expected: "> 0 s" });
    }
    Ok(())
}
