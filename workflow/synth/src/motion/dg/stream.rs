//! The DG error process drawn leg by leg along a long drive (the `city` preset): the fault timeline, the
//! drift series and the white noise continue from one leg to the next, so the error is continuous where
//! legs join and its statistics are those of one drive ([`super::simulate`] for a whole drive at once).

use plumbline_geo::Map;
use plumbline_geo::Vec3;

use super::drift::KnotStream;
use super::faults::FaultDrawer;
use super::{DgConfig, DgSolution, EnvironmentParameters, errors_of};
use crate::motion::rng::{Purpose, Stream};
use crate::motion::{Drive, MotionError};

/// The DG error process of a drive simulated in legs.
#[derive(Clone, Debug)]
pub struct DgStream {
    config: DgConfig,
    faults: FaultDrawer,
    drift: Vec<KnotStream>,
    drift_rng: Stream,
    noise: Stream,
}

impl DgStream {
    /// A new process; every random draw comes from `seed`.
    pub fn new(config: &DgConfig, seed: u64) -> Result<Self, MotionError> {
        config.check()?;
        let axis = || KnotStream::new(config.knot_interval, config.drift_correlation_time);
        Ok(Self {
            config: config.clone(),
            faults: FaultDrawer::new(seed),
            drift: (0..6).map(|_| axis()).collect(),
            drift_rng: Stream::new(seed, Purpose::Drift),
            noise: Stream::new(seed, Purpose::DgNoise),
        })
    }

    /// The DG solution of the next leg (its epochs follow the previous leg's).
    pub fn leg(&mut self, drive: &Drive) -> Result<DgSolution, MotionError> {
        let k = &drive.kinematics;
        if k.is_empty() {
            return Err(MotionError::RouteTooShort { waypoints: 0 });
        }
        let faults = self.faults.leg(k, &self.config);
        let (t0, t1) = drive.trajectory.span();
        let config = &self.config;
        let env_at = |t: f64| {
            let i = k.partition_point(|e| e.time < t).min(k.len() - 1);
            config.params(super::Environment::of_ratio(k[i].canyon.ratio()))
        };
        let pick: [fn(&EnvironmentParameters) -> f64; 6] = [
            |p| p.drift_horizontal,
            |p| p.drift_horizontal,
            |p| p.drift_height,
            |p| p.drift_roll_pitch,
            |p| p.drift_roll_pitch,
            |p| p.drift_heading,
        ];
        let rng = &mut self.drift_rng;
        let axes: Vec<_> =
            self.drift.iter_mut().zip(pick).map(|(s, f)| s.extend(t0, t1, |t| f(env_at(t)), rng)).collect();
        let position = |t: f64| Vec3::<Map>::new(axes[0].at(t), axes[1].at(t), axes[2].at(t));
        let attitude = |t: f64| [axes[3].at(t), axes[4].at(t), axes[5].at(t)];
        errors_of(drive, config, faults, (&position, &attitude), &mut self.noise)
    }
}
