//! The nominal navigation state, its strapdown mechanisation and the error-state transition.
//!
//! Mechanisation in the map frame (east-north-up) on the configured [`Earth`]: flat, not rotating, gravity
//! along −z (the model the simulator, `plumbline_synth::motion::imu`, generates increments with), or WGS 84
//! with Earth rate, transport rate, Coriolis and normal gravity. Error state
//! (18): δp, δv (map), φ (attitude error, map-frame rotation vector, C_true = Exp(φ)·C), δb_a, δb_g (body),
//! and δe, the lasting part of the GNSS positions' error (map; a first-order Gauss–Markov process per axis,
//! [`crate::CorrelatedGnssError`]; held near zero when none is modelled).

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use crate::config::{CorrelatedGnssError, ImuModel};
use crate::earth::Earth;
use crate::inputs::ImuSample;

/// Dimension of the error state.
pub(crate) const N: usize = 18;
/// N × N matrix of the error state.
pub(crate) type ErrMat = SMatrix<f64, N, N>;
/// Error-state vector.
pub(crate) type ErrVec = SVector<f64, N>;

/// Offsets of the error-state blocks.
pub(crate) const POS: usize = 0;
pub(crate) const VEL: usize = 3;
pub(crate) const ATT: usize = 6;
pub(crate) const BA: usize = 9;
pub(crate) const BG: usize = 12;
pub(crate) const GNSS: usize = 15;

/// The nominal (whole) state at one epoch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Nominal {
    pub time: f64,
    pub position: Vector3<f64>,
    pub velocity: Vector3<f64>,
    /// R_B^M.
    pub attitude: UnitQuaternion<f64>,
    pub accel_bias: Vector3<f64>,
    pub gyro_bias: Vector3<f64>,
    /// The GNSS positions' lasting error (fix = antenna + this + white noise), m.
    pub gnss_error: Vector3<f64>,
}

/// Skew-symmetric matrix: `skew(a) * b == a × b`.
pub(crate) fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

impl Nominal {
    /// Bias-corrected increments: (Δθ − b_g dt, Δv − b_a dt).
    fn corrected(&self, s: &ImuSample) -> (Vector3<f64>, Vector3<f64>) {
        (s.delta_theta.v - self.gyro_bias * s.dt, s.delta_v.v - self.accel_bias * s.dt)
    }

    /// The velocity increment in the map frame (without gravity), rotated with the mid-interval attitude.
    fn map_delta_v(&self, s: &ImuSample) -> Vector3<f64> {
        let (theta, dv) = self.corrected(s);
        (self.attitude * UnitQuaternion::from_scaled_axis(theta * 0.5)) * dv
    }

    /// Rotation of the map frame against inertial space (Earth rate + transport rate) at this state, rad/s.
    fn frame_rate(&self, earth: &Earth) -> (Vector3<f64>, Vector3<f64>) {
        (earth.earth_rate(), earth.transport_rate(&self.velocity, self.position.z))
    }

    /// Strapdown step over one IMU interval: attitude by the rotation vector less the frame's own rotation,
    /// velocity with the mid-interval attitude, Coriolis and gravity, position by the trapezoid (on the flat
    /// Earth, the simulator's increment definition, `motion::imu`).
    pub fn propagate(&self, s: &ImuSample, earth: &Earth) -> Self {
        let (theta, _) = self.corrected(s);
        let (ie, en) = self.frame_rate(earth);
        let gravity = earth.gravity(self.position.z);
        let coriolis = (2.0 * ie + en).cross(&self.velocity) * s.dt;
        let frame_half = UnitQuaternion::from_scaled_axis(-(ie + en) * (0.5 * s.dt));
        let velocity =
            self.velocity + frame_half * self.map_delta_v(s) - coriolis + Vector3::new(0.0, 0.0, -gravity * s.dt);
        let frame = UnitQuaternion::from_scaled_axis(-(ie + en) * s.dt);
        Self {
            time: s.time,
            position: self.position + (self.velocity + velocity) * (0.5 * s.dt),
            velocity,
            attitude: frame * self.attitude * UnitQuaternion::from_scaled_axis(theta),
            ..*self
        }
    }

