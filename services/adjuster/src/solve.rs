//! The global adjustment of a campaign: the consistency check's weak links, the adjustment (standstills
//! detected in the DG trajectory inside it), and the corrected full-rate trajectory.

use std::time::Instant;

use plumbline_adjustment::{
    Adjustment, AdjustmentError, AdjustmentInput, Iteration, RelativeMotion, WeakLink, adjust_observed,
};
use plumbline_geo::dg::CameraMount;
use plumbline_geo::{Trajectory, TrajectoryError};
use plumbline_navigation::{ConsistencyReport, NavError, check_consistency};

use crate::config::AdjusterConfig;
use crate::merge::Merged;

/// Why the adjustment of a campaign failed as a whole (single bad observations are skipped instead).
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// The consistency check's settings are invalid.
    #[error("consistency check: {0}")]
    Consistency(#[from] NavError),
    /// The adjustment's linear algebra failed.
    #[error("adjustment: {0}")]
    Adjustment(#[from] AdjustmentError),
    /// The corrections gave an invalid trajectory.
    #[error("corrected trajectory: {0}")]
    Apply(#[from] TrajectoryError),
}

/// As a service error: invalid settings of the consistency check are the manifest's; the rest fails the
/// campaign.
impl From<SolveError> for plumbline_runtime::Error {
    fn from(e: SolveError) -> Self {
        let kind = match e {
            SolveError::Consistency(_) => plumbline_runtime::ErrorKind::Invalid,
            SolveError::Adjustment(_) | SolveError::Apply(_) => plumbline_runtime::ErrorKind::Internal,
        };
        Self::from_cause(kind, e)
    }
}

/// The adjusted campaign.
#[derive(Clone, Debug)]
pub struct Solved {
    /// The consistency check of image motions against the DG trajectory.
    pub consistency: ConsistencyReport,
    /// The weak links handed to the adjustment.
    pub weak_links: Vec<WeakLink>,
    /// The adjustment's result.
    pub adjustment: Adjustment,
    /// The corrected trajectory, one record per DG record.
    pub corrected: Trajectory,
    /// Wall time of the check, the adjustment and applying it, seconds.
    pub seconds: f64,
}

/// Check the DG trajectory against the image motions (Cazzaniga et al. 2007 §4), weaken the flagged links, adjust
/// (standstills as `config.standstills` says, the image motions as relative observations when
/// `config.image_motions`) on rayon, and apply the corrections to every record.
pub fn solve(
    trajectory: &Trajectory,
    merged: &Merged,
    mount: &CameraMount,
    config: &AdjusterConfig,
) -> Result<Solved, SolveError> {
    solve_observed(trajectory, merged, mount, config, &mut |_| {})
}

/// [`solve`], reporting each Gauss–Newton/LM iteration of the adjustment to `observer` as it ends.
pub fn solve_observed(
    trajectory: &Trajectory,
    merged: &Merged,
    mount: &CameraMount,
    config: &AdjusterConfig,
    observer: &mut dyn FnMut(&Iteration),
) -> Result<Solved, SolveError> {
    let start = Instant::now();
    let consistency = check_consistency(trajectory, &merged.motions, &config.consistency)?;
    let weak_links = consistency.weak_links();
    let mut observations = merged.observations.clone();
    if config.image_motions {
        observations.motions = merged.motions.iter().copied().map(RelativeMotion::from).collect();
    }
    let input = AdjustmentInput { trajectory, observations: &observations, mount, weak_links: &weak_links };
    let adjustment = adjust_observed(&input, &config.adjustment(), faer::Par::rayon(0), observer)?;
    let corrected = adjustment.apply(trajectory)?;
    Ok(Solved { consistency, weak_links, adjustment, corrected, seconds: start.elapsed().as_secs_f64() })
}

/// The panorama camera's mount of a manifest (`panoramas.mount`; none: at the body origin, unrotated).
pub fn panorama_mount(manifest: &plumbline_campaign::ManifestV1) -> CameraMount {
    let Some(p) = &manifest.panoramas else {
        return CameraMount::new([0.0; 3], &plumbline_geo::dg::Boresight::default());
    };
    let [r, pitch, y] = p.mount.boresight_deg;
    CameraMount::new(p.mount.lever_arm_m, &plumbline_geo::dg::Boresight::from_degrees(r, pitch, y))
}
