//! The fault timeline: multipath jumps and GNSS outages, drawn epoch by epoch from the environment.
//!
//! At most one fault is active at a time. While idle, a jump begins with probability `jump_rate · dt` and an
//! outage with `outage_rate · dt` (both 0 in the open). A jump is a constant offset that appears and vanishes
//! within `jump_transition` (1 s, a smoothstep: the smoother converging to the shifted GNSS fix; Cazzaniga et al. 2007
//! §1.2: the shift "may last for some time and finally vanish with a new jump"); its holding time is counted in driving time, which runs at `0.2 + 0.8 · min(v / 5 m/s, 1)` of the
//! clock, so a jump persists longer at slow speed and standstill (Meyer et al. 2023 §4.2.3, Fig. 7), and it ends at
//! once when the street opens up. An outage lasts an exponential time with mean
//! `outage_seconds_per_ratio · ratio`; the smoothed solution bridges it with an error bump
//! `peak · sin²(π u)` (u = 0…1 across the outage) whose per-axis σ grows with the duration,
//! `outage_growth · (D / 60 s)²` (Grejner-Brzezinska and Toth 2000 §2.1: 10–20 cm after 60 s for an LN-100).

use plumbline_geo::{Map, Vec3};

use super::DgConfig;
use super::environment::Environment;
use crate::motion::Kinematics;
use crate::motion::rng::{Purpose, Stream};

/// Speed at which multipath decorrelates at the full clock rate, m/s.
const DECORRELATION_SPEED: f64 = 5.0;

/// What kind of fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FaultKind {
    /// A multipath jump: a constant offset for its duration.
    Jump,
    /// A GNSS outage bridged by the inertial solution.
    Outage,
}

/// One fault of the DG solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    /// Jump or outage.
    pub kind: FaultKind,
    /// Index of the first affected epoch.
    pub first: usize,
    /// Index one past the last affected epoch.
    pub end: usize,
    /// Time of the first affected epoch, s.
    pub start_time: f64,
    /// Duration, s, from the first affected epoch until the error is gone.
    pub duration: f64,
    /// Rise and fall time of a jump, s.
    pub transition: f64,
    /// Jump: the offset. Outage: the peak of the error bump. East, north, up; metres.
    pub offset: Vec3<Map>,
}

impl Fault {
    /// The fault's position error at epoch time `t` (zero outside it).
    pub fn error_at(&self, t: f64) -> Vec3<Map> {
        match self.kind {
            FaultKind::Jump => {
                let rise = smoothstep((t - self.start_time) / self.transition);
                let fall = smoothstep((self.start_time + self.duration - t) / self.transition);
                self.offset * rise.min(fall)
            }
            FaultKind::Outage => {
                let u = ((t - self.start_time) / self.duration).clamp(0.0, 1.0);
                self.offset * (std::f64::consts::PI * u).sin().powi(2)
            }
        }
    }

    /// True while a jump rises or falls at time `t` (where consecutive epochs may differ by centimetres).
    pub fn in_transition(&self, t: f64) -> bool {
        let end = self.start_time + self.duration;
        self.kind == FaultKind::Jump
            && ((t >= self.start_time && t <= self.start_time + self.transition)
                || (t >= end - self.transition && t <= end))
    }
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// Draw the faults along the epochs of a drive.
pub(crate) fn draw(kinematics: &[Kinematics], config: &DgConfig, seed: u64) -> Vec<Fault> {
    let mut drawer = FaultDrawer::new(seed);
    let mut faults: Vec<Fault> = Vec::new();
    for (i, k) in kinematics.iter().enumerate() {
        drawer.step(i, k, config, &mut faults);
    }
    if let Some((mut fault, _)) = drawer.active {
        fault.end = kinematics.len();
        faults.push(fault);
    }
    faults
}

/// The fault timeline drawn epoch by epoch; carried from one leg of a drive to the next.
#[derive(Clone, Debug)]
pub(crate) struct FaultDrawer {
    rng: Stream,
    /// The active fault and, for a jump still holding, its remaining driving time.
    active: Option<(Fault, Option<f64>)>,
    last_time: Option<f64>,
}

impl FaultDrawer {
    pub(crate) fn new(seed: u64) -> Self {
        Self { rng: Stream::new(seed, Purpose::Faults), active: None, last_time: None }
    }

