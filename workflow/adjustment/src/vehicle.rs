//! The DG's motion in the vehicle's own frame: along its heading, across it (to the right) and up, sampled
//! finely. A road vehicle moves along its heading (the non-holonomic constraint of the land-vehicle motion model of
//! Cazzaniga et al. 2007 §2: no sideways velocity) — up to a constant crab angle when the IMU's heading is
//! misaligned with the direction of travel (a boresight or mounting error of a degree moves 17 cm/s sideways
//! at 10 m/s), which [`crab_angle`] estimates robustly over the whole drive. A DG jump
//! (Cazzaniga et al. 2007 §1.2) shifts the position within about a second without turning the vehicle: its
//! across-track part is sideways motion beyond the crab, its along-track part a bump in the along-track speed;
//! neither disturbs the heading, so the vehicle-frame decomposition follows turns that a world-frame velocity
//! median would smear.

use nalgebra::Vector3;
use plumbline_geo::Trajectory;
use plumbline_geo::trajectory::PositionInterpolation;

/// Speed above which a sample counts as moving for the crab-angle estimate, m/s: there the DG's millimetre
/// noise is well below a hundredth of a sample's displacement.
pub(crate) const MOVING_SPEED: f64 = 2.0;

/// The DG's displacement over consecutive sample intervals of `h` seconds from `start`, in the vehicle frame.
pub(crate) struct Motion {
    /// Time of the first sample, seconds.
    pub start: f64,
    /// Sample spacing, seconds.
    pub h: f64,
    /// Mid-interval heading of each sample interval, radians clockwise from north.
    heading: Vec<f64>,
    /// Along the heading, metres.
    pub along: Vec<f64>,
    /// Across the heading, to its right, metres.
    pub across: Vec<f64>,
    /// Up, metres.
    pub up: Vec<f64>,
}

impl Motion {
    /// Sample [t0, t0 + n·h] with n = ⌊(t1 − t0) / h⌋ (None when some sample lies outside the trajectory).
    pub fn sample(trajectory: &Trajectory, (t0, t1): (f64, f64), h: f64) -> Option<Self> {
        let count = ((t1 - t0) / h).floor().max(0.0) as usize;
        let at = |t: f64| trajectory.interpolate(t, PositionInterpolation::Linear).ok();
        let records: Vec<_> = (0..=count).map(|i| at(t0 + i as f64 * h)).collect::<Option<_>>()?;
        let n = records.len().saturating_sub(1);
        let mut m = Self {
            start: t0,
            h,
            heading: Vec::with_capacity(n),
            along: Vec::with_capacity(n),
            across: Vec::with_capacity(n),
            up: Vec::with_capacity(n),
        };
        for w in records.windows(2) {
            let d = w[1].position.p - w[0].position.p;
            let psi = w[0].attitude.heading + 0.5 * crate::model::wrap(w[1].attitude.heading - w[0].attitude.heading);
            // Forward = (sin ψ, cos ψ), right = (cos ψ, −sin ψ) in east, north.
            let (s, c) = psi.sin_cos();
            m.heading.push(psi);
            m.along.push(d.x * s + d.y * c);
            m.across.push(d.x * c - d.y * s);
            m.up.push(d.z);
        }
        Some(m)
    }

    /// Number of sample intervals.
    pub fn len(&self) -> usize {
        self.along.len()
    }

    /// The sample interval starting nearest to `t`, clamped to [0, len].
    pub fn index(&self, t: f64) -> usize {
        (((t - self.start) / self.h).round().max(0.0) as usize).min(self.len())
    }

    /// The east, north, up vector of vehicle-frame components (along, across, up) at sample interval `i`.
    pub fn to_world(&self, i: usize, along: f64, across: f64, up: f64) -> Vector3<f64> {
        let (s, c) = self.heading[i].sin_cos();
        Vector3::new(along * s + across * c, along * c - across * s, up)
    }
}

/// The crab angle of the drive: the median of atan(across / along) over the samples moving faster than
/// [`MOVING_SPEED`] (forwards or backwards), radians, positive when the vehicle moves to the right of its
/// heading. A jump or a turn spoils a minority of them; None when no sample moves.
pub(crate) fn crab_angle(m: &Motion) -> Option<f64> {
    let min = MOVING_SPEED * m.h;
    // Non-holonomic land vehicle (Cazzaniga et al. 2007 §2): across / along = tan(crab) when no jump intervenes.
    let mut angles: Vec<f64> =
        m.along.iter().zip(&m.across).filter(|(a, _)| a.abs() > min).map(|(a, x)| (x / a).atan()).collect();
    if angles.is_empty() {
        return None;
    }
    let mid = angles.len() / 2;
    let (_, m, _) = angles.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::{Attitude, Point3, TrajectoryRecord, ValidationLimits};

    /// Driving north-east at 10 m/s for 60 s with the heading reading `crab` less than the direction of
    /// travel, and a 0.3 m jump to the right rising over 1 s at 30 s.
    fn crabbed(crab: f64) -> Trajectory {
        let course = 45f64.to_radians();
        let records = (0..3000)
            .map(|i| {
                let t = i as f64 * 0.02;
                let jump = 0.3 * (t - 30.0).clamp(0.0, 1.0);
                let (s, c) = course.sin_cos();
                let p = Point3::new(1000.0 + 10.0 * t * s + jump * c, 2000.0 + 10.0 * t * c - jump * s, 50.0);
                TrajectoryRecord { time: t, position: p, attitude: Attitude::new(0.0, 0.0, course - crab), std: None }
            })
            .collect();
        Trajectory::new(records, &ValidationLimits::default()).unwrap()
    }

    #[test]
    fn the_crab_angle_is_the_heading_misalignment_and_jumps_do_not_bias_it() {
        for degrees in [0.0f64, 1.0, -2.0] {
            let crab = degrees.to_radians();
            let m = Motion::sample(&crabbed(crab), (0.0, 59.9), 0.05).unwrap();
            let estimated = crab_angle(&m).unwrap();
            assert!((estimated - crab).abs() < 1e-4, "{degrees}°: {}", estimated.to_degrees());
            // Back to the world frame: 0.5 m along the heading and none across is the heading's direction.
            let w = m.to_world(0, 0.5, 0.0, 0.0);
            let psi = (45f64.to_radians() - crab).sin_cos();
            assert!((w - Vector3::new(0.5 * psi.0, 0.5 * psi.1, 0.0)).norm() < 1e-12);
        }
    }
}
