//! GNSS steps found against the IMU's own motion — the default integrity layer of `navigate`, and the
//! one that holds on real IMU data.
//!
//! The innovation tests of the filter (`adaptive`) compare a fix with the filter's prediction, so they
//! judge the GNSS by the filter's velocity and attitude. On a real drive those carry errors the IMU model
//! does not describe (a gyro that loses 10° in one sharp turn, velocity a metre per second off after it):
//! good fixes are then rejected, the filter drifts further without them, and the tests reject ever more.
//!
//! This test does not use the filter's velocity at all. For every fix it takes r = fix − lever arm −
//! P(t), with P the *free* inertial displacement: the IMU's map-frame acceleration (attitude and biases from
//! a first filter pass, gravity and Coriolis included) integrated twice from zero velocity. The true
//! position is P plus a straight line (the unknown start position and velocity), so the second divided
//! difference of r over three consecutive fixes,
//!
//! ```text
//! e_k = (r_k − r_{k−1}) / h_k − (r_{k−1} − r_{k−2}) / h_{k−1}     (m/s; h = time between fixes)
//! ```
//!
//! is zero up to the fixes' noise and what the IMU's acceleration errs in two intervals, independent of any
//! drift accumulated before. The IMU's errors are smooth: on a real drive they hold e at a few decimetres
//! per second, with the same sign, for seconds at a time. A GNSS step J at fix k is a doublet instead:
//! e_k = J / h_k and e_{k+1} = −J / h_k. So each pair of consecutive e is split into its antisymmetric part
//! a = (e_k − e_{k+1}) / 2 — the step's evidence, J = a·h_k — and its symmetric part, which a step leaves
//! at zero and the IMU's errors fill. Each axis of a is scaled by a robust σ measured on the data itself
//! (1.4826 × the median absolute a: a real unit's errors set the scale, not its datasheet) and vᵀv is tested
//! against χ²₃ at `alpha`. A step leaks into the pairs either side at half its size, and a fault changing
//! level fix by fix puts true steps side by side, so each run of consecutive rejected pairs has its steps
//! estimated together by least squares over their e: a side lobe's estimate falls to near zero, a true
//! neighbour keeps its size. A step is declared where its estimate is at least `min_step` (an outlier,
//! +J −2J +J in e, shows as a step out and a step back).
//!
//! The declared steps add up to each fix's offset; a step that lands near a level seen before in the chain
//! returns to it exactly. Within a chain of fixes (broken by gaps longer than
//! `max_gap`, where nothing links the levels on either side) the level most fixes share is trusted — the
//! GNSS is right most of the time, and a chain may begin inside a fault, as after an outage — and the runs
//! of fixes at least `min_step` away from it are excluded: the **episodes**. An isolated outlier is the
//! shortest (a step out and a step back).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::chi2::chi2_critical;
use crate::config::{InitialState, NavConfig};
use crate::filter::ForwardPass;
use crate::gaps::find_imu_gaps;
use crate::inputs::{GnssFix, ImuSample};
use crate::passes::{filter, filter_excluding};

/// Parameters of the step test.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StepTest {
    /// Significance level of the test at each fix.
    pub alpha: f64,
    /// Longest time between two fixes the test bridges, s: past it the chain restarts and any episode ends.
    pub max_gap: f64,
    /// Smallest step worth excluding fixes for, m. On real data the mismatch has sub-metre glitches for
    /// which a gap costs more than the filter's averaging (and which seldom return as a clean step), so the
    /// default is a metre; clean or simulated data can go lower.
    pub min_step: f64,
}

impl Default for StepTest {
    fn default() -> Self {
        Self { alpha: 0.001, max_gap: 5.0, min_step: 1.5 }
    }
}

