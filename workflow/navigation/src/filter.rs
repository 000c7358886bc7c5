//! The forward pass: strapdown prediction at the IMU rate, closed-loop GNSS position updates with the lever
//! arm (Cazzaniga et al. 2007 §2.1 prediction and update), and everything the RTS smoother needs.

use std::ops::AddAssign as _;

use nalgebra::{Matrix2, Matrix3, SMatrix, Vector2, Vector3};
use plumbline_geo::Rotation;

use crate::adaptive::{Decision, Monitor, reopen};
use crate::config::{InitialState, NavConfig, VehicleConstraint};
use crate::gaps::{GapNoise, ImuGap};
use crate::inputs::{GnssFix, ImuSample};
use crate::state::{ATT, BA, BG, GNSS, N, POS, VEL};
use crate::state::{ErrMat, ErrVec, Nominal, predict_cov, process_noise, skew};
use crate::{NavError, check_fix};

/// Smallest initial bias σ, so that the covariance stays invertible for a perfect IMU model.
const MIN_BIAS_STD: f64 = 1e-12;

/// One GNSS innovation (predicted residual, Cazzaniga et al. 2007 §3.1) with its covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Innovation {
    /// Time of the fix, s.
    pub time: f64,
    /// Index of the fix in the input.
    pub fix: usize,
    /// Fix − predicted antenna position: east, north, up, m.
    pub residual: Vector3<f64>,
    /// C_v = C_y + A·C_{k|k−1}·Aᵀ (Cazzaniga et al. 2007 §3.1; the predicted covariance, as the innovation's
    /// definition requires — the paper's C_{k|k} is a typo).
    pub covariance: Matrix3<f64>,
    /// What the filter did with the fix ([`Decision::Used`] always for [`filter`](crate::filter())).
    pub decision: Decision,
}

impl Innovation {
    /// vᵀC_v⁻¹v: χ² with 3 degrees of freedom when the model holds (NaN when C_v cannot be inverted).
    pub fn statistic(&self) -> f64 {
        self.covariance.try_inverse().map_or(f64::NAN, |inv| self.residual.dot(&(inv * self.residual)))
    }
}

/// A GNSS fix the filter did not use, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct SkippedFix {
    /// Index of the fix in the input.
    pub fix: usize,
    /// What is wrong with it.
    pub reason: NavError,
}

/// Covariances around an update epoch: the RTS smoother's checkpoints.
#[derive(Clone, Debug)]
pub(crate) struct Checkpoint {
    pub epoch: usize,
    /// C_{k|k−1}.
    pub prior: ErrMat,
    /// C_{k|k}.
    pub posterior: ErrMat,
    /// The error-state estimate injected at this epoch (zero where nothing was observed).
    pub update: ErrVec,
    /// The part of `prior`'s position block that re-opening added: the smoother spreads it as a position
    /// random walk over the interval from the previous checkpoint (zero where nothing was re-opened; see
    /// [`spread_back`] for re-openings after vehicle-constraint checkpoints).
    pub spread: Matrix3<f64>,
    /// Whether a GNSS fix was used here, not excluded (the initial state counts as one).
    pub fix: bool,
}

/// The result of the forward pass.
#[derive(Clone, Debug)]
pub struct ForwardPass {
    pub(crate) config: NavConfig,
    pub(crate) samples: Vec<ImuSample>,
    /// Epoch 0 is the initial state, epoch i + 1 follows sample i (after any update).
    pub(crate) nominal: Vec<Nominal>,
    pub(crate) position_cov: Vec<Matrix3<f64>>,
    pub(crate) checkpoints: Vec<Checkpoint>,
    /// The innovations of every used fix, in time order.
    pub innovations: Vec<Innovation>,
    /// Fixes not used (invalid, or outside the IMU's time span).
    pub skipped: Vec<SkippedFix>,
    /// The IMU's unrecorded stretches and the noise they add.
    pub(crate) gap_noise: GapNoise,
}

