//! Stretches of an IMU recording that were not measured: dropouts a logger or converter filled in (the
//! samples of a run lie exactly on a straight line in time, or repeat one value), and intervals much longer
//! than the recording's rate (samples lost and not filled).
//!
//! Real logs have them: the KITTI raw drive 2011_10_03_drive_0027 as GTSAM's wheel ships it holds eight runs
//! of about 1.6 s in which all six channels are linear interpolations, three of them in sharp turns, where
//! the interpolated yaw rate misses up to 15° of the turn. Mechanised as if measured, such a run turns the
//! heading by the wrong angle with the filter's full confidence, and through a GNSS outage the error grows
//! to metres. Found, the run is mechanised as recorded (the best guess there is) but the filter adds process
//! noise for the motion nobody recorded: a road vehicle's unrecorded turn rate about the vertical, a little
//! roll and pitch (the suspension's travel bounds them whatever the gap's length), and its acceleration.
//! The GNSS fixes after the gap then pull the heading back, and the smoother places the correction inside
//! the gap instead of smearing it over the outage.
//!
//! A filled run is recognised only in a noisy recording: sensor noise never puts a dozen samples on one line
//! in all six channels, but a noise-free simulation does so on every straight, so detection stays off when
//! the recording's typical residual from linearity is itself at rounding level.

use plumbline_geo::metrics::median;
use serde::{Deserialize, Serialize};

use crate::config::ImuGapModel;
use crate::inputs::ImuSample;
use crate::state::{ATT, ErrVec, VEL};

/// What kind of unrecorded stretch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum GapKind {
    /// Samples interpolated or held by whoever wrote the file.
    Filled,
    /// One interval far longer than the recording's rate: samples lost.
    Missing,
}

/// One unrecorded stretch: samples `first..=last` (indices into the IMU input).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct ImuGap {
    pub kind: GapKind,
    /// First and last sample of the stretch.
    pub first: usize,
    pub last: usize,
    /// Start of the first sample's interval and end of the last one's, s.
    pub start: f64,
    pub end: f64,
}

impl ImuGap {
    /// Length of the stretch, s.
    pub fn duration(&self) -> f64 {
        self.end - self.start
    }
}

/// "On the line" means a residual under this share of the recording's median residual (noise sits around
/// the median; a filler's rounding, 1e-12 to 1e-8 of the value in KITTI's file, far below it) …
const LINEAR_SHARE: f64 = 1e-4;
/// … and never under this relative residual (a few rounding steps of the rates).
const LINEAR_FLOOR: f64 = 1e-9;
/// Detection of filled runs needs a recording whose median relative residual from linearity is at least
/// this (noise, not rounding).
const NOISY: f64 = 1e-6;

/// Every unrecorded stretch of `imu`, in time order.
pub fn find_imu_gaps(imu: &[ImuSample], model: &ImuGapModel) -> Vec<ImuGap> {
    let mut gaps = filled_runs(imu, model.min_filled);
    gaps.extend(missing(imu, model.missing_factor));
    gaps.sort_by_key(|g| g.first);
    gaps
}

/// The six rates of a sample (Δθ/dt, Δv/dt).
fn rates(s: &ImuSample) -> [f64; 6] {
    let (w, a) = (s.delta_theta.v / s.dt, s.delta_v.v / s.dt);
    [w.x, w.y, w.z, a.x, a.y, a.z]
}

/// Largest relative residual of sample `i`'s rates from the line through its neighbours', whichever of two
/// fillers wrote them: one interpolating by sample count, one by time stamp (the same where the intervals are
/// equal).
fn residual(imu: &[ImuSample], i: usize) -> f64 {
    let (a, b, c) = (&imu[i - 1], &imu[i], &imu[i + 1]);
    let (ra, rb, rc) = (rates(a), rates(b), rates(c));
    let off_line = |w: f64| {
        (0..6).map(|k| (rb[k] - (ra[k] + w * (rc[k] - ra[k]))).abs() / (1.0 + rb[k].abs())).fold(0.0, f64::max)
    };
    off_line(0.5).min(off_line((b.time - a.time) / (c.time - a.time)))
}

fn filled_runs(imu: &[ImuSample], min_filled: usize) -> Vec<ImuGap> {
    if imu.len() < 3 {
        return Vec::new();
    }
    let residuals: Vec<f64> = (1..imu.len() - 1).map(|i| residual(imu, i)).collect();
    let mut finite: Vec<f64> = residuals.iter().copied().filter(|r| r.is_finite()).collect();
    let typical = median(&mut finite).unwrap_or(0.0);
    if typical < NOISY {
        return Vec::new();
    }
    let tolerance = (LINEAR_SHARE * typical).max(LINEAR_FLOOR);
    let mut gaps = Vec::new();
    let mut run_start = None;
    // residuals[j] belongs to sample j + 1; a sentinel closes the last run.
    for (j, r) in residuals.iter().copied().chain(std::iter::once(f64::INFINITY)).enumerate() {
        match (r <= tolerance, run_start) {
            (true, None) => run_start = Some(j + 1),
            (false, Some(first)) => {
                let last = j; // sample j is the last linear one
                if last + 1 - first >= min_filled {
                    gaps.push(ImuGap {
                        kind: GapKind::Filled,
                        first,
                        last,
                        start: imu[first].time - imu[first].dt,
                        end: imu[last].time,
                    });
                }
                run_start = None;
            }
            _ => {}
        }
    }
    gaps
}

fn missing(imu: &[ImuSample], factor: f64) -> Vec<ImuGap> {
    let mut dts: Vec<f64> = imu.iter().map(|s| s.dt).collect();
    let Some(typical) = median(&mut dts) else { return Vec::new() };
    imu.iter()
        .enumerate()
        .filter(|(_, s)| s.dt > factor * typical)
        .map(|(i, s)| ImuGap { kind: GapKind::Missing, first: i, last: i, start: s.time - s.dt, end: s.time })
        .collect()
}

