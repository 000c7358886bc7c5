//! The consistency check of the DG trajectory's relative motion against the image-derived motion between
//! consecutive panoramas (Cazzaniga et al. 2007 §4.1, Jende et al. 2017 §3.3): where they disagree beyond their
//! combined precision, the DG solution jumped, and the adjustment's relative constraints there are weakened.
//!
//! The image side is the transformation between the ortho-projected neighbouring panoramas (Jende et al. 2017
//! §3.3): a ground-plane displacement of the body origin and a heading change, with their σ. The DG side is
//! the same motion read off the trajectory, with the σ of its relative accuracy between close epochs.
//! Their difference d is tested with the overall χ² test T = Σ d_i² / (σ_img,i² + σ_dg,i²) against
//! χ²_{3,α} (Cazzaniga et al. 2007 §3.1.2 applied to the photogrammetric innovation of §4.1).

use plumbline_adjustment::WeakLink;
use plumbline_geo::angle::wrap;
use plumbline_geo::{PositionInterpolation, Trajectory};
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::chi2::chi2_critical;

/// The motion between two consecutive panoramas as the images measured it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct ImageMotion {
    /// Exposure time of the first panorama, s.
    pub start: f64,
    /// Exposure time of the second panorama, s.
    pub end: f64,
    /// Displacement of the body origin east and north, m.
    pub displacement: [f64; 2],
    /// Heading change (clockwise from north, Applanix), rad.
    pub heading_change: f64,
    /// σ of east, north displacement (m) and heading change (rad).
    pub std: [f64; 3],
}

impl From<ImageMotion> for plumbline_adjustment::RelativeMotion {
    /// The same motion as the adjustment's relative observation.
    fn from(m: ImageMotion) -> Self {
        let ImageMotion { start, end, displacement, heading_change, std } = m;
        Self { start, end, displacement, heading_change, std }
    }
}

/// Parameters of the check.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ConsistencyConfig {
    /// Significance level of the χ² test.
    pub alpha: f64,
    /// σ of the DG trajectory's relative motion between consecutive panoramas: east, north (m), heading (rad).
    pub dg_relative_std: [f64; 3],
    /// Factor on the relative constraint's σ over a flagged interval (> 1 weakens).
    pub weak_factor: f64,
}

impl Default for ConsistencyConfig {
    fn default() -> Self {
        Self { alpha: 0.001, dg_relative_std: [0.005, 0.005, 2e-4], weak_factor: 100.0 }
    }
}

/// One pair whose DG and image motions disagree.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct ConsistencyFlag {
    /// Index of the pair in the input.
    pub pair: usize,
    /// Image − DG: east, north (m), heading change (rad).
    pub discrepancy: [f64; 3],
    /// The χ² statistic.
    pub statistic: f64,
    /// χ²_{3,α}.
    pub critical: f64,
    /// The weakened interval for the adjustment.
    pub link: WeakLink,
}

/// What the check found: flagged pairs and pairs it could not test (with the reason).
#[derive(Clone, Debug, PartialEq)]
pub struct ConsistencyReport {
    /// Pairs that failed the test.
    pub flags: Vec<ConsistencyFlag>,
    /// Pairs that could not be tested.
    pub skipped: Vec<(usize, NavError)>,
}

impl ConsistencyReport {
    /// The weak links to hand to the adjustment.
    pub fn weak_links(&self) -> Vec<WeakLink> {
        self.flags.iter().map(|f| f.link).collect()
    }
}

/// Test every pair of `motions` against the DG trajectory `dg`.
pub fn check_consistency(
    dg: &Trajectory,
    motions: &[ImageMotion],
    config: &ConsistencyConfig,
) -> Result<ConsistencyReport, NavError> {
    if !(config.alpha > 0.0 && config.alpha < 1.0) {
        return Err(NavError::Config { field: "consistency.alpha", value: config.alpha, expected: "in (0, 1)" });
    }
    if !(config.weak_factor.is_finite() && config.weak_factor >= 1.0) {
        let value = config.weak_factor;
        return Err(NavError::Config { field: "consistency.weak_factor", value, expected: "a finite number >= 1" });
    }
    let critical = chi2_critical(3.0, config.alpha);
    let mut report = ConsistencyReport { flags: Vec::new(), skipped: Vec::new() };
    for (pair, m) in motions.iter().enumerate() {
        match test_pair(dg, pair, m, config) {
            Ok((discrepancy, statistic)) if statistic >= critical => {
                let link = WeakLink { start: m.start, end: m.end, factor: config.weak_factor };
                report.flags.push(ConsistencyFlag { pair, discrepancy, statistic, critical, link });
            }
            Ok(_) => {}
            Err(e) => report.skipped.push((pair, e)),
        }
    }
    Ok(report)
}

/// The discrepancy of one pair and its χ² statistic.
fn test_pair(
    dg: &Trajectory,
    pair: usize,
    m: &ImageMotion,
    config: &ConsistencyConfig,
) -> Result<([f64; 3], f64), NavError> {
    let bad = |field, value, expected| NavError::Pair { index: pair, field, value, expected };
    let finite = [("start", m.start), ("end", m.end), ("displacement[0]", m.displacement[0])];
    let finite =
        finite.into_iter().chain([("displacement[1]", m.displacement[1]), ("heading_change", m.heading_change)]);
    for (field, value) in finite {
        if !value.is_finite() {
            return Err(bad(field, value, "finite"));
        }
    }
    for (field, value) in [("std[east]", m.std[0]), ("std[north]", m.std[1]), ("std[heading]", m.std[2])] {
        if !(value.is_finite() && value > 0.0) {
            return Err(bad(field, value, "a finite σ > 0"));
        }
    }
    if m.end <= m.start {
        return Err(bad("end", m.end, "after start"));
    }
    let at = |t: f64| {
        dg.interpolate(t, PositionInterpolation::Cubic).map_err(|_| bad("start/end", t, "inside the DG trajectory"))
    };
    let (a, b) = (at(m.start)?, at(m.end)?);
    let d = b.position - a.position;
    let turn = wrap(b.attitude.heading - a.attitude.heading);
    let disc = [m.displacement[0] - d.x(), m.displacement[1] - d.y(), wrap(m.heading_change - turn)];
    // Cazzaniga et al. 2007 §3.1.2: T = vᵀ C_v⁻¹ v with C_v = C_img + C_dg (independent, diagonal)
    let statistic = (0..3).map(|i| disc[i].powi(2) / (m.std[i].powi(2) + config.dg_relative_std[i].powi(2))).sum();
    Ok((disc, statistic))
}