impl ForwardPass {
    /// The IMU's unrecorded stretches the filter found (none when `NavConfig::gaps` is `None`).
    pub fn imu_gaps(&self) -> &[ImuGap] {
        self.gap_noise.gaps()
    }

    /// Process noise of sample `k`: the IMU model's, plus a gap's where sample `k` lies in one.
    pub(crate) fn noise(&self, k: usize) -> ErrVec {
        noise_of(&self.config, &self.gap_noise, k, &self.samples[k])
    }
}

fn noise_of(config: &NavConfig, gaps: &GapNoise, k: usize, s: &ImuSample) -> ErrVec {
    let q = process_noise(&config.imu, &config.gnss_error_model(), s.dt);
    gaps.at(k, s.dt).map_or(q, |extra| q + extra)
}

/// One forward pass; `corrections` (sample index, error state) shift the nominal state after those samples.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_once(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    initial: &InitialState,
    config: &NavConfig,
    monitor: Option<Monitor>,
    excluded: &[bool],
    gaps: GapNoise,
    corrections: &[(usize, ErrVec)],
) -> ForwardPass {
    let mut run = Run::new(imu, initial, config, monitor);
    run.excluded = excluded;
    run.out.gap_noise = gaps;
    run.updates_at(gnss, imu.first().map_or(0.0, |s| s.dt) * 0.5, None);
    let mut next = corrections.iter().peekable();
    for (k, s) in imu.iter().enumerate() {
        run.predict(k, s);
        if let Some((_, dx)) = next.next_if(|(at, _)| *at == k) {
            run.pending = Some(*dx);
        }
        run.updates_at(gnss, s.dt * 0.5, Some(s));
    }
    run.finish(gnss.len())
}

/// The running filter.
struct Run<'a> {
    config: &'a NavConfig,
    imu: &'a [ImuSample],
    state: Nominal,
    p: ErrMat,
    next_fix: usize,
    /// Time of the next vehicle-constraint update, s.
    next_constraint: f64,
    monitor: Option<Monitor>,
    /// Fixes decided out before the run (by index).
    excluded: &'a [bool],
    /// A re-linearisation shift to inject at the next epoch.
    pending: Option<ErrVec>,
    out: ForwardPass,
}

impl<'a> Run<'a> {
    fn new(imu: &'a [ImuSample], init: &InitialState, config: &'a NavConfig, monitor: Option<Monitor>) -> Self {
        let attitude = *init.attitude.to_rotation().quaternion();
        let state = Nominal {
            time: init.time,
            position: init.position.p,
            velocity: init.velocity.v,
            attitude,
            accel_bias: Vector3::zeros(),
            gyro_bias: Vector3::zeros(),
            gnss_error: Vector3::zeros(),
        };
        let p = initial_covariance(init, config);
        let mut nominal = Vec::with_capacity(imu.len() + 1);
        nominal.push(state);
        let out = ForwardPass {
            config: *config,
            samples: imu.to_vec(),
            nominal,
            position_cov: vec![p.fixed_view::<3, 3>(POS, POS).into_owned()],
            checkpoints: vec![Checkpoint {
                epoch: 0,
                prior: p,
                posterior: p,
                update: ErrVec::zeros(),
                spread: Matrix3::zeros(),
                fix: true,
            }],
            innovations: Vec::new(),
            skipped: Vec::new(),
            gap_noise: GapNoise::default(),
        };
        let next_constraint = init.time + config.vehicle.map_or(f64::INFINITY, |v| v.interval);
        Self { config, imu, state, p, next_fix: 0, next_constraint, monitor, excluded: &[], pending: None, out }
    }