/// The process noise a gap adds to one of its samples of length `dt`: a gap of length T reaches σ = rate·T
/// in heading, `tilt_std` in roll and pitch, accel·T in velocity.
pub(crate) fn gap_noise(model: &ImuGapModel, gap: &ImuGap, dt: f64) -> ErrVec {
    let span = gap.duration().max(dt);
    let mut q = ErrVec::zeros();
    for a in 0..3 {
        q[VEL + a] = model.accel_std.powi(2) * span * dt;
    }
    q[ATT] = model.tilt_std.powi(2) * dt / span;
    q[ATT + 1] = model.tilt_std.powi(2) * dt / span;
    q[ATT + 2] = model.yaw_rate_std.powi(2) * span * dt;
    q
}

/// The extra process noise per sample, looked up by sample index.
#[derive(Clone, Debug, Default)]
pub(crate) struct GapNoise {
    /// The gaps in sample order (they do not overlap).
    gaps: Vec<ImuGap>,
    model: Option<ImuGapModel>,
}

impl GapNoise {
    pub fn new(gaps: Vec<ImuGap>, model: Option<ImuGapModel>) -> Self {
        Self { gaps, model }
    }

    pub fn gaps(&self) -> &[ImuGap] {
        &self.gaps
    }

    /// The extra noise of sample `k` of length `dt`, if it lies in a gap.
    pub fn at(&self, k: usize, dt: f64) -> Option<ErrVec> {
        let model = self.model.as_ref()?;
        let i = self.gaps.partition_point(|g| g.last < k);
        self.gaps.get(i).filter(|g| g.first <= k).map(|g| gap_noise(model, g, dt))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::{Body, Vec3};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Samples `first..=last` replaced by the line between their neighbours' rates, by sample count.
    fn fill_line(imu: &mut [ImuSample], first: usize, last: usize) {
        let (r0, r1) = (rates(&imu[first - 1]), rates(&imu[last + 1]));
        let n = (last + 2 - first) as f64;
        for (j, s) in imu[first..=last].iter_mut().enumerate() {
            let f = (j + 1) as f64 / n;
            let r: Vec<f64> = (0..6).map(|k| r0[k] + f * (r1[k] - r0[k])).collect();
            s.delta_theta = Vec3::new(r[0], r[1], r[2]) * s.dt;
            s.delta_v = Vec3::new(r[3], r[4], r[5]) * s.dt;
        }
    }

    /// A noisy 100 Hz recording (deterministic pseudo-noise) with samples 200..=359 replaced by the line
    /// between samples 199 and 360, and sample 500's interval stretched to 0.5 s.
    fn recording() -> Vec<ImuSample> {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut n = move || (rng.random::<f64>() - 0.5) * 2e-3;
        let mut time = 0.0;
        let mut out = Vec::new();
        for i in 0..1000 {
            let dt = if i == 500 { 0.5 } else { 0.01 };
            time += dt;
            let w = Vec3::<Body>::new(0.01 + n(), n(), 0.3 * (f64::from(i) * 0.01).sin() + n());
            let a = Vec3::<Body>::new(n(), n(), -9.8 + n());
            out.push(ImuSample { time, dt, delta_theta: w * dt, delta_v: a * dt });
        }
        fill_line(&mut out, 200, 359);
        out
    }

    #[test]
    fn finds_the_filled_run_and_the_lost_interval() {
        let imu = recording();
        let gaps = find_imu_gaps(&imu, &ImuGapModel::default());
        assert_eq!(gaps.len(), 2, "{gaps:?}");
        assert_eq!((gaps[0].kind, gaps[0].first, gaps[0].last), (GapKind::Filled, 200, 359));
        assert!((gaps[0].duration() - 1.6).abs() < 1e-9, "{}", gaps[0].duration());
        assert_eq!((gaps[1].kind, gaps[1].first, gaps[1].last), (GapKind::Missing, 500, 500));
    }

    #[test]
    fn a_noise_free_recording_has_no_filled_runs() {
        let imu: Vec<ImuSample> = (1..=500)
            .map(|i| ImuSample {
                time: i as f64 * 0.01,
                dt: 0.01,
                delta_theta: Vec3::new(0.0, 0.0, 0.001),
                delta_v: Vec3::new(0.0, 0.0, -0.098),
            })
            .collect();
        assert!(find_imu_gaps(&imu, &ImuGapModel::default()).is_empty());
    }

    #[test]
    fn a_short_linear_stretch_is_not_a_gap() {
        let mut imu = recording();
        imu.truncate(190); // before the filled run
        fill_line(&mut imu, 101, 105);
        assert!(find_imu_gaps(&imu, &ImuGapModel::default()).is_empty());
    }

    #[test]
    fn noise_grows_heading_with_the_gap_and_bounds_tilt() {
        let model = ImuGapModel::default();
        let gap = ImuGap { kind: GapKind::Filled, first: 0, last: 159, start: 0.0, end: 1.6 };
        let total: ErrVec = (0..160).map(|_| gap_noise(&model, &gap, 0.01)).sum();
        assert!((total[ATT + 2].sqrt() - 0.15 * 1.6).abs() < 1e-9);
        assert!((total[ATT].sqrt() - 0.02).abs() < 1e-9);
        assert!((total[VEL].sqrt() - 0.3 * 1.6).abs() < 1e-9);
        let noise = GapNoise::new(vec![gap], Some(model));
        assert!(noise.at(159, 0.01).is_some() && noise.at(160, 0.01).is_none());
        assert!(GapNoise::new(vec![gap], None).at(10, 0.01).is_none());
    }
}