    /// The faults of one leg (epoch indices within it): those that end in it, then the one still active at
    /// its end, whose fall (if a holding jump) lies beyond the leg.
    pub(crate) fn leg(&mut self, kinematics: &[Kinematics], config: &DgConfig) -> Vec<Fault> {
        if let Some((fault, _)) = &mut self.active {
            fault.first = 0;
        }
        let mut faults = Vec::new();
        for (i, k) in kinematics.iter().enumerate() {
            self.step(i, k, config, &mut faults);
        }
        if let Some((mut fault, holding)) = self.active {
            fault.end = kinematics.len();
            if holding.is_some() {
                fault.duration = f64::INFINITY;
            }
            faults.push(fault);
        }
        faults
    }

    /// Advance to epoch `i`; a fault that ends here goes to `out`.
    fn step(&mut self, i: usize, k: &Kinematics, config: &DgConfig, out: &mut Vec<Fault>) {
        let dt = self.last_time.map_or(0.0, |t| k.time - t);
        self.last_time = Some(k.time);
        let env = Environment::of_ratio(k.canyon.ratio());
        if let Some((mut fault, holding)) = self.active.take() {
            match holding {
                Some(left) => {
                    let left = left - dt * driving_rate(k.speed);
                    if left <= 0.0 || env == Environment::Open {
                        // Start to fall now: gone after the transition.
                        fault.duration = k.time - fault.start_time + fault.transition;
                        self.active = Some((fault, None));
                    } else {
                        self.active = Some((fault, Some(left)));
                    }
                    return;
                }
                None if k.time < fault.start_time + fault.duration => {
                    self.active = Some((fault, None));
                    return;
                }
                None => {
                    fault.end = i;
                    out.push(fault);
                }
            }
        }
        self.active = begin(i, k, env, dt, config, &mut self.rng);
    }
}

/// Maybe start a fault at epoch `i`.
fn begin(
    i: usize,
    k: &Kinematics,
    env: Environment,
    dt: f64,
    config: &DgConfig,
    rng: &mut Stream,
) -> Option<(Fault, Option<f64>)> {
    let p = &config.environments[env.index()];
    let (jump, outage) = (rng.chance(p.jump_rate * dt), rng.chance(p.outage_rate * dt));
    let transition = config.jump_transition;
    let base = Fault {
        kind: FaultKind::Jump,
        first: i,
        end: i,
        start_time: k.time,
        duration: 0.0,
        transition,
        offset: Vec3::zeros(),
    };
    if jump {
        let size = rng.log_uniform(p.jump_size.0, p.jump_size.1);
        let (e, n) = rng.direction();
        let up = config.jump_height_factor * size * rng.normal();
        let duration = rng.uniform(p.jump_duration.0, p.jump_duration.1);
        return Some((Fault { offset: Vec3::new(e * size, n * size, up), ..base }, Some(duration)));
    }
    if outage {
        let duration = -(1.0 - rng.unit()).ln() * p.outage_seconds_per_ratio * k.canyon.ratio().min(10.0);
        let duration = duration.clamp(1.0, config.max_outage);
        let sigma = config.outage_growth * (duration / 60.0).powi(2);
        let offset = Vec3::new(rng.normal(), rng.normal(), rng.normal()) * sigma;
        return Some((Fault { kind: FaultKind::Outage, duration, offset, ..base }, None));
    }
    None
}

/// Driving-time rate: multipath changes with the geometry, so it persists when the vehicle is slow.
fn driving_rate(speed: f64) -> f64 {
    0.2 + 0.8 * (speed / DECORRELATION_SPEED).min(1.0)
}

/// σ per axis of an outage bump of `duration` seconds.
pub(crate) fn outage_sigma(config: &DgConfig, duration: f64) -> f64 {
    config.outage_growth * (duration / 60.0).powi(2)
}