    /// Prediction (Cazzaniga et al. 2007 §2.1): mechanise the nominal state, propagate the error covariance.
    fn predict(&mut self, k: usize, s: &ImuSample) {
        let gnss_tau = self.config.gnss_error_model().correlation_time;
        let f = self.state.transition(s, self.config.imu.bias_correlation_time, gnss_tau, &self.config.earth);
        self.p = predict_cov(&f, &self.p, &noise_of(self.config, &self.out.gap_noise, k, s));
        self.state = self.state.propagate(s, &self.config.earth);
        // The GNSS error's expected value decays as the Gauss–Markov process does.
        self.state.gnss_error *= (-s.dt / gnss_tau).exp();
        self.out.nominal.push(self.state);
        self.out.position_cov.push(self.p.fixed_view::<3, 3>(POS, POS).into_owned());
    }

    /// Apply the vehicle constraint when it is due after `sample`, then every fix within `half` seconds of
    /// the current epoch.
    fn updates_at(&mut self, gnss: &[GnssFix], half: f64, sample: Option<&ImuSample>) {
        let epoch = self.out.nominal.len() - 1;
        let mut prior = self.p;
        let mut update = ErrVec::zeros();
        let mut spread = Matrix3::zeros();
        let mut fix = false;
        if let Some(dx) = self.pending.take() {
            // A known shift of the linearisation point: the smoother carries it back like an update.
            self.state = self.state.inject(&dx);
            update += dx;
        }
        if let (Some(vehicle), Some(s)) = (self.config.vehicle, sample)
            && self.state.time >= self.next_constraint - half
        {
            self.next_constraint = self.state.time + vehicle.interval;
            update += self.constrain(&vehicle, s);
        }
        // A fix belongs to the epoch nearest it; one the previous epoch's window (half of a shorter interval)
        // left out still lies in this interval. Only a fix before it is out of place.
        let earliest = sample.map_or(self.state.time - half, |s| self.state.time - s.dt - half);
        while let Some(f) = gnss.get(self.next_fix).filter(|f| f.time <= self.state.time + half) {
            let index = self.next_fix;
            self.next_fix += 1;
            if let Err(reason) = check_fix(index, f) {
                self.out.skipped.push(SkippedFix { fix: index, reason });
            } else if f.time < earliest {
                let reason = NavError::FixOutsideImu { index, time: f.time };
                self.out.skipped.push(SkippedFix { fix: index, reason });
            } else {
                let (dx, reopened) = self.update(index, f);
                fix |= self.out.innovations.last().is_some_and(|i| i.decision != Decision::Excluded);
                update += dx;
                // Re-opening is process noise added at this epoch: the smoother's C_{k|k−1} includes it.
                prior += reopened;
                spread += reopened.fixed_view::<3, 3>(POS, POS);
            }
        }
        if update != ErrVec::zeros() {
            self.out.position_cov[epoch] = self.p.fixed_view::<3, 3>(POS, POS).into_owned();
            *self.out.nominal.last_mut().expect("the initial epoch is always present") = self.state;
            self.out.checkpoints.push(Checkpoint { epoch, prior, posterior: self.p, update, spread, fix });
        }
    }

    /// Update (Cazzaniga et al. 2007 §2.1) with one antenna position; returns the injected error-state estimate and the
    /// covariance the adaptive filter added before the update.
    fn update(&mut self, index: usize, fix: &GnssFix) -> (ErrVec, ErrMat) {
        let c = self.state.attitude.to_rotation_matrix().into_inner();
        let arm = c * self.config.lever_arm.v;
        let predicted =
            self.state.position + self.state.velocity * (fix.time - self.state.time) + arm + self.state.gnss_error;
        let residual = fix.position.p - predicted;
        let mut h = SMatrix::<f64, 3, N>::zeros();
        h.fixed_view_mut::<3, 3>(0, POS).copy_from(&Matrix3::identity());
        h.fixed_view_mut::<3, 3>(0, GNSS).copy_from(&Matrix3::identity());
        // Antenna = p + Exp(φ)·C·l ≈ p + C·l − (C·l)×φ.
        h.fixed_view_mut::<3, 3>(0, ATT).copy_from(&(-skew(&arm)));
        let r = Matrix3::from_diagonal(&Vector3::from(fix.std.map(|s| s * s)));
        let s = h * self.p * h.transpose() + r;
        let before = self.p;
        let decision = match &mut self.monitor {
            _ if self.excluded.get(index).copied().unwrap_or(false) => Decision::Excluded,
            None => Decision::Used,
            Some(m) => {
                let age = m.episode_age(fix.time);
                let d = m.decide(fix.time, &residual, &s);
                reopen(&mut self.p, d, &self.config.imu, &residual, age, m.reopen_scale());
                d
            }
        };
        self.out.innovations.push(Innovation { time: fix.time, fix: index, residual, covariance: s, decision });
        let reopened = self.p - before;
        if decision == Decision::Excluded {
            return (ErrVec::zeros(), reopened);
        }
        (self.correct(&h, &r, &residual), reopened)
    }