    /// Inject an error-state estimate (closed loop): the corrected nominal state.
    pub fn inject(&self, dx: &ErrVec) -> Self {
        let block = |o: usize| Vector3::new(dx[o], dx[o + 1], dx[o + 2]);
        Self {
            time: self.time,
            position: self.position + block(POS),
            velocity: self.velocity + block(VEL),
            attitude: UnitQuaternion::from_scaled_axis(block(ATT)) * self.attitude,
            accel_bias: self.accel_bias + block(BA),
            gyro_bias: self.gyro_bias + block(BG),
            gnss_error: self.gnss_error + block(GNSS),
        }
    }

    /// Error-state transition F over the interval of `s` (first order in dt): `tau` is the IMU biases'
    /// correlation time, `gnss_tau` the GNSS error's.
    pub fn transition(&self, s: &ImuSample, tau: f64, gnss_tau: f64, earth: &Earth) -> ErrMat {
        let c = self.attitude.to_rotation_matrix().into_inner();
        let decay = (-s.dt / tau).exp();
        let gnss_decay = (-s.dt / gnss_tau).exp();
        let (ie, en) = self.frame_rate(earth);
        let mut f = ErrMat::identity();
        f.fixed_view_mut::<3, 3>(POS, VEL).copy_from(&(Matrix3::identity() * s.dt));
        // The frame's rotation turns the attitude error, Coriolis the velocity error (rate derivatives by
        // position and velocity are below the tactical gyro noise and left out).
        f.fixed_view_mut::<3, 3>(ATT, ATT).copy_from(&(Matrix3::identity() - skew(&(ie + en)) * s.dt));
        f.fixed_view_mut::<3, 3>(VEL, VEL).copy_from(&(Matrix3::identity() - skew(&(2.0 * ie + en)) * s.dt));
        f.fixed_view_mut::<3, 3>(VEL, ATT).copy_from(&(-skew(&self.map_delta_v(s))));
        f.fixed_view_mut::<3, 3>(VEL, BA).copy_from(&(-c * s.dt));
        f.fixed_view_mut::<3, 3>(ATT, BG).copy_from(&(-c * s.dt));
        for i in BA..GNSS {
            f[(i, i)] = decay;
        }
        for i in GNSS..N {
            f[(i, i)] = gnss_decay;
        }
        f
    }
}

/// Diagonal process noise of one interval from the IMU model (random walks and Gauss–Markov biases) and
/// the GNSS error's Gauss–Markov model (steady σ `gnss.std`).
pub(crate) fn process_noise(imu: &ImuModel, gnss: &CorrelatedGnssError, dt: f64) -> ErrVec {
    let gm = 1.0 - (-2.0 * dt / imu.bias_correlation_time).exp();
    let gnss_gm = 1.0 - (-2.0 * dt / gnss.correlation_time).exp();
    let mut q = ErrVec::zeros();
    for a in 0..3 {
        q[VEL + a] = imu.accel_random_walk.powi(2) * dt;
        q[ATT + a] = imu.gyro_random_walk.powi(2) * dt;
        q[BA + a] = imu.accel_bias_instability.powi(2) * gm;
        q[BG + a] = imu.gyro_bias_instability.powi(2) * gm;
        q[GNSS + a] = gnss.std[a].powi(2) * gnss_gm;
    }
    q
}

/// F·M·Fᵀ for a matrix F shaped like [`Nominal::transition`]'s (or its transpose): the navigation states'
/// block (0..`GNSS`) dense, the GNSS error's block diagonal and coupled to nothing. About (15/18)³ of the
/// dense product's work, which the filter and the smoother do at every IMU sample.
pub(crate) fn sandwich(f: &ErrMat, m: &ErrMat) -> ErrMat {
    debug_assert!(f.fixed_view::<GNSS, 3>(0, GNSS).iter().all(|v| *v == 0.0));
    debug_assert!(f.fixed_view::<3, GNSS>(GNSS, 0).iter().all(|v| *v == 0.0));
    let a = f.fixed_view::<GNSS, GNSS>(0, 0);
    let d = [0, 1, 2].map(|i| f[(GNSS + i, GNSS + i)]);
    let mut out = ErrMat::zeros();
    out.fixed_view_mut::<GNSS, GNSS>(0, 0).copy_from(&(a * m.fixed_view::<GNSS, GNSS>(0, 0) * a.transpose()));
    let upper = a * m.fixed_view::<GNSS, 3>(0, GNSS);
    let lower = m.fixed_view::<3, GNSS>(GNSS, 0) * a.transpose();
    for j in 0..3 {
        for i in 0..GNSS {
            out[(i, GNSS + j)] = upper[(i, j)] * d[j];
            out[(GNSS + j, i)] = lower[(j, i)] * d[j];
        }
        for i in 0..3 {
            out[(GNSS + i, GNSS + j)] = d[i] * m[(GNSS + i, GNSS + j)] * d[j];
        }
    }
    out
}

