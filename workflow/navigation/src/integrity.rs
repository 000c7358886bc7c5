//! Innovation-based integrity tests (Cazzaniga et al. 2007 §3.1.2): local overall χ² test, local slippage test, and
//! their global versions over a moving window of N epochs.
//!
//! The slippage tests blame one component of the GNSS fix (east, north or up): the one with the largest
//! statistic. With GNSS and an IMU alone a failure cannot be pinned on either sensor for certain (Cazzaniga et al. 2007
//! §3.2); a jump in the fixes shows as an abrupt local rejection, an IMU bias step as a slow growth the
//! global tests catch first. Each flag names the sensor that pattern points to ([`Sensor`]): a local
//! rejection is *abrupt* when its innovation also differs significantly from the mean innovation of the
//! preceding window (χ²₃ test of v_k − v̄ with C_v,k + C̄/N) — a jump, blamed on GNSS; a local rejection
//! that continues the preceding trend, and a global rejection whose window holds no abrupt one, blame the
//! IMU (a drift the prediction model does not know).

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::chi2::chi2_critical;
use crate::filter::Innovation;

/// Which test rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum TestKind {
    /// T_k = vᵀ C_v⁻¹ v against χ²_{n,α}.
    LocalOverall,
    /// t_{k,i} = (c_iᵀ C_v⁻¹ v)² / (C_v⁻¹)_ii against χ²_{1,α}.
    LocalSlippage,
    /// Σ T_j over the window against χ²_{N,α}, N the sum of the dimensions.
    GlobalOverall,
    /// (Σ c_iᵀ C_v⁻¹ v_j)² / Σ (C_v⁻¹)_ii over the window against χ²_{1,α}.
    GlobalSlippage,
}

/// The component of the GNSS fix a slippage test blames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Component {
    /// GNSS easting.
    GnssEast,
    /// GNSS northing.
    GnssNorth,
    /// GNSS height.
    GnssUp,
}

/// The sensor a flag blames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Sensor {
    /// The GNSS fixes (abrupt disagreement).
    Gnss,
    /// The IMU (a slow trend only the global tests see).
    Imu,
}

const COMPONENTS: [Component; 3] = [Component::GnssEast, Component::GnssNorth, Component::GnssUp];

/// Parameters of the tests.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct IntegrityConfig {
    /// Significance level α of every test (false-alarm probability per test).
    pub alpha: f64,
    /// Epochs in the moving window of the global tests (≥ 1).
    pub window: usize,
}

impl Default for IntegrityConfig {
    fn default() -> Self {
        Self { alpha: 0.001, window: 25 }
    }
}

/// One rejection.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Flag {
    /// Time of the (last) innovation tested, s.
    pub time: f64,
    /// Index of that fix in the GNSS input.
    pub fix: usize,
    /// Time of the first innovation in the window (equal to `time` for local tests), s.
    pub window_start: f64,
    /// The test that rejected.
    pub test: TestKind,
    /// Its statistic.
    pub statistic: f64,
    /// The critical value it exceeded.
    pub critical: f64,
    /// The blamed component (slippage tests only).
    pub component: Option<Component>,
    /// The blamed sensor.
    pub sensor: Sensor,
}