    /// The Kalman update with observation matrix `h`, noise `r` and innovation `residual`: the gain, the
    /// Joseph-form covariance (symmetric and positive definite) and the closed-loop injection; returns the
    /// injected error state (zero when the innovation covariance cannot be inverted).
    fn correct<const M: usize>(
        &mut self,
        h: &SMatrix<f64, M, N>,
        r: &SMatrix<f64, M, M>,
        residual: &SMatrix<f64, M, 1>,
    ) -> ErrVec {
        let ph = self.p * h.transpose();
        let Some(s_inv) = (h * ph + r).try_inverse() else {
            return ErrVec::zeros();
        };
        let k = ph * s_inv;
        let dx = k * residual;
        let ikh = ErrMat::identity() - k * h;
        self.p = ikh * self.p * ikh.transpose() + k * r * k.transpose();
        self.state = self.state.inject(&dx);
        dx
    }

    /// The vehicle constraint (see [`VehicleConstraint`]): the vehicle's lateral and vertical velocity
    /// observed as zero. With C = R_B^M and C_true = Exp(φ)·C, v_body = Cᵀ(v + δv) + Cᵀ[v]×φ to first order.
    fn constrain(&mut self, vehicle: &VehicleConstraint, s: &ImuSample) -> ErrVec {
        // Map to the vehicle's axes (the IMU's, turned by its mounting).
        let ct = vehicle.mounting.to_vehicle() * self.state.attitude.to_rotation_matrix().into_inner().transpose();
        let body = ct * self.state.velocity;
        let turning = ct * skew(&self.state.velocity);
        let mut h = SMatrix::<f64, 2, N>::zeros();
        for (row, axis) in [(0, 1), (1, 2)] {
            for j in 0..3 {
                h[(row, VEL + j)] = ct[(axis, j)];
                h[(row, ATT + j)] = turning[(axis, j)];
            }
        }
        let rate = (s.delta_theta.v - self.state.gyro_bias * s.dt) / s.dt;
        let lateral = vehicle.velocity_std + rate.z.abs() * vehicle.arm;
        let vertical = vehicle.velocity_std + rate.y.abs() * vehicle.arm;
        let r = Matrix2::new(lateral * lateral, 0.0, 0.0, vertical * vertical);
        let residual = -Vector2::new(body.y, body.z);
        self.correct(&h, &r, &residual)
    }

    fn finish(mut self, total_fixes: usize) -> ForwardPass {
        for index in self.next_fix..total_fixes {
            let time = self.imu.last().map_or(self.state.time, |s| s.time);
            self.out.skipped.push(SkippedFix { fix: index, reason: NavError::FixOutsideImu { index, time } });
        }
        let epoch = self.out.nominal.len() - 1;
        if self.out.checkpoints.last().is_none_or(|c| c.epoch != epoch) {
            let (prior, posterior, update, spread) = (self.p, self.p, ErrVec::zeros(), Matrix3::zeros());
            self.out.checkpoints.push(Checkpoint { epoch, prior, posterior, update, spread, fix: false });
        }
        let nominal = &self.out.nominal;
        spread_back(&mut self.out.checkpoints, |epoch| nominal[epoch].time);
        self.out
    }
}