impl StepTest {
    /// Check every parameter; the error names the first bad one.
    pub fn check(&self) -> Result<(), NavError> {
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return Err(NavError::Config { field: "steps.alpha", value: self.alpha, expected: "in (0, 1)" });
        }
        if !(self.min_step.is_finite() && self.min_step >= 0.0) {
            return Err(NavError::Config {
                field: "steps.min_step",
                value: self.min_step,
                expected: "a finite length >= 0 m",
            });
        }
        if !(self.max_gap.is_finite() && self.max_gap > 0.0) {
            let value = self.max_gap;
            return Err(NavError::Config { field: "steps.max_gap", value, expected: "a finite time > 0 s" });
        }
        Ok(())
    }
}

/// How an episode ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum EpisodeEnd {
    /// A step brought the fixes back to the trusted level: the GNSS recovered.
    Returned,
    /// A gap in the fixes, or in the IMU's record, broke the chain.
    Gap,
    /// The data ended inside it.
    Data,
}

/// A run of fixes excluded for carrying a step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct StepEpisode {
    /// Index of the first excluded fix.
    pub first_fix: usize,
    /// Fixes excluded.
    pub fixes: usize,
    /// Time of the first excluded fix, s.
    pub start: f64,
    /// Time of the last excluded fix, s.
    pub end: f64,
    /// Its offset from the trusted level at its first fix, east/north/up, m.
    pub step: [f64; 3],
    /// How it ended.
    pub ended: EpisodeEnd,
}

/// What [`screen_steps`] found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct StepScreen {
    /// Per input fix: excluded for lying in an episode.
    #[serde(skip)]
    pub excluded: Vec<bool>,
    /// The episodes in time order.
    pub episodes: Vec<StepEpisode>,
    /// Fixes tested (those with two predecessors and a successor in an unbroken chain).
    pub tested: usize,
    /// Significant steps found (each opens, extends or closes an episode).
    pub steps: usize,
    /// The robust σ of the step evidence a per axis (east, north, up), m/s.
    pub scale: [f64; 3],
    /// The smallest step declared, m ([`StepTest::min_step`]).
    pub min_step: f64,
}

impl StepScreen {
    /// Number of fixes excluded.
    pub fn excluded_count(&self) -> usize {
        self.excluded.iter().filter(|&&x| x).count()
    }
}

/// σ of a never drops below this, m/s: a perfect simulation must not make every centimetre a step.
const MIN_SCALE: f64 = 0.01;

/// `navigate`'s default: a first forward pass over every fix, the step test on it, and the filter again
/// without the fixes it excluded. The first pass takes every IMU sample at its own noise even where
/// `config.gaps` finds a gap: its heading stays stiff through a dropout, whose hidden turn then reads as a
/// slow drift of the free displacement, which the step test ignores. Loosened there, it would let faulty
/// fixes just after a gap turn the heading and spoil the free displacement everywhere after (on KITTI a
/// false 1.6 m step and 191 clean fixes excluded). The final pass applies `config` in full.
pub fn filter_screened(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    initial: &InitialState,
    config: &NavConfig,
    test: &StepTest,
) -> Result<(ForwardPass, StepScreen), NavError> {
    test.check()?;
    config.check()?;
    let gaps = config.gaps.map(|m| find_imu_gaps(imu, &m)).unwrap_or_default();
    let first = filter(imu, gnss, initial, &NavConfig { gaps: None, gnss_error: None, ..*config })?;
    let screen = screen_steps(&first, gnss, test);
    // Nothing excluded and nothing loosened: the first pass is the final one.
    let forward = if screen.excluded_count() == 0 && gaps.is_empty() {
        first
    } else {
        filter_excluding(imu, gnss, initial, config, &screen.excluded)?
    };
    Ok((forward, screen))
}