/// Every rejection of the four tests over `innovations` (time order), sorted by time then test.
pub fn test_innovations(innovations: &[Innovation], config: &IntegrityConfig) -> Result<Vec<Flag>, NavError> {
    if !(config.alpha > 0.0 && config.alpha < 1.0) {
        return Err(NavError::Config { field: "integrity.alpha", value: config.alpha, expected: "in (0, 1)" });
    }
    if config.window == 0 {
        return Err(NavError::Config { field: "integrity.window", value: 0.0, expected: ">= 1 epoch" });
    }
    let parts: Vec<Parts> = innovations.iter().map(Parts::of).collect();
    let c1 = chi2_critical(1.0, config.alpha);
    let c3 = chi2_critical(3.0, config.alpha);
    let cn = chi2_critical(3.0 * config.window as f64, config.alpha);
    let abrupt = abrupt_rejections(innovations, &parts, config.window, c1, c3);
    let mut flags = Vec::new();
    for (k, (inn, p)) in innovations.iter().zip(&parts).enumerate() {
        let in_window = abrupt[(k + 1).saturating_sub(config.window)..=k].iter().any(|a| *a);
        let flag = |test, statistic, critical, component, start: f64| Flag {
            time: inn.time,
            fix: inn.fix,
            window_start: start,
            test,
            statistic,
            critical,
            component,
            sensor: match test {
                TestKind::LocalOverall | TestKind::LocalSlippage if abrupt[k] => Sensor::Gnss,
                TestKind::GlobalOverall | TestKind::GlobalSlippage if in_window => Sensor::Gnss,
                _ => Sensor::Imu,
            },
        };
        // Cazzaniga et al. 2007 §3.1.2, local overall test
        if p.nis >= c3 {
            flags.push(flag(TestKind::LocalOverall, p.nis, c3, None, inn.time));
        }
        // Cazzaniga et al. 2007 §3.1.2, local slippage test
        let (i, t) = largest(&p.weighted, &p.inv_diag);
        if t >= c1 {
            flags.push(flag(TestKind::LocalSlippage, t, c1, Some(COMPONENTS[i]), inn.time));
        }
        if k + 1 >= config.window {
            let w = &parts[k + 1 - config.window..=k];
            let start = innovations[k + 1 - config.window].time;
            // Cazzaniga et al. 2007 §3.1.2, global overall test
            let total: f64 = w.iter().map(|p| p.nis).sum();
            if total >= cn {
                flags.push(flag(TestKind::GlobalOverall, total, cn, None, start));
            }
            // Cazzaniga et al. 2007 §3.1.2, global slippage test
            let num: Vector3<f64> = w.iter().map(|p| p.weighted).sum();
            let den: Vector3<f64> = w.iter().map(|p| p.inv_diag).sum();
            let (i, t) = largest(&num, &den);
            if t >= c1 {
                flags.push(flag(TestKind::GlobalSlippage, t, c1, Some(COMPONENTS[i]), start));
            }
        }
    }
    Ok(flags)
}

/// Whether each innovation is a local rejection that breaks with the preceding `window` innovations.
fn abrupt_rejections(innovations: &[Innovation], parts: &[Parts], window: usize, c1: f64, c3: f64) -> Vec<bool> {
    (0..innovations.len())
        .map(|k| {
            let p = &parts[k];
            if p.nis < c3 && largest(&p.weighted, &p.inv_diag).1 < c1 {
                return false;
            }
            let before = &innovations[k.saturating_sub(window)..k];
            if before.is_empty() {
                return true;
            }
            let n = before.len() as f64;
            let mean: Vector3<f64> = before.iter().map(|i| i.residual).sum::<Vector3<f64>>() / n;
            let cov: Matrix3<f64> = before.iter().map(|i| i.covariance).sum::<Matrix3<f64>>() / (n * n);
            let d = innovations[k].residual - mean;
            let c = innovations[k].covariance + cov;
            c.try_inverse().is_none_or(|inv| d.dot(&(inv * d)) >= c3)
        })
        .collect()
}

/// The per-innovation pieces: normalised innovation squared, C_v⁻¹ v and diag(C_v⁻¹).
struct Parts {
    nis: f64,
    weighted: Vector3<f64>,
    inv_diag: Vector3<f64>,
}

impl Parts {
    fn of(inn: &Innovation) -> Self {
        let inv = inn.covariance.try_inverse().unwrap_or_else(Matrix3::zeros);
        let weighted = inv * inn.residual;
        Self { nis: inn.residual.dot(&weighted), weighted, inv_diag: inv.diagonal() }
    }
}

/// The component with the largest slippage statistic (num_i² / den_i).
fn largest(num: &Vector3<f64>, den: &Vector3<f64>) -> (usize, f64) {
    (0..3)
        .map(|i| (i, if den[i] > 0.0 { num[i] * num[i] / den[i] } else { 0.0 }))
        .fold((0, f64::NEG_INFINITY), |best, c| if c.1 > best.1 { c } else { best })
}