/// One covariance prediction: F P Fᵀ + Q.
pub(crate) fn predict_cov(f: &ErrMat, p: &ErrMat, q: &ErrVec) -> ErrMat {
    let mut out = sandwich(f, p);
    for i in 0..N {
        out[(i, i)] += q[i];
    }
    out
}

/// Jacobian of (roll, pitch, heading) with respect to the map-frame attitude error φ (ENU).
pub(crate) fn euler_jacobian(attitude: &UnitQuaternion<f64>) -> Matrix3<f64> {
    let r = plumbline_geo::Rotation::<plumbline_geo::Map, plumbline_geo::Body>::from_quaternion(*attitude);
    let a = plumbline_geo::Attitude::from_rotation(&r);
    let (sp, cp) = a.pitch.sin_cos();
    let (sh, ch) = a.heading.sin_cos();
    // NED rates ω = E·(roll˙, pitch˙, heading˙) for R = Rz(h)·Ry(p)·Rx(r) (ARCHITECTURE.md, Angles).
    let e = Matrix3::new(ch * cp, -sh, 0.0, sh * cp, ch, 0.0, -sp, 0.0, 1.0);
    let enu_to_ned = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
    e.try_inverse().map_or(Matrix3::zeros(), |inv| inv * enu_to_ned)
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::{Attitude, Body, Map, Rotation};

    fn angles(q: &UnitQuaternion<f64>) -> Vector3<f64> {
        let a = Attitude::from_rotation(&Rotation::<Map, Body>::from_quaternion(*q));
        Vector3::new(a.roll, a.pitch, a.heading)
    }

    /// The Euler Jacobian agrees with finite differences of Exp(φ)·C through `Attitude::from_rotation`.
    #[test]
    fn euler_jacobian_matches_finite_differences() {
        for (r, p, h) in [(0.02, -0.05, 0.3), (-0.1, 0.2, 2.5), (0.3, 0.1, 4.0), (0.0, 0.0, 1.0)] {
            let q = *Attitude::new(r, p, h).to_rotation().quaternion();
            let j = euler_jacobian(&q);
            let eps = 1e-6;
            for axis in 0..3 {
                let mut phi = Vector3::zeros();
                phi[axis] = eps;
                let plus = angles(&(UnitQuaternion::from_scaled_axis(phi) * q));
                let minus = angles(&(UnitQuaternion::from_scaled_axis(-phi) * q));
                let fd = (plus - minus) / (2.0 * eps);
                let col = j.column(axis);
                assert!((fd - col).norm() < 1e-6, "attitude ({r}, {p}, {h}) axis {axis}: fd {fd:?} vs {col:?}");
            }
        }
    }

    /// One error-state step predicts how a small initial error propagates through the mechanisation.
    #[test]
    fn transition_matches_perturbed_mechanisation() {
        let nominal = Nominal {
            time: 0.0,
            position: Vector3::new(10.0, 20.0, 3.0),
            velocity: Vector3::new(8.0, -3.0, 0.1),
            attitude: *Attitude::new(0.03, -0.02, 1.2).to_rotation().quaternion(),
            accel_bias: Vector3::new(1e-3, -2e-3, 5e-4),
            gyro_bias: Vector3::new(1e-5, 2e-5, -1e-5),
            gnss_error: Vector3::new(0.1, -0.2, 0.3),
        };
        let s = ImuSample {
            time: 0.01,
            dt: 0.01,
            delta_theta: plumbline_geo::Vec3::new(0.001, -0.002, 0.004),
            delta_v: plumbline_geo::Vec3::new(0.02, 0.01, -0.098),
        };
        let earth = Earth::Flat { gravity: 9.8 };
        let f = nominal.transition(&s, 3600.0, 10.0, &earth);
        let base = nominal.propagate(&s, &earth);
        let dx = ErrVec::from_fn(|i, _| {
            [
                1e-3, -2e-3, 1e-3, 1e-3, 2e-3, -1e-3, 1e-4, -2e-4, 3e-4, 1e-3, 2e-3, -1e-3, 1e-4, 2e-4, 1e-4, 0.1, 0.1,
                0.1,
            ][i]
        });
        let moved = nominal.inject(&dx).propagate(&s, &earth);
        let predicted = f * dx;
        // The GNSS error block decays with its own correlation time (the filter decays the nominal value alike).
        let decay = (-s.dt / 10.0f64).exp();
        assert!((predicted.fixed_rows::<3>(GNSS) - Vector3::repeat(0.1 * decay)).norm() < 1e-12);
        let err =
            |o: usize, got: Vector3<f64>| (got - Vector3::new(predicted[o], predicted[o + 1], predicted[o + 2])).norm();
        assert!(err(POS, moved.position - base.position) < 1e-6);
        assert!(err(VEL, moved.velocity - base.velocity) < 1e-6);
        let dphi = (moved.attitude * base.attitude.inverse()).scaled_axis();
        assert!(err(ATT, dphi) < 1e-7, "attitude {dphi:?} vs {:?}", predicted.fixed_rows::<3>(ATT));
    }

    /// The block product equals the dense one for a transition and its transpose.
    #[test]
    fn sandwich_matches_the_dense_product() {
        let nominal = Nominal {
            time: 0.0,
            position: Vector3::new(1.0, 2.0, 3.0),
            velocity: Vector3::new(8.0, -3.0, 0.1),
            attitude: *Attitude::new(0.03, -0.02, 1.2).to_rotation().quaternion(),
            accel_bias: Vector3::zeros(),
            gyro_bias: Vector3::zeros(),
            gnss_error: Vector3::zeros(),
        };
        let s = ImuSample {
            time: 0.01,
            dt: 0.01,
            delta_theta: plumbline_geo::Vec3::new(0.001, -0.002, 0.004),
            delta_v: plumbline_geo::Vec3::new(0.02, 0.01, -0.098),
        };
        let f = nominal.transition(&s, 3600.0, 5.0, &Earth::Flat { gravity: 9.8 });
        let m = ErrMat::from_fn(|i, j| 1.0 / (1.0 + (i + 2 * j) as f64) + if i == j { 2.0 } else { 0.0 });
        assert!((sandwich(&f, &m) - f * m * f.transpose()).norm() < 1e-12);
        let ft = f.transpose();
        assert!((sandwich(&ft, &m) - ft * m * f).norm() < 1e-12);
    }

    /// An IMU at rest on the rotating Earth (gyros sensing Earth rate, accelerometers normal gravity) stays
    /// at rest through 100 s of WGS 84 mechanisation; the flat model, blind to Earth rate, tilts and runs off.
    #[test]
    fn a_unit_at_rest_on_the_rotating_earth_stays_at_rest() {
        let earth = Earth::Wgs84 { latitude: 49f64.to_radians(), convergence: 0.0 };
        let attitude = *Attitude::new(0.01, -0.02, 0.5).to_rotation().quaternion();
        let start = Nominal {
            time: 0.0,
            position: Vector3::new(0.0, 0.0, 120.0),
            velocity: Vector3::zeros(),
            attitude,
            accel_bias: Vector3::zeros(),
            gyro_bias: Vector3::zeros(),
            gnss_error: Vector3::zeros(),
        };
        let dt = 0.01;
        let rate = attitude.inverse() * earth.earth_rate();
        let force = attitude.inverse() * Vector3::new(0.0, 0.0, earth.gravity(120.0));
        let sample = |k: usize| ImuSample {
            time: (k + 1) as f64 * dt,
            dt,
            delta_theta: plumbline_geo::Vec3::from_vector(rate * dt),
            delta_v: plumbline_geo::Vec3::from_vector(force * dt),
        };
        let run = |earth: &Earth| (0..10_000).fold(start, |state, k| state.propagate(&sample(k), earth));
        let wgs = run(&earth);
        assert!(wgs.velocity.norm() < 1e-4, "velocity {:?}", wgs.velocity);
        assert!((wgs.position - start.position).norm() < 5e-3, "moved {:?}", wgs.position - start.position);
        assert!(wgs.attitude.angle_to(&attitude) < 1e-7, "turned {}", wgs.attitude.angle_to(&attitude));
        let flat = run(&Earth::Flat { gravity: earth.gravity(120.0) });
        assert!(flat.velocity.norm() > 1.0, "the flat model ignores Earth rate: {:?}", flat.velocity);
    }
}