/// Find the GNSS steps of `gnss` against the free inertial displacement of `first` (a forward pass over the
/// same fixes: its attitude and biases rotate and correct the IMU increments). Fixes outside the IMU's
/// time span are left untested and kept.
pub fn screen_steps(first: &ForwardPass, gnss: &[GnssFix], test: &StepTest) -> StepScreen {
    let free = FreeMotion::of(first);
    let lever = first.config.lever_arm.v;
    let r: Vec<Option<Vector3<f64>>> =
        gnss.iter().map(|f| free.at(f.time).map(|(p, attitude)| f.position.p - attitude * lever - p)).collect();
    let chains = chains_of(gnss, &r, test.max_gap);
    let triples = chain_triples(gnss, &chains);
    let e: Vec<Vector3<f64>> = triples.iter().map(|t| t.e(&r)).collect();
    // Pairs of consecutive triples in one chain: the antisymmetric part of their e, at the later fix of
    // the first triple.
    let pairs: Vec<(usize, Vector3<f64>)> = (0..triples.len().saturating_sub(1))
        .filter(|&i| triples[i + 1].chain == triples[i].chain)
        .map(|i| (i, (e[i] - e[i + 1]) * 0.5))
        .collect();
    let scale = robust_scale(&pairs.iter().map(|(_, a)| *a).collect::<Vec<_>>());
    let crit = chi2_critical(3.0, test.alpha);
    let z2: Vec<f64> = pairs.iter().map(|(_, a)| a.component_div(&scale).norm_squared()).collect();
    let min_step = test.min_step;
    // A step's evidence leaks into the pairs on either side at half its size, and a fault that changes
    // level fix by fix puts true steps side by side: the significant pairs are taken in runs of
    // consecutive fixes and their steps estimated together; a side lobe then gets a step near zero, a true
    // neighbouring step keeps its size. Those of at least `min_step` are declared.
    let significant: Vec<usize> = pairs.iter().zip(&z2).filter(|(_, z)| **z >= crit).map(|((i, _), _)| *i).collect();
    let mut declared: Vec<usize> = Vec::new();
    for run in significant.chunk_by(|a, b| b - a == 1) {
        for (i, step) in run.iter().zip(block_steps(&triples, &e, run)) {
            if step.norm() >= min_step {
                declared.push(*i);
            }
        }
    }
    let mut steps: Vec<Option<Vector3<f64>>> = vec![None; gnss.len()];
    for block in declared.chunk_by(|a, b| b - a == 1) {
        for (i, step) in block.iter().zip(block_steps(&triples, &e, block)) {
            steps[triples[*i].k] = Some(step);
        }
    }
    let count = declared.len();
    let mut excluded = vec![false; gnss.len()];
    let mut episodes = Vec::new();
    for (c, chain) in chains.iter().enumerate() {
        let last_chain = c + 1 == chains.len();
        episodes.extend(judge_chain(chain, gnss, &steps, min_step, last_chain, &mut excluded));
    }
    StepScreen { excluded, episodes, tested: pairs.len(), steps: count, scale: [scale.x, scale.y, scale.z], min_step }
}

/// The steps at the fixes ending the consecutive triples `block`, by least squares over their e and the
/// next triple's: e_i = J(k_i)/h2_i − J(k_{i−1})/h1_i, with J zero outside the block. A lone step gives
/// (e_i − e_{i+1})/2·h; adjacent steps (a fault changing level fix by fix) are separated, where the pairs'
/// antisymmetric parts would halve them.
fn block_steps(triples: &[Triple], e: &[Vector3<f64>], block: &[usize]) -> Vec<Vector3<f64>> {
    let m = block.len();
    let first = block[0];
    let rows = if first + m < triples.len() { m + 1 } else { m };
    let mut a = nalgebra::DMatrix::<f64>::zeros(rows, m);
    for row in 0..rows {
        let t = &triples[first + row];
        if row < m {
            a[(row, row)] = 1.0 / t.h2;
        }
        if row > 0 {
            a[(row, row - 1)] = -1.0 / t.h1;
        }
    }
    let mut out = vec![Vector3::zeros(); m];
    let Some(solver) = (a.transpose() * &a).cholesky() else {
        return block.iter().map(|&i| e[i] * triples[i].h2).collect();
    };
    for axis in 0..3 {
        let b = nalgebra::DVector::from_iterator(rows, (0..rows).map(|row| e[first + row][axis]));
        let x = solver.solve(&(a.transpose() * b));
        for (j, value) in x.iter().enumerate() {
            out[j][axis] = *value;
        }
    }
    out
}

