//! Applying the node corrections to a full-rate trajectory: linear interpolation of [δp; δθ] between
//! nodes (constant beyond the ends) and of their covariance (with the cross-covariance of the two nodes
//! and the random walk's spread in between), holding the pose over accepted standstills.

use nalgebra::{Matrix3, Matrix6, Rotation3, Vector6};
use plumbline_geo::trajectory::PositionInterpolation;
use plumbline_geo::{Attitude, PoseStd, Rotation, Trajectory, TrajectoryError, TrajectoryRecord, ValidationLimits};

use crate::adjust::Adjustment;
use crate::so3::exp;

/// The pose a fraction `w` of the way from `start` to `end` (position linear, attitude along the geodesic),
/// with the standard deviations of `record`.
fn at_rest(record: &TrajectoryRecord, w: f64, start: &TrajectoryRecord, end: &TrajectoryRecord) -> TrajectoryRecord {
    let (ra, rb) = (start.attitude.to_rotation().matrix(), end.attitude.to_rotation().matrix());
    let turn = Rotation3::from_matrix_unchecked(rb * ra.transpose()).scaled_axis();
    let attitude = Attitude::from_rotation(&Rotation::from_matrix(&(exp(&(turn * w)) * ra)));
    let position = start.position + (end.position - start.position) * w;
    TrajectoryRecord { position, attitude, ..*record }
}

impl Adjustment {
    /// The interpolated correction [δp; δθ] at `t` and its covariance; `None` without nodes.
    pub fn correction_at(&self, t: f64) -> Option<(Vector6<f64>, Matrix6<f64>)> {
        let first = self.nodes.first()?;
        let upper = self.nodes.partition_point(|n| n.time <= t);
        let vec = |k: usize| {
            let n = &self.nodes[k];
            Vector6::new(n.position[0], n.position[1], n.position[2], n.rotation[0], n.rotation[1], n.rotation[2])
        };
        if upper == 0 {
            return Some((vec(0), first.covariance));
        }
        let k = upper - 1;
        if k + 1 >= self.nodes.len() {
            return Some((vec(k), self.nodes[k].covariance));
        }
        let (a, b) = (&self.nodes[k], &self.nodes[k + 1]);
        let w = (t - a.time) / (b.time - a.time);
        let cross = self.cross_covariances[k];
        // Var((1−w) a + w b) = (1−w)² Q_aa + w² Q_bb + w(1−w)(Q_ab + Q_ba), plus the random walk's own
        // spread between two fixed ends (Brownian bridge): σ_rel² · w(1−w).
        let bridge = Matrix6::from_diagonal(&self.link_variances[k]) * (w * (1.0 - w));
        let cov = a.covariance * (1.0 - w).powi(2)
            + b.covariance * w * w
            + (cross + cross.transpose()) * (w * (1.0 - w))
            + bridge;
        Some((vec(k) * (1.0 - w) + vec(k + 1) * w, cov))
    }

    /// The corrected trajectory: p' = p + δp, R' = Exp(δθ) R at every record, with the posterior standard
    /// deviations (attitude σ: roll/pitch from the body-frame tilt covariance, heading from the vertical).
    /// Inside an accepted standstill the vehicle is at rest: the pose is the corrected pose at its start,
    /// moved linearly (position; attitude along the geodesic) to the corrected pose at its end — equal to it
    /// within the constraint's σ — so the DG's motion inside (a jump) does not reach the result.
    pub fn apply(&self, trajectory: &Trajectory) -> Result<Trajectory, TrajectoryError> {
        let held: Vec<(f64, f64, TrajectoryRecord, TrajectoryRecord)> = self
            .standstills
            .iter()
            .filter(|s| s.accepted())
            .filter_map(|s| {
                let at = |t| trajectory.interpolate(t, PositionInterpolation::Linear).ok().map(|r| self.correct(&r));
                Some((s.standstill.start, s.standstill.end, at(s.standstill.start)?, at(s.standstill.end)?))
            })
            .collect();
        let records = trajectory
            .records()
            .iter()
            .map(|r| {
                let corrected = self.correct(r);
                // Sorted, disjoint intervals: the last one starting before r.time is the only candidate.
                let k = held.partition_point(|(a, _, _, _)| *a < r.time);
                match k.checked_sub(1).map(|k| &held[k]).filter(|(_, b, _, _)| r.time < *b) {
                    Some((a, b, start, end)) => at_rest(&corrected, (r.time - a) / (b - a), start, end),
                    None => corrected,
                }
            })
            .collect();
        Trajectory::new(records, &ValidationLimits { max_speed: f64::INFINITY })
    }

    fn correct(&self, r: &TrajectoryRecord) -> TrajectoryRecord {
        let Some((d, cov)) = self.correction_at(r.time) else {
            return *r;
        };
        let rot = r.attitude.to_rotation().matrix();
        let corrected = exp(&d.fixed_rows::<3>(3).into_owned()) * rot;
        let position = r.position + plumbline_geo::Vec3::from_vector(d.fixed_rows::<3>(0).into_owned());
        let attitude = Attitude::from_rotation(&Rotation::from_matrix(&corrected));
        let q_theta: Matrix3<f64> = cov.fixed_view::<3, 3>(3, 3).into_owned();
        let q_body = rot.transpose() * q_theta * rot;
        let sd = |v: f64| v.max(0.0).sqrt();
        let std = PoseStd {
            east: sd(cov[(0, 0)]),
            north: sd(cov[(1, 1)]),
            height: sd(cov[(2, 2)]),
            roll: sd(q_body[(0, 0)]),
            pitch: sd(q_body[(1, 1)]),
            heading: sd(q_theta[(2, 2)]),
        };
        TrajectoryRecord { time: r.time, position, attitude, std: Some(std) }
    }
}
