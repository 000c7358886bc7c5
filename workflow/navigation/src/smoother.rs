//! The Rauch–Tung–Striebel smoother over the forward pass (Cazzaniga et al. 2007 §2.1, smoothing equations).
//!
//! The forward pass keeps the covariances only at update epochs. Between two of them (j, j+1) no fix was
//! used, so the gain chain B_k···B_j collapses: x̂_{k|T} = x̂_{k|k} + C_{k|k}·Φ_{j+1,k}ᵀ·C_{j+1|j}⁻¹·(x̂_{j+1|T} −
//! x̂_{j+1|j}) and C_{k|T} = C_{k|k} + C_{k|k}·Φᵀ·C_{j+1|j}⁻¹·(C_{j+1|T} − C_{j+1|j})·C_{j+1|j}⁻¹·Φ·C_{k|k},
//! the paper's recursion applied step by step. The interval's C_{k|k} are re-propagated from C_{j|j}, and
//! Φᵀ(·) is accumulated backwards (λ_k = F_kᵀ λ_{k+1}, Λ_k = F_kᵀ Λ_{k+1} F_k). The filter runs closed loop,
//! so x̂_{k|k} = 0 around the nominal state and x̂_{j+1|T} − x̂_{j+1|j} is the smoothed error plus the update
//! the filter injected at j+1.

use nalgebra::{Cholesky, Matrix3, U18, UnitQuaternion, Vector3};
use plumbline_geo::{Attitude, Map, Point3, PoseStd, Rotation, Trajectory, TrajectoryRecord, ValidationLimits, Vec3};

use crate::NavError;
use crate::filter::ForwardPass;
use crate::state::{ATT, ErrMat, ErrVec, POS, VEL, euler_jacobian, predict_cov, sandwich};

/// One smoothed epoch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothedEpoch {
    /// Time, s.
    pub time: f64,
    /// Body origin, m.
    pub position: Point3<Map>,
    /// Velocity, m/s.
    pub velocity: Vec3<Map>,
    /// Attitude (Applanix convention).
    pub attitude: Attitude,
    /// C_{k|T} of the position, m².
    pub position_cov: Matrix3<f64>,
    /// σ of roll, pitch, heading, rad.
    pub attitude_std: [f64; 3],
}

/// Run the RTS smoother backwards over `forward`; one smoothed epoch per forward epoch.
pub fn smooth(forward: &ForwardPass) -> Result<Vec<SmoothedEpoch>, NavError> {
    let mut out = vec![None; forward.nominal.len()];
    smooth_errors(forward, |k, s, p| out[k] = Some(epoch(forward, k, s, p)))?;
    Ok(out.into_iter().flatten().collect())
}

/// The smoother's recursion, handing each epoch's smoothed error state and covariance (around the forward
/// pass's nominal state) to `visit`, from the last epoch back to the first.
pub(crate) fn smooth_errors(
    forward: &ForwardPass,
    mut visit: impl FnMut(usize, &ErrVec, &ErrMat),
) -> Result<(), NavError> {
    let cps = &forward.checkpoints;
    let last = cps.last().ok_or(NavError::Empty)?;
    let mut s_next = ErrVec::zeros();
    let mut p_next = last.posterior;
    visit(last.epoch, &s_next, &p_next);
    for c in (0..cps.len().saturating_sub(1)).rev() {
        let (cp, nx) = (&cps[c], &cps[c + 1]);
        let chol = ScaledCholesky::new(&nx.prior).ok_or(NavError::Singular { time: forward.nominal[nx.epoch].time })?;
        let lambda = chol.solve_vec(&(s_next + nx.update));
        let x = chol.solve_mat(&(p_next - nx.prior));
        let big_lambda = chol.solve_mat(&x.transpose());
        let gains = Gains { lambda, big_lambda, spread: nx.spread };
        let (s, p) = interval(forward, cp.epoch, nx.epoch, &cp.posterior, gains, &mut visit);
        s_next = s;
        p_next = p;
    }
    Ok(())
}

/// What the next checkpoint hands back to an interval: λ and Λ there, and the re-opened position variance to
/// spread over the interval.
struct Gains {
    lambda: ErrVec,
    big_lambda: ErrMat,
    spread: Matrix3<f64>,
}