/// A re-opening at a fix spreads its position variance over the time since the previous fix, not just since
/// the previous checkpoint (a vehicle-constraint update may lie a tenth of a second before it): each
/// checkpoint in between gets the share of the variance that a random walk would have reached by its time,
/// in its prior and posterior alike, and the share of its own interval as its `spread`. This is exact: the
/// constraint does not observe position, and position variance passes through the transition unchanged, so
/// added position variance survives both untouched — the smoother then sees one consistent random walk.
fn spread_back(checkpoints: &mut [Checkpoint], time: impl Fn(usize) -> f64) {
    let mut last_fix = 0;
    for j in 1..checkpoints.len() {
        if checkpoints[j].spread != Matrix3::zeros() && j > last_fix + 1 {
            let total = checkpoints[j].spread;
            let start = time(checkpoints[last_fix].epoch);
            let span = time(checkpoints[j].epoch) - start;
            let mut reached = 0.0;
            for c in &mut checkpoints[last_fix + 1..j] {
                let share = if span > 0.0 { (time(c.epoch) - start) / span } else { 0.0 };
                let added = total * share;
                c.prior.fixed_view_mut::<3, 3>(POS, POS).add_assign(&added);
                c.posterior.fixed_view_mut::<3, 3>(POS, POS).add_assign(&added);
                c.spread = total * (share - reached);
                reached = share;
            }
            checkpoints[j].spread = total * (1.0 - reached);
        }
        if checkpoints[j].fix {
            last_fix = j;
        }
    }
}

/// C_0 from the initial σ and the IMU's turn-on biases.
fn initial_covariance(init: &InitialState, config: &NavConfig) -> ErrMat {
    let mut d = ErrVec::zeros();
    for a in 0..3 {
        d[POS + a] = init.position_std.powi(2);
        d[VEL + a] = init.velocity_std.powi(2);
        d[ATT + a] = init.attitude_std[a].powi(2);
        d[BA + a] = config.imu.accel_bias.max(MIN_BIAS_STD).powi(2);
        d[BG + a] = config.imu.gyro_bias.max(MIN_BIAS_STD).powi(2);
        d[GNSS + a] = config.gnss_error_model().std[a].powi(2);
    }
    ErrMat::from_diagonal(&d)
}

impl ForwardPass {
    /// The filtered (forward) state at every epoch: time, body origin, attitude, position covariance.
    pub fn filtered(&self) -> impl Iterator<Item = FilteredEpoch> + '_ {
        self.nominal.iter().zip(&self.position_cov).map(|(n, cov)| FilteredEpoch {
            time: n.time,
            position: plumbline_geo::Point3::from_vector(n.position),
            attitude: Rotation::from_quaternion(n.attitude),
            position_cov: *cov,
        })
    }

    /// Number of epochs (IMU samples + 1).
    pub fn len(&self) -> usize {
        self.nominal.len()
    }

    /// Always false: the initial epoch is always present.
    pub fn is_empty(&self) -> bool {
        self.nominal.is_empty()
    }

    /// The estimated accelerometer and gyro biases at the last epoch (body frame; m/s², rad/s).
    pub fn final_biases(&self) -> (Vector3<f64>, Vector3<f64>) {
        self.nominal.last().map_or((Vector3::zeros(), Vector3::zeros()), |n| (n.accel_bias, n.gyro_bias))
    }
}

/// One epoch of the forward (filtered) solution.
#[derive(Clone, Copy, Debug)]
pub struct FilteredEpoch {
    /// Time, s.
    pub time: f64,
    /// Body origin, m.
    pub position: plumbline_geo::Point3<plumbline_geo::Map>,
    /// R_B^M.
    pub attitude: Rotation<plumbline_geo::Map, plumbline_geo::Body>,
    /// C_{k|k} of the position, m².
    pub position_cov: Matrix3<f64>,
}