/// The usable fixes split into chains at gaps longer than `max_gap`.
fn chains_of(gnss: &[GnssFix], r: &[Option<Vector3<f64>>], max_gap: f64) -> Vec<Vec<usize>> {
    let mut chains: Vec<Vec<usize>> = Vec::new();
    let mut previous: Option<usize> = None;
    for (k, f) in gnss.iter().enumerate() {
        if r[k].is_none() {
            continue;
        }
        let h = previous.map(|p| f.time - gnss[p].time);
        match chains.last_mut() {
            Some(chain) if h.is_some_and(|h| h > 0.0 && h <= max_gap) => chain.push(k),
            _ => chains.push(vec![k]),
        }
        previous = Some(k);
    }
    chains
}

/// Within one chain: the offset of every fix (its steps summed), the level most fixes share (the GNSS is
/// right most of the time; a chain may start inside a fault, after an outage), and the runs of fixes away
/// from it by `min_step` or more, which are excluded and returned as episodes.
fn judge_chain(
    chain: &[usize],
    gnss: &[GnssFix],
    steps: &[Option<Vector3<f64>>],
    min_step: f64,
    last_chain: bool,
    excluded: &mut [bool],
) -> Vec<StepEpisode> {
    // Faults are transient offsets from one true level, so a step that lands within `min_step` of a level
    // seen before in the chain returns to it exactly: step estimates' errors do not pile up over a series
    // of faults. (Offsets are relative to the chain's first level, zero.)
    let mut offset = Vector3::zeros();
    let mut seen: Vec<Vector3<f64>> = vec![offset];
    let offsets: Vec<Vector3<f64>> = chain
        .iter()
        .map(|&k| {
            if let Some(step) = steps[k] {
                offset += step;
                let nearest = seen.iter().min_by(|a, b| (*a - offset).norm().total_cmp(&(*b - offset).norm()));
                match nearest {
                    Some(earlier) if (earlier - offset).norm() < min_step => offset = *earlier,
                    // A large step landing nearer the chain's first level than half its own length goes back
                    // to it: where fixes were set aside around an outlier, its return is estimated coarsely.
                    _ if offset.norm() < 0.5 * step.norm() => offset = Vector3::zeros(),
                    _ => seen.push(offset),
                }
            }
            offset
        })
        .collect();
    // Candidate levels: the offset of each segment's first fix.
    let sharing = |level: &Vector3<f64>| offsets.iter().filter(|o| (*o - level).norm() < min_step).count();
    let mut level = Vector3::zeros();
    let mut most = 0;
    for (i, o) in offsets.iter().enumerate() {
        if i == 0 || steps[chain[i]].is_some() {
            let n = sharing(o);
            if n > most {
                (level, most) = (*o, n);
            }
        }
    }
    let mut episodes: Vec<StepEpisode> = Vec::new();
    let mut open: Option<StepEpisode> = None;
    for (&k, o) in chain.iter().zip(&offsets) {
        let away = (o - level).norm() >= min_step;
        excluded[k] = away;
        match (&mut open, away) {
            (Some(e), true) => {
                e.fixes += 1;
                e.end = gnss[k].time;
            }
            (None, true) => {
                let d = o - level;
                let (step, ended) = ([d.x, d.y, d.z], EpisodeEnd::Data);
                open =
                    Some(StepEpisode { first_fix: k, fixes: 1, start: gnss[k].time, end: gnss[k].time, step, ended });
            }
            (Some(_), false) => {
                if let Some(mut e) = open.take() {
                    e.ended = EpisodeEnd::Returned;
                    episodes.push(e);
                }
            }
            (None, false) => {}
        }
    }
    if let Some(mut e) = open {
        e.ended = if last_chain { EpisodeEnd::Data } else { EpisodeEnd::Gap };
        episodes.push(e);
    }
    episodes
}

