//! Raw GNSS positions of the antenna at 1–10 Hz, sharing the DG solution's canyon process.
//!
//! The DG solution follows GNSS, so a GNSS fix carries the same slow drift and multipath jumps as the DG
//! error at that epoch ([`dg`](super::dg)), plus receiver white noise per environment. During an outage
//! there is no fix (the DG solution's outage bump comes from the inertial bridge, not from GNSS). The
//! antenna sits at `lever_arm` in the body frame (x forward, y right, z down). Reported σ: the environment's
//! reported DG σ combined with the white noise.

use nalgebra::Vector3;
use plumbline_geo::{Body, Map, Point3, Vec3};
use serde::{Deserialize, Serialize};

use super::dg::{DgConfig, DgSolution, Environment, FaultKind};
use super::rng::{Purpose, Stream};
use super::{Drive, MotionError};

/// Parameters of the raw GNSS positions.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct GnssConfig {
    /// Fix rate, Hz (1–10). Default 5.
    pub rate_hz: f64,
    /// Antenna position in the body frame, m. Default (0, 0, −0.4): 40 cm above the IMU.
    pub lever_arm: [f64; 3],
    /// Receiver white noise per horizontal axis, m, for open / urban / canyon. Default 5 mm, 2 cm, 5 cm.
    pub white_horizontal: [f64; 3],
    /// Receiver white noise in height, m, for open / urban / canyon. Default 1 cm, 4 cm, 10 cm.
    pub white_height: [f64; 3],
}

impl Default for GnssConfig {
    fn default() -> Self {
        Self {
            rate_hz: 5.0,
            lever_arm: [0.0, 0.0, -0.4],
            white_horizontal: [0.005, 0.02, 0.05],
            white_height: [0.01, 0.04, 0.10],
        }
    }
}

/// One GNSS fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssRecord {
    /// Time, s.
    pub time: f64,
    /// Antenna position in the mapping frame, m.
    pub position: Point3<Map>,
    /// Reported σ: east, north, up; m.
    pub std: [f64; 3],
    /// The environment at the fix.
    pub environment: Environment,
}

/// GNSS fixes of `drive` consistent with its DG solution `dg` (made with `dg_config`).
pub fn simulate(
    drive: &Drive,
    dg: &DgSolution,
    dg_config: &DgConfig,
    config: &GnssConfig,
    seed: u64,
) -> Result<Vec<GnssRecord>, MotionError> {
    GnssStream::new(dg_config, config, seed)?.leg(drive, dg)
}

/// GNSS fixes of a drive simulated in legs (the `city` preset): the fix clock (one grid of `rate_hz` from the
/// first leg's start) and the receiver noise continue from leg to leg, so the joined fixes are those of one
/// drive; [`simulate`] is one leg.
#[derive(Clone, Debug)]
pub struct GnssStream {
    dg_config: DgConfig,
    config: GnssConfig,
    rng: Stream,
    /// Start of the fix clock (the first leg's first epoch), once known.
    origin: Option<f64>,
    /// Number of the next fix on the clock.
    next: u64,
}

impl GnssStream {
    /// A new receiver for DG solutions made with `dg_config`; noise from `seed`.
    pub fn new(dg_config: &DgConfig, config: &GnssConfig, seed: u64) -> Result<Self, MotionError> {
        if !(config.rate_hz.is_finite() && config.rate_hz > 0.0) {
            return Err(MotionError::Config {
                config: "gnss",
                field: "rate_hz",
                value: config.rate_hz,
                expected: "> 0 Hz",
            });
        }
        let rng = Stream::new(seed, Purpose::Gnss);
        Ok(Self { dg_config: dg_config.clone(), config: *config, rng, origin: None, next: 0 })
    }

    /// The fixes of the next leg `drive` (epochs after the previous leg's) with its DG solution `dg`.
    pub fn leg(&mut self, drive: &Drive, dg: &DgSolution) -> Result<Vec<GnssRecord>, MotionError> {
        let records = drive.trajectory.records();
        if records.is_empty() || dg.errors.len() != records.len() {
            return Err(MotionError::Mismatch { what: "DG errors", expected: records.len(), got: dg.errors.len() });
        }
        let (t0, t1) = drive.trajectory.span();
        let origin = *self.origin.get_or_insert(t0);
        let lever = Point3::<Body>::from_vector(Vector3::from(self.config.lever_arm));
        let mut out = Vec::new();
        loop {
            let t = origin + self.next as f64 / self.config.rate_hz;
            if t > t1 + 1e-9 {
                break;
            }
            self.next += 1;
            let i = records.partition_point(|r| r.time < t - 1e-9).min(records.len() - 1);
            let (truth, e) = (&records[i], &dg.errors[i]);
            if e.fault == Some(FaultKind::Outage) {
                continue;
            }
            let env = e.environment.index();
            let (wh, wv) = (self.config.white_horizontal[env], self.config.white_height[env]);
            let rng = &mut self.rng;
            let white = Vec3::new(wh * rng.normal(), wh * rng.normal(), wv * rng.normal());
            let antenna = truth.pose().transform_point(&lever);
            let p = &self.dg_config.environments[env];
            let std = [p.reported_horizontal.hypot(wh), p.reported_horizontal.hypot(wh), p.reported_height.hypot(wv)];
            out.push(GnssRecord {
                time: truth.time,
                position: antenna + e.position + white,
                std,
                environment: e.environment,
            });
        }
        Ok(out)
    }
}