/// Smooth epochs `from..to` (exclusive of `to`); returns the smoothed error and covariance at `from`.
///
/// A re-initialisation re-opened the position at `to`: a fault the filter only noticed there (Cazzaniga et al. 2007
/// §3.2 places it at the start of the window). Its position variance is spread as a position random walk
/// over the interval, in proportion to each step's dt — the same C_{to|to−1} (position noise passes through
/// the transition unchanged), but the smoothed trajectory bends over the interval instead of stepping.
fn interval(
    fw: &ForwardPass,
    from: usize,
    to: usize,
    p_from: &ErrMat,
    gains: Gains,
    visit: &mut impl FnMut(usize, &ErrVec, &ErrMat),
) -> (ErrVec, ErrMat) {
    let tau = fw.config.imu.bias_correlation_time;
    let gnss_tau = fw.config.gnss_error_model().correlation_time;
    let span: f64 = fw.samples[from..to].iter().map(|s| s.dt).sum();
    let Gains { mut lambda, mut big_lambda, spread } = gains;
    let mut steps = Vec::with_capacity(to - from);
    let mut p = *p_from;
    for k in from..to {
        let sample = &fw.samples[k];
        let f = fw.nominal[k].transition(sample, tau, gnss_tau, &fw.config.earth);
        steps.push((f, p));
        p = predict_cov(&f, &p, &fw.noise(k));
        if span > 0.0 {
            let mut block = p.fixed_view_mut::<3, 3>(POS, POS);
            block += spread * (sample.dt / span);
        }
    }
    let mut result = (ErrVec::zeros(), *p_from);
    for (i, (f, p)) in steps.iter().enumerate().rev() {
        lambda = f.transpose() * lambda;
        big_lambda = sandwich(&f.transpose(), &big_lambda);
        // Cazzaniga et al. 2007 §2.1: x̂_{k|T} = x̂_{k|k} + B_k(…), C_{k|T} = C_{k|k} + B_k(C_{k+1|T} − C_{k+1|k})B_kᵀ
        let s = p * lambda;
        let ps = p + p * big_lambda * p;
        visit(from + i, &s, &ps);
        result = (s, ps);
    }
    result
}

/// The smoothed epoch: nominal state ⊕ smoothed error, with σ from the smoothed covariance.
fn epoch(fw: &ForwardPass, k: usize, s: &ErrVec, p: &ErrMat) -> SmoothedEpoch {
    let n = &fw.nominal[k];
    let block = |o: usize| Vector3::new(s[o], s[o + 1], s[o + 2]);
    let attitude = UnitQuaternion::from_scaled_axis(block(ATT)) * n.attitude;
    let j = euler_jacobian(&attitude);
    let att_cov = j * p.fixed_view::<3, 3>(ATT, ATT) * j.transpose();
    SmoothedEpoch {
        time: n.time,
        position: Point3::from_vector(n.position + block(POS)),
        velocity: Vec3::from_vector(n.velocity + block(VEL)),
        attitude: Attitude::from_rotation(&Rotation::from_quaternion(attitude)),
        position_cov: p.fixed_view::<3, 3>(POS, POS).into_owned(),
        attitude_std: [0, 1, 2].map(|i| att_cov[(i, i)].max(0.0).sqrt()),
    }
}

/// The smoothed epochs as a trajectory with σ.
pub fn to_trajectory(epochs: &[SmoothedEpoch]) -> Result<Trajectory, NavError> {
    let records = epochs
        .iter()
        .map(|e| TrajectoryRecord {
            time: e.time,
            position: e.position,
            attitude: e.attitude,
            std: Some(PoseStd {
                east: e.position_cov[(0, 0)].max(0.0).sqrt(),
                north: e.position_cov[(1, 1)].max(0.0).sqrt(),
                height: e.position_cov[(2, 2)].max(0.0).sqrt(),
                roll: e.attitude_std[0],
                pitch: e.attitude_std[1],
                heading: e.attitude_std[2],
            }),
        })
        .collect();
    Ok(Trajectory::new(records, &ValidationLimits::default())?)
}

/// Cholesky of D·C·D with D = diag(C)^−½: the states' variances span many orders of magnitude.
struct ScaledCholesky {
    chol: Cholesky<f64, U18>,
    scale: ErrVec,
}

impl ScaledCholesky {
    fn new(c: &ErrMat) -> Option<Self> {
        let scale = ErrVec::from_fn(|i, _| 1.0 / c[(i, i)].sqrt());
        if !scale.iter().all(|s| s.is_finite()) {
            return None;
        }
        let scaled = ErrMat::from_fn(|i, j| c[(i, j)] * scale[i] * scale[j]);
        Some(Self { chol: Cholesky::new(scaled)?, scale })
    }

    fn solve_vec(&self, b: &ErrVec) -> ErrVec {
        self.chol.solve(&b.component_mul(&self.scale)).component_mul(&self.scale)
    }

    fn solve_mat(&self, b: &ErrMat) -> ErrMat {
        let d = ErrMat::from_diagonal(&self.scale);
        d * self.chol.solve(&(d * b))
    }
}
