//! Global trajectory adjustment: sparse least squares with control, robust estimation and data snooping.
//!
//! ```text
//! AdjustmentInput { DG trajectory, ObservationSet (ties, poles, GNSS, motions), weak links, frame sets }
//!   → build: nodes, DG chain (jumps localised, standstills), observations linearised → problem
//!   → lm: Levenberg–Marquardt + Huber IRLS on the sparse normal matrix (faer Cholesky)
//!   → snooping: Baarda's w-test, reject or widen, re-solve until nothing is left
//!   → Adjustment (node corrections with covariances, points, rejections, biases) → apply(full-rate trajectory)
//! ```
//!
//! - **Unknowns**: pose corrections [δp; δθ] (position, small-angle rotation vector in the mapping frame,
//!   R' = Exp(δθ) R) at node epochs — the observation epochs, weak-link boundaries, the trajectory ends and
//!   optional regular spacing — linearly interpolated in between; plus the coordinates of tie points.
//! - **DG model**: random-walk constraints between consecutive nodes whose strength follows the DG σ
//!   ([`RandomWalk`]), weakened over flagged intervals ([`WeakLink`]) — with nodes inside, and where the DG's
//!   motion departs from the vehicle's reference motion (in the vehicle's own frame: along the heading, across
//!   it beyond the drive's crab angle, up), i.e. where it jumped, the links follow the reference motion (mean
//!   −anomaly) with σ widened by the anomaly ([`JumpLocalizationConfig`]) — and a weak absolute
//!   prior per node, floored between DG breaks close enough to be one jump ([`FaultPriorConfig`]): there the DG's
//!   own σ says nothing about its offset.
//! - **Cadastre objects**: the pole updates of one object share its cadastre error; an object seen more than
//!   once gets a 2-D nuisance offset with prior σ_pole, its updates keep σ_cam (Meyer et al. 2023 eq. (1) split).
//! - **Observations** ([`ObservationSet`]): pole CUPTs (2D), GNSS positions (3D, with antenna lever arm),
//!   tie rays (spherical collinearity through [`plumbline_geo::dg::CameraMount`]), aerial coordinates, and
//!   the image-derived motion between consecutive panoramas ([`RelativeMotion`]: east/north displacement and
//!   heading change between two node epochs, independent of the DG, so it bridges a DG jump; rejected ones
//!   in [`Adjustment::rejected_motions`]).
//! - **Aerial frame sets** ([`AerialFrameSet`]): the aerial heights triangulated from the same frames share
//!   one height bias, a nuisance parameter with a prior as large as one point's height σ ([`HeightBiasConfig`]),
//!   estimated jointly and reported ([`Adjustment::height_biases`]).
//! - **Standstills** ([`detect_standstills`]): where the DG trajectory says the vehicle stands still, the
//!   corrected pose at the end equals the one at the start (a zero-velocity constraint, robust-weighted and
//!   snooped like any observation) instead of following the DG's relative motion, so a DG jump while
//!   standing is absorbed into the correction; [`Adjustment::apply`] holds the pose over the accepted ones.
//! - **Jumps seen in the DG's own motion** ([`KinematicJumpConfig`]): where the DG moves sideways (a car moves
//!   along its heading, up to the crab angle estimated over the drive), it jumped; those spans get nodes every
//!   0.2 s, links that cancel the sideways motion (mean and σ from it), and count as DG breaks for the prior's
//!   floor — so a jump no image pair flagged is resolved where it rose.
//! - **Jumps the consistency check missed** ([`JumpDetectionConfig`]): snooping tests the relative constraints'
//!   position rows too; an inconsistent one is widened as a DG jump ([`Adjustment::jumps`]) instead of the
//!   control after it being rejected one by one.
//! - **Solver**: Levenberg–Marquardt with Huber IRLS; the normal matrix is assembled straight into
//!   compressed-column form; faer's simplicial sparse Cholesky with AMD on the block graph, symbolic
//!   factorisation once and reused. Then Baarda data snooping (w-test with redundancy numbers from Q_vv's
//!   diagonal) and posterior covariances, both from the selected inverse of the normal matrix (Takahashi
//!   recurrences on the factor's pattern).
//! - **Output** ([`Adjustment`]): node corrections with covariances, tie points, rejected and skipped
//!   observations, standstills with their fate ([`Adjustment::rejected_standstills`]), height biases,
//!   variance factors, timings; every iteration reported as it ends with [`adjust_observed`] ([`Iteration`]); [`Adjustment::apply`] corrects a full-rate trajectory.
//!   A tie point that snooping leaves undetermined (no aerial coordinates, fewer than two rays) is rejected
//!   whole. [`export`] writes the chain and pole CUPTs as plain data for the GTSAM comparison bench.
//!
//! Modules, bottom-up (each imports only modules listed before it):
//! - `config` (every settings type), `observations` (the input types), `so3`, `pattern`, `parallel`, `faults`;
//! - `model` (the observation models), `nodes` (node epochs, [`WeakLink`]), `standstill`, `solver`, `vehicle`;
//! - `problem`: the internal problem's plain types (input, internal observations, the assembled problem and
//!   its parameter layout, DG pose and node helpers); it imports no algorithm module;
//! - the algorithms on it: `relative`, `offsets`, `heights`, `normal`, `jumps`, `kinematics`, `localize`;
//! - `chain` (the DG chain, driving `kinematics`, `localize` and `faults`), `lm`, `stats`;
//! - `build` (assembles a `problem`, driving `relative`, `offsets`, `heights`, `standstill` and `chain`);
//! - `adjust` and `export`, then `apply`.

mod adjust;
mod apply;
mod build;
mod chain;
mod config;
mod export;
mod faults;
mod heights;
mod jumps;
mod kinematics;
mod lm;
mod localize;
mod model;
mod nodes;
mod normal;
mod observations;
mod offsets;
mod parallel;
mod pattern;
mod problem;
mod relative;
mod so3;
mod solver;
mod standstill;
mod stats;
mod vehicle;

pub use adjust::{
    AdjustedPoint, Adjustment, AdjustmentError, NodeCorrection, RejectedMotion, RejectedObservation,
    RejectedStandstill, StandstillOutcome, adjust, adjust_observed,
};
pub use config::{
    AdjustmentConfig, FaultPriorConfig, HeightBiasConfig, JumpDetectionConfig, JumpLocalizationConfig,
    KinematicJumpConfig, RandomWalk, Snooping, StandstillConfig,
};
pub use export::{ExportedNode, ExportedPole, ExportedProblem, export};
pub use heights::HeightBias;
pub use jumps::DetectedJump;
pub use lm::Iteration;
pub use nodes::WeakLink;
pub use observations::{
    AerialFrameSet, AerialPoint, GnssPosition, MotionError, ObservationError, ObservationRef, ObservationSet,
    ObservationSetV1, PoleUpdate, RelativeMotion, TiePoint, TiePointId, TieRay,
};
pub use problem::AdjustmentInput;
pub use solver::{SolverError, SolverTimings};
pub use standstill::{Standstill, detect_standstills};
pub use stats::VarianceFactors;