/// Three consecutive fixes of one unbroken chain.
#[derive(Clone, Copy, Debug)]
struct Triple {
    k0: usize,
    k1: usize,
    k: usize,
    h1: f64,
    h2: f64,
    /// Index of its chain.
    chain: usize,
}

impl Triple {
    fn e(&self, r: &[Option<Vector3<f64>>]) -> Vector3<f64> {
        let at = |i: usize| r[i].unwrap_or_default();
        (at(self.k) - at(self.k1)) / self.h2 - (at(self.k1) - at(self.k0)) / self.h1
    }
}

/// The triples of every chain in time order: three consecutive fixes of one chain each.
fn chain_triples(gnss: &[GnssFix], chains: &[Vec<usize>]) -> Vec<Triple> {
    let mut out = Vec::new();
    for (c, chain) in chains.iter().enumerate() {
        for w in chain.windows(3) {
            let (k0, k1, k) = (w[0], w[1], w[2]);
            let (h1, h2) = (gnss[k1].time - gnss[k0].time, gnss[k].time - gnss[k1].time);
            out.push(Triple { k0, k1, k, h1, h2, chain: c });
        }
    }
    out
}

/// 1.4826 × the median absolute value per axis (σ for normal data), floored at [`MIN_SCALE`].
fn robust_scale(values: &[Vector3<f64>]) -> Vector3<f64> {
    let mut scale = Vector3::repeat(MIN_SCALE);
    for axis in 0..3 {
        let mut a: Vec<f64> = values.iter().map(|v| v[axis].abs()).filter(|x| x.is_finite()).collect();
        if let Some(m) = plumbline_geo::metrics::median(&mut a) {
            scale[axis] = (1.4826 * m).max(MIN_SCALE);
        }
    }
    scale
}

/// The free inertial displacement at every epoch of a forward pass, with the attitude there.
struct FreeMotion {
    times: Vec<f64>,
    displacement: Vec<Vector3<f64>>,
    attitude: Vec<nalgebra::UnitQuaternion<f64>>,
}

impl FreeMotion {
    fn of(pass: &ForwardPass) -> Self {
        let n = pass.nominal.len();
        let mut times = Vec::with_capacity(n);
        let mut displacement = Vec::with_capacity(n);
        let mut attitude = Vec::with_capacity(n);
        let (mut v, mut p) = (Vector3::zeros(), Vector3::zeros());
        for (i, state) in pass.nominal.iter().enumerate() {
            times.push(state.time);
            displacement.push(p);
            attitude.push(state.attitude);
            if let Some(s) = pass.samples.get(i) {
                // The mechanisation's own velocity change over the sample (specific force, gravity, Coriolis),
                // from the corrected state at its start.
                let dv = state.propagate(s, &pass.config.earth).velocity - state.velocity;
                let next = v + dv;
                p += (v + next) * (0.5 * s.dt);
                v = next;
            }
        }
        Self { times, displacement, attitude }
    }

    /// Displacement (interpolated) and attitude (of the nearer epoch) at `time`; None outside the span.
    fn at(&self, time: f64) -> Option<(Vector3<f64>, nalgebra::UnitQuaternion<f64>)> {
        let (first, last) = (*self.times.first()?, *self.times.last()?);
        if !(time >= first && time <= last) {
            return None;
        }
        let i = self.times.partition_point(|&t| t <= time).clamp(1, self.times.len() - 1);
        let (t0, t1) = (self.times[i - 1], self.times[i]);
        let w = if t1 > t0 { (time - t0) / (t1 - t0) } else { 0.0 };
        let p = self.displacement[i - 1] * (1.0 - w) + self.displacement[i] * w;
        let attitude = if w < 0.5 { self.attitude[i - 1] } else { self.attitude[i] };
        Some((p, attitude))
    }
}
