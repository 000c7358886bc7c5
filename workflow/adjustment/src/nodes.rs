//! Node epochs of the correction, interpolation weights between them, and the DG chain model: relative
//! random-walk constraints between consecutive nodes and the weak absolute prior.

use nalgebra::Vector6;
use plumbline_geo::trajectory::PositionInterpolation;
use plumbline_geo::{PoseStd, Trajectory};
use serde::{Deserialize, Serialize};

use crate::config::AdjustmentConfig;

/// A time interval over which the relative constraints are weakened, e.g. a DG jump flagged by the
/// navigation consistency check.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct WeakLink {
    /// Start of the interval, seconds.
    pub start: f64,
    /// End of the interval, seconds.
    pub end: f64,
    /// Factor applied to the relative constraint's standard deviation (> 1 weakens).
    pub factor: f64,
}

/// The sorted node epochs.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Nodes {
    pub times: Vec<f64>,
}

impl Nodes {
    /// Observation epochs + regular spacing + the trajectory ends, sorted, near-duplicates merged.
    pub fn new(mut times: Vec<f64>, span: (f64, f64), config: &AdjustmentConfig) -> Self {
        times.push(span.0);
        times.push(span.1);
        if let Some(step) = config.node_spacing.filter(|s| *s > 0.0) {
            let count = ((span.1 - span.0) / step).floor() as usize;
            times.extend((1..=count).map(|i| span.0 + i as f64 * step));
        }
        times.retain(|t| t.is_finite() && *t >= span.0 && *t <= span.1);
        times.sort_by(f64::total_cmp);
        let mut merged: Vec<f64> = Vec::with_capacity(times.len());
        for t in times {
            if merged.last().is_none_or(|last| t - last >= config.min_node_gap) {
                merged.push(t);
            }
        }
        Self { times: merged }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// The node at `t` (within the merge gap), if any.
    pub fn index_of(&self, t: f64) -> Option<usize> {
        let k = self.times.partition_point(|x| *x < t);
        [k.checked_sub(1), Some(k)]
            .into_iter()
            .flatten()
            .filter(|&i| i < self.times.len())
            .min_by(|&i, &j| (self.times[i] - t).abs().total_cmp(&(self.times[j] - t).abs()))
    }

    /// The nodes bracketing `t` with their linear-interpolation weights (zero weights dropped); constant
    /// beyond the ends.
    pub fn bracket(&self, t: f64) -> Vec<(usize, f64)> {
        let upper = self.times.partition_point(|x| *x <= t);
        if upper == 0 {
            return vec![(0, 1.0)];
        }
        let k = upper - 1;
        if k + 1 >= self.times.len() {
            return vec![(k, 1.0)];
        }
        let w = (t - self.times[k]) / (self.times[k + 1] - self.times[k]);
        [(k, 1.0 - w), (k + 1, w)].into_iter().filter(|(_, w)| *w > 0.0).collect()
    }
}

/// DG standard deviations at `t` as [east, north, height, θ_east, θ_north, θ_up].
pub(crate) fn dg_std(trajectory: &Trajectory, t: f64, config: &AdjustmentConfig) -> Vector6<f64> {
    let std = trajectory.interpolate(t, PositionInterpolation::Linear).ok().and_then(|r| r.std);
    let [e, n, h, roll, pitch, heading] = match std {
        Some(PoseStd { east, north, height, roll, pitch, heading }) => [east, north, height, roll, pitch, heading],
        None => config.default_std,
    };
    let tilt = ((roll * roll + pitch * pitch) / 2.0).sqrt();
    let floor = 1e-6;
    Vector6::new(e, n, h, tilt, tilt, heading).map(|s| s.max(floor))
}

/// σ of the relative constraint x_{k+1} − x_k for each component (the random-walk model of [`RandomWalk`]).
///
/// [`RandomWalk`]: crate::RandomWalk
pub(crate) fn relative_sigma(
    dt: f64,
    std_a: &Vector6<f64>,
    std_b: &Vector6<f64>,
    config: &AdjustmentConfig,
    factor: f64,
) -> Vector6<f64> {
    let rw = &config.random_walk;
    Vector6::from_fn(|c, _| {
        let floor = if c < 3 { rw.position_floor } else { rw.attitude_floor };
        let mean = 0.5 * (std_a[c] + std_b[c]);
        let rate = floor * floor + mean * mean / rw.correlation_time;
        (dt * rate).sqrt().max(1e-9) * factor
    })
}

/// The largest weakening factor of the links overlapping (t0, t1); 1 when none does.
pub(crate) fn link_factor(links: &[WeakLink], t0: f64, t1: f64) -> f64 {
    links.iter().filter(|l| l.start < t1 && l.end > t0).map(|l| l.factor).fold(1.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brackets_interpolate_linearly_and_clamp_at_the_ends() {
        let nodes = Nodes::new(vec![2.0, 5.0, 5.0005], (0.0, 10.0), &AdjustmentConfig::default());
        assert_eq!(nodes.times, [0.0, 2.0, 5.0, 10.0]);
        assert_eq!(nodes.bracket(3.5), [(1, 0.5), (2, 0.5)]);
        assert_eq!(nodes.bracket(5.0), [(2, 1.0)]);
        assert_eq!(nodes.bracket(-1.0), [(0, 1.0)]);
        assert_eq!(nodes.bracket(10.0), [(3, 1.0)]);
        let spaced = AdjustmentConfig { node_spacing: Some(4.0), ..AdjustmentConfig::default() };
        assert_eq!(Nodes::new(vec![], (0.0, 10.0), &spaced).times, [0.0, 4.0, 8.0, 10.0]);
    }

    #[test]
    fn relative_sigma_grows_with_root_dt_and_dg_sigma() {
        let cfg = AdjustmentConfig::default();
        let good = Vector6::repeat(0.01);
        let bad = Vector6::repeat(1.0);
        let s1 = relative_sigma(1.0, &good, &good, &cfg, 1.0);
        let s4 = relative_sigma(4.0, &good, &good, &cfg, 1.0);
        assert!((s4[0] / s1[0] - 2.0).abs() < 1e-12);
        assert!(relative_sigma(1.0, &bad, &bad, &cfg, 1.0)[0] > 10.0 * s1[0]);
        let expected = (0.002f64.powi(2) + 0.01f64.powi(2) / 10.0).sqrt();
        assert!((s1[0] - expected).abs() < 1e-15);
    }
}
