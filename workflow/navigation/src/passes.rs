//! The forward pass as callers run it: plain, acting on its own tests, or with fixes decided out before;
//! where the IMU record has gaps, re-linearised around what the smoother found hidden in them.

use crate::NavError;
use crate::adaptive::{Adaptation, Monitor};
use crate::check_samples;
use crate::config::{InitialState, NavConfig};
use crate::filter::{ForwardPass, run_once};
use crate::gaps::{GapNoise, find_imu_gaps};
use crate::inputs::{GnssFix, ImuSample};
use crate::smoother::smooth_errors;
use crate::state::{ATT, BA, ErrVec, N};

/// Run the filter over `imu` (contiguous increments starting at `initial.time`) and `gnss` (time-sorted),
/// using every valid fix as it comes.
pub fn filter(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    initial: &InitialState,
    config: &NavConfig,
) -> Result<ForwardPass, NavError> {
    run_filter(imu, gnss, initial, config, None, &[])
}

/// The filter acting on its own tests (see the `adaptive` module): fixes the local test rejects are
/// excluded, and the covariances re-opened where the tests blame the IMU; each innovation carries the
/// [`Decision`](crate::Decision) taken.
pub fn filter_adaptive(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    initial: &InitialState,
    config: &NavConfig,
    adaptation: &Adaptation,
) -> Result<ForwardPass, NavError> {
    adaptation.check()?;
    run_filter(imu, gnss, initial, config, Some(Monitor::new(*adaptation)), &[])
}

/// Run the filter with the fixes `excluded` marks (by index into `gnss`; shorter than `gnss` means the rest
/// are not) left out: their innovations are recorded as [`Decision::Excluded`](crate::Decision::Excluded)
/// and nothing is updated. The step test ([`crate::screen_steps`]) decides them.
pub fn filter_excluding(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    initial: &InitialState,
    config: &NavConfig,
    excluded: &[bool],
) -> Result<ForwardPass, NavError> {
    run_filter(imu, gnss, initial, config, None, excluded)
}

/// The forward pass. Where the IMU has gaps it runs again, up to three times: a 15° turn hidden in a gap
/// is too large for the smoother's linear correction (over 400 m a heading error of 15° linearised is 14 m
/// off), so each further pass re-linearises — it shifts its nominal state at each gap's end by the motion
/// the previous smoothing found hidden there (the smoothed error at the end less the start's carried
/// through the gap). That motion's prior is the gap's loose process noise, so using the data again through
/// it changes the estimate by a negligible shrinkage.
fn run_filter(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    initial: &InitialState,
    config: &NavConfig,
    monitor: Option<Monitor>,
    excluded: &[bool],
) -> Result<ForwardPass, NavError> {
    let gaps = prepare(imu, initial, config)?;
    let mut pass = run_once(imu, gnss, initial, config, monitor.clone(), excluded, gaps.clone(), &[]);
    if gaps.gaps().is_empty() {
        return Ok(pass);
    }
    let mut corrections: Vec<(usize, ErrVec)> = Vec::new();
    for _ in 0..RELINEARISATIONS {
        // A pass the smoother cannot take is kept as it is.
        let Ok(found) = hidden_motion(&pass) else { break };
        let attitude = found.iter().map(|(_, dx)| dx.fixed_rows::<3>(ATT).norm()).fold(0.0, f64::max);
        corrections = if corrections.is_empty() {
            found
        } else {
            corrections.iter().zip(&found).map(|((k, a), (_, b))| (*k, a + b)).collect()
        };
        pass = run_once(imu, gnss, initial, config, monitor.clone(), excluded, gaps.clone(), &corrections);
        if attitude < LINEAR_ENOUGH {
            break;
        }
    }
    Ok(pass)
}

/// Check the inputs of a forward pass and find the IMU's gaps with the noise `config` gives them.
pub(crate) fn prepare(imu: &[ImuSample], initial: &InitialState, config: &NavConfig) -> Result<GapNoise, NavError> {
    config.check()?;
    initial.check()?;
    check_samples(imu, initial.time)?;
    Ok(GapNoise::new(config.gaps.map(|m| find_imu_gaps(imu, &m)).unwrap_or_default(), config.gaps))
}

/// Re-linearisations at most.
const RELINEARISATIONS: usize = 3;
/// A hidden rotation below this (rad, 0.5°) is linear enough: no further pass.
const LINEAR_ENOUGH: f64 = 0.009;

/// Per gap of `pass`: the sample it ends with, and the motion the smoother found hidden in it, x̂(end) −
/// Φ·x̂(start) (position, velocity and attitude; the biases and the GNSS error have no gap noise).
fn hidden_motion(pass: &ForwardPass) -> Result<Vec<(usize, ErrVec)>, NavError> {
    let gaps = pass.imu_gaps();
    let mut wanted: std::collections::HashMap<usize, ErrVec> = std::collections::HashMap::new();
    for g in gaps {
        wanted.insert(g.first, ErrVec::zeros());
        wanted.insert(g.last + 1, ErrVec::zeros());
    }
    smooth_errors(pass, |k, s, _| {
        if let Some(slot) = wanted.get_mut(&k) {
            *slot = *s;
        }
    })?;
    let tau = pass.config.imu.bias_correlation_time;
    let gnss_tau = pass.config.gnss_error_model().correlation_time;
    Ok(gaps
        .iter()
        .map(|g| {
            let mut carried = wanted[&g.first];
            for k in g.first..=g.last {
                carried = pass.nominal[k].transition(&pass.samples[k], tau, gnss_tau, &pass.config.earth) * carried;
            }
            let mut dx = wanted[&(g.last + 1)] - carried;
            dx.rows_mut(BA, N - BA).fill(0.0);
            (g.last, dx)
        })
        .collect())
}
