//! Seeded synthetic scenarios for the navigation tests and benchmark: a simulated drive, its IMU increments
//! (plumbline-synth) and white-noise GNSS fixes of the antenna.
#![allow(dead_code, clippy::unwrap_used)]

use nalgebra::Vector3;
use plumbline_geo::{Attitude, Body, Point3, Rotation, Vec3};
use plumbline_navigation::{
    Earth, GnssFix, ImuGapModel, ImuModel, ImuSample, InitialState, NavConfig, STANDARD_GRAVITY,
};
use plumbline_synth::motion::imu::{self, ImuErrors};
use plumbline_synth::motion::routes;
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::route::{Canyon, Route};
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// GNSS σ used by the scenarios: east, north, up (m).
pub const GNSS_STD: [f64; 3] = [0.01, 0.01, 0.02];
/// Antenna lever arm, body frame (m).
pub const LEVER: [f64; 3] = [0.3, -0.2, -0.5];

/// Standard normal draw (Box–Muller).
pub fn gauss(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A simulated drive with everything the filter needs, and its truth.
pub struct Scenario {
    pub drive: Drive,
    pub imu: Vec<ImuSample>,
    pub gnss: Vec<GnssFix>,
    pub initial: InitialState,
    pub config: NavConfig,
}

/// `passes` times around a 240 m × 160 m open-sky block.
pub fn block_route(passes: usize) -> Route {
    routes::block_loop((1000.0, 2000.0), 240.0, 160.0, passes, Canyon::OPEN)
}

/// The filter's model of an IMU grade: on a level vehicle the vertical accelerometer's scale-factor error
/// times g acts as a bias, so it joins the turn-on bias.
pub fn model_of(grade: &ImuErrors) -> ImuModel {
    ImuModel {
        gyro_bias: grade.gyro_bias,
        gyro_bias_instability: grade.gyro_bias_instability,
        gyro_random_walk: grade.gyro_random_walk,
        accel_bias: grade.accel_bias.hypot(grade.accel_scale_factor * STANDARD_GRAVITY),
        accel_bias_instability: grade.accel_bias_instability,
        accel_random_walk: grade.accel_random_walk,
        bias_correlation_time: grade.bias_correlation_time,
    }
}

/// Drive `route` at `imu_rate` Hz with `grade`; GNSS at `gnss_rate` Hz with [`GNSS_STD`]; initial state
/// drawn from its stated σ around the truth.
pub fn scenario(seed: u64, route: &Route, grade: &ImuErrors, imu_rate: f64, gnss_rate: f64) -> Scenario {
    let drive_config = DriveConfig { rate_hz: imu_rate, ..DriveConfig::default() };
    let drive = Drive::simulate(route, &drive_config, seed).unwrap();
    let data = imu::simulate(&drive, grade, seed).unwrap();
    let imu = data
        .records
        .iter()
        .map(|r| ImuSample { time: r.time, dt: r.dt, delta_theta: r.delta_theta, delta_v: r.delta_v })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9e37_79b9);
    let gnss = fixes(&drive, gnss_rate, &mut rng);
    let initial = initial_state(&drive, &mut rng);
    let config = NavConfig {
        imu: model_of(grade),
        lever_arm: Vec3::from_vector(Vector3::from(LEVER)),
        earth: Earth::Flat { gravity: STANDARD_GRAVITY },
        vehicle: None,
        gaps: Some(ImuGapModel::default()),
    };
    Scenario { drive, imu, gnss, initial, config }
}

/// White-noise fixes of the antenna at `rate` Hz on the drive's epochs.
fn fixes(drive: &Drive, rate: f64, rng: &mut ChaCha8Rng) -> Vec<GnssFix> {
    let records = drive.trajectory.records();
    let step = ((records[1].time - records[0].time).recip() / rate).round() as usize;
    let lever = Point3::<Body>::from_vector(Vector3::from(LEVER));
    records
        .iter()
        .step_by(step)
        .map(|r| {
            let antenna = r.pose().transform_point(&lever);
            let noise = Vector3::from_fn(|i, _| GNSS_STD[i] * gauss(rng));
            GnssFix { time: r.time, position: Point3::from_vector(antenna.p + noise), std: GNSS_STD }
        })
        .collect()
}

/// The initial state: truth + errors drawn from the stated σ.
fn initial_state(drive: &Drive, rng: &mut ChaCha8Rng) -> InitialState {
    let (r, k) = (&drive.trajectory.records()[0], &drive.kinematics[0]);
    let (pos_std, vel_std, att_std) = (0.05, 0.02, [2e-4, 2e-4, 2e-3]);
    let phi = Vector3::from_fn(|i, _| att_std[i] * gauss(rng));
    let rot = nalgebra::UnitQuaternion::from_scaled_axis(phi) * r.attitude.to_rotation().quaternion();
    InitialState {
        time: r.time,
        position: Point3::from_vector(r.position.p + Vector3::from_fn(|_, _| pos_std * gauss(rng))),
        velocity: Vec3::from_vector(k.velocity.v + Vector3::from_fn(|_, _| vel_std * gauss(rng))),
        attitude: Attitude::from_rotation(&Rotation::from_quaternion(rot)),
        position_std: pos_std,
        velocity_std: vel_std,
        attitude_std: att_std,
    }
}

/// Add an accelerometer bias step of `step` m/s² on the forward axis to every IMU record after `at`.
pub fn add_bias_step(imu: &mut [ImuSample], at: f64, step: f64) {
    for r in imu.iter_mut().filter(|r| r.time > at) {
        r.delta_v.v.x += step * r.dt;
    }
}

/// Shift the fixes in [a, b) by `offset`, building up linearly over the first `ramp` seconds and fading over
/// the last `ramp` seconds: a multipath jump as the simulator's DG model makes one (not a clean step).
pub fn add_ramped_jump(gnss: &mut [GnssFix], a: f64, b: f64, ramp: f64, offset: Vector3<f64>) {
    for f in gnss.iter_mut().filter(|f| f.time >= a && f.time < b) {
        let share = ((f.time - a) / ramp).min((b - f.time) / ramp).clamp(0.0, 1.0);
        f.position.p += offset * share;
    }
}

/// The scenario's data from `at` on, as if the recording started there (the vehicle already moving).
pub fn starting_at(s: &Scenario, at: f64) -> (Vec<ImuSample>, Vec<GnssFix>) {
    let imu: Vec<ImuSample> = s.imu.iter().filter(|r| r.time - r.dt >= at - 1e-9).copied().collect();
    let start = imu[0].time - imu[0].dt;
    let gnss = s.gnss.iter().filter(|f| f.time >= start - 1e-9).copied().collect();
    (imu, gnss)
}

/// Add white noise of `std` (east, north, up) to every fix and state it in the fixes' σ: canyon-grade fixes.
pub fn degrade_fixes(gnss: &mut [GnssFix], std: [f64; 3], seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_f1c5);
    for f in gnss.iter_mut() {
        for (i, s) in std.iter().enumerate() {
            f.position.p[i] += s * gauss(&mut rng);
            f.std[i] = f.std[i].hypot(*s);
        }
    }
}

/// Replace samples `first..=last` by sample `first − 1`'s rates: a logger's dropout filled by holding the
/// last value. Returns the heading turn the filled samples miss, rad (about the body's z axis).
pub fn hold_dropout(imu: &mut [ImuSample], first: usize, last: usize) -> f64 {
    let held = imu[first - 1];
    let mut missed = 0.0;
    for sample in &mut imu[first..=last] {
        let recorded = sample.delta_theta.v.z;
        sample.delta_theta.v = held.delta_theta.v / held.dt * sample.dt;
        sample.delta_v.v = held.delta_v.v / held.dt * sample.dt;
        missed += recorded - sample.delta_theta.v.z;
    }
    missed
}

/// The first sample after `after` seconds from the start whose turn rate exceeds 0.2 rad/s: the simulated
/// block's corners turn at a constant rate, so this is a corner's onset.
pub fn corner_onset(imu: &[ImuSample], after: f64) -> usize {
    let start = imu[0].time;
    (0..imu.len()).find(|&k| imu[k].time > start + after && (imu[k].delta_theta.v.z / imu[k].dt).abs() > 0.2).unwrap()
}
