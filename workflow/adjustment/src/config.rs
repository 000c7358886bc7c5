//! Settings of the adjustment: node spacing, the DG random-walk model, the weak prior and its floor inside
//! possible DG faults, robust estimation and data snooping, standstills, jump localisation, kinematic jumps,
//! height biases and jump detection on the chain. Every settings type of the crate lives here, and this module
//! imports none of the others: the algorithm modules read their settings from it.

use serde::{Deserialize, Serialize};

/// How the DG trajectory's relative accuracy enters as constraints between consecutive nodes.
///
/// The DG error e(t) (position and attitude, per mapping-frame component) is modelled as a random walk
/// whose rate follows the DG standard deviation σ_DG: between nodes i and i+1
/// `Var(e_{i+1} − e_i) = Δt · (floor² + σ̄_DG² / correlation_time)`, σ̄_DG the mean of the two nodes' σ.
/// Where the DG solution says it is good the relative constraint is stiff; in GNSS outages (σ_DG grows)
/// it lets the correction bend. Attitude uses σ_roll/σ_pitch (RMS) about east and north and σ_heading about up.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RandomWalk {
    /// Position random-walk floor, m/√s.
    pub position_floor: f64,
    /// Attitude random-walk floor, rad/√s.
    pub attitude_floor: f64,
    /// Time over which the DG error decorrelates by about its own σ, seconds.
    pub correlation_time: f64,
}

impl Default for RandomWalk {
    fn default() -> Self {
        Self { position_floor: 0.002, attitude_floor: 2e-5, correlation_time: 10.0 }
    }
}

/// Data snooping (Baarda's w-test) settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Snooping {
    /// Critical value of the normalised residual |w| (3.29 ↔ α = 0.1 % two-sided).
    pub critical_value: f64,
    /// Per round, only the largest |w| within this many seconds of another rejection is rejected.
    pub window: f64,
    /// Upper bound on snooping rounds (each round re-adjusts).
    pub max_rounds: usize,
}

impl Default for Snooping {
    fn default() -> Self {
        Self { critical_value: 3.29, window: 10.0, max_rounds: 20 }
    }
}

/// All settings of [`crate::adjust`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AdjustmentConfig {
    /// Extra nodes every this many seconds besides the observation epochs (`None`: observation epochs only).
    pub node_spacing: Option<f64>,
    /// Observation epochs closer than this share a node, seconds.
    pub min_node_gap: f64,
    /// Relative constraints between consecutive nodes.
    pub random_walk: RandomWalk,
    /// Weak absolute prior at every node: σ = prior_scale · σ_DG.
    pub prior_scale: f64,
    /// The weak prior counts once per this many seconds of trajectory instead of once per node: a node's prior
    /// σ is scaled by √(prior_time / Δt), Δt the time the node stands for (half the span to its neighbours),
    /// never below `prior_scale` · σ_DG. The DG error is correlated over seconds, so independent priors at dense
    /// nodes would add up to a pull towards the DG that grows with the observation density. `None`: per node.
    #[serde(default = "default_prior_time")]
    pub prior_time: Option<f64>,
    /// DG standard deviations used where the trajectory has none: east, north, height (m), roll, pitch,
    /// heading (rad).
    pub default_std: [f64; 6],
    /// Huber threshold on the whitened residual norm of an observation (`None`: plain least squares).
    pub huber: Option<f64>,
    /// Data snooping after the robust solution (`None`: no snooping).
    pub snooping: Option<Snooping>,
    /// Largest number of Gauss–Newton/LM iterations per solve.
    pub max_iterations: usize,
    /// Converged when no update component exceeds this (metres / radians), or the objective drops by less
    /// than 1e-10 of itself.
    pub tolerance: f64,
    /// Floor on the weak prior's position σ between DG breaks close enough to be one jump (`None`: off).
    #[serde(default = "default_fault_prior")]
    pub fault_prior: Option<FaultPriorConfig>,
    /// Nodes inside flagged weak links and their weakening placed where the DG jumped (`None`: even).
    #[serde(default = "default_localization")]
    pub jump_localization: Option<JumpLocalizationConfig>,
    /// One 2-D nuisance offset per cadastre object observed more than once (prior σ = its `sigma_pole`), the
    /// updates then weighted with `sigma_camera` alone: they share the object's cadastre error, so they must
    /// not pull like independent control (`false`: every update weighted with Meyer et al. 2023 eq. (1)).
    #[serde(default = "default_true")]
    pub pole_offsets: bool,
    /// Standstill detection on the DG trajectory and zero-velocity constraints (`None`: off).
    #[serde(default = "default_standstill")]
    pub standstill: Option<StandstillConfig>,
    /// One height bias per aerial frame set listed in the observations (`None`: aerial heights independent).
    #[serde(default = "default_height_biases")]
    pub height_biases: Option<HeightBiasConfig>,
    /// Data snooping also tests the relative constraints' position rows and widens an inconsistent one as
    /// a DG jump the consistency check missed (`None`: only observations are tested).
    #[serde(default = "default_jump_detection")]
    pub jump_detection: Option<JumpDetectionConfig>,
    /// Nodes (and optionally weakened links) where the DG's own motion breaks the vehicle's kinematics, i.e.
    /// where it may have jumped unflagged (`None`: off).
    #[serde(default = "default_kinematic_jumps")]
    pub kinematic_jumps: Option<KinematicJumpConfig>,
}

fn default_kinematic_jumps() -> Option<KinematicJumpConfig> {
    Some(KinematicJumpConfig::default())
}

fn default_jump_detection() -> Option<JumpDetectionConfig> {
    Some(JumpDetectionConfig::default())
}

fn default_height_biases() -> Option<HeightBiasConfig> {
    Some(HeightBiasConfig::default())
}

fn default_fault_prior() -> Option<FaultPriorConfig> {
    Some(FaultPriorConfig::default())
}

fn default_localization() -> Option<JumpLocalizationConfig> {
    Some(JumpLocalizationConfig::default())
}

fn default_true() -> bool {
    true
}

fn default_prior_time() -> Option<f64> {
    None
}

fn default_standstill() -> Option<StandstillConfig> {
    Some(StandstillConfig::default())
}

impl Default for AdjustmentConfig {
    fn default() -> Self {
        Self {
            node_spacing: None,
            min_node_gap: 1e-3,
            random_walk: RandomWalk::default(),
            prior_scale: 10.0,
            prior_time: default_prior_time(),
            default_std: [0.05, 0.05, 0.08, 3e-4, 3e-4, 8e-4],
            huber: Some(2.0),
            snooping: Some(Snooping::default()),
            max_iterations: 20,
            tolerance: 1e-5,
            standstill: default_standstill(),
            pole_offsets: true,
            fault_prior: default_fault_prior(),
            jump_localization: default_localization(),
            height_biases: default_height_biases(),
            jump_detection: default_jump_detection(),
            kinematic_jumps: default_kinematic_jumps(),
        }
    }
}

/// Settings of standstill detection and of the zero-velocity constraint.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StandstillConfig {
    /// Spacing of the speed samples, seconds.
    pub sample_step: f64,
    /// Time over which each speed sample's displacement is taken, seconds.
    pub baseline: f64,
    /// Length of the centred window whose median speed decides, seconds (more than twice a jump's rise).
    pub window: f64,
    /// Median speed below which the vehicle stands still, m/s. Creeping at 0.1 m/s must stay above it:
    /// over 40 s it would move 4 m, which the constraint would pull the trajectory by.
    pub speed_threshold: f64,
    /// Shortest standstill used, seconds.
    pub min_duration: f64,
    /// σ of "corrected position at the end = at the start", per axis, metres.
    pub position_sigma: f64,
    /// σ of "corrected heading at the end = at the start" (the vertical rotation-vector component), radians.
    /// Roll and pitch are not constrained: the body settles on its suspension after braking.
    pub heading_sigma: f64,
    /// Factor on the σ of the DG relative constraints inside a standstill (> 1 weakens them, so the
    /// zero-velocity constraint replaces the DG's relative motion there rather than competing with it).
    pub chain_factor: f64,
    /// A weak link (flagged DG jump) containing a standstill over which the DG moves more than this many
    /// metres is taken as caused by that jump while standing and dropped: the zero-velocity constraint
    /// absorbs the jump, and the chain on either side stays stiff to hold the standstill in place.
    pub explained_above: f64,
}

impl Default for StandstillConfig {
    fn default() -> Self {
        Self {
            sample_step: 0.1,
            baseline: 0.5,
            window: 5.0,
            speed_threshold: 0.02,
            min_duration: 3.0,
            position_sigma: 0.005,
            heading_sigma: 1e-4,
            chain_factor: 10.0,
            explained_above: 0.05,
        }
    }
}

/// Settings of the prior floor inside possible DG faults.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FaultPriorConfig {
    /// Floor on the prior's position σ (east, north, up) inside a possible fault, metres: the size of the jumps
    /// to expect (Cazzaniga et al. 2007 §1.2: "tens of cm and more").
    pub sigma: f64,
    /// Longest span between two breaks taken as one fault, seconds (a jump persists longer at low speed).
    pub max_duration: f64,
}

impl Default for FaultPriorConfig {
    fn default() -> Self {
        Self { sigma: 1.0, max_duration: 120.0 }
    }
}

/// Settings of jump localisation inside flagged intervals.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JumpLocalizationConfig {
    /// Node spacing inside a flagged interval, seconds.
    pub step: f64,
    /// Length of the centred window of the median velocity, seconds (more than twice a jump's rise).
    pub window: f64,
    /// σ added to a sub-interval's position constraint per metre of anomalous DG motion in it.
    pub anomaly_scale: f64,
}

impl Default for JumpLocalizationConfig {
    fn default() -> Self {
        Self { step: 0.2, window: 3.0, anomaly_scale: 2.0 }
    }
}

/// Settings of the search for DG jumps in the DG's own motion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct KinematicJumpConfig {
    /// Node spacing over an anomalous span, seconds.
    pub step: f64,
    /// Sideways displacement per `step` above which a span gets nodes, metres.
    pub threshold: f64,
    /// Let the links of anomalous spans follow the vehicle's kinematics (mean −d of their sideways
    /// displacement d, σ² = σ_DG² + (anomaly_scale · |d|)²), and count the spans as DG breaks.
    pub widen: bool,
    /// σ added per metre of sideways displacement when widening.
    pub anomaly_scale: f64,
    /// Estimate the crab angle (the heading's misalignment with the direction of travel) over the drive and
    /// take the sideways motion relative to it; `false`: the heading is the direction of travel.
    #[serde(default = "default_true")]
    pub crab: bool,
}

impl Default for KinematicJumpConfig {
    fn default() -> Self {
        Self { step: 0.2, threshold: 0.01, widen: true, anomaly_scale: 2.0, crab: true }
    }
}

/// Settings of the height biases.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HeightBiasConfig {
    /// Prior σ of a set's bias as a multiple of its median triangulated height σ.
    pub prior_scale: f64,
}

impl Default for HeightBiasConfig {
    fn default() -> Self {
        Self { prior_scale: 1.0 }
    }
}

/// Settings of jump detection on the chain.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JumpDetectionConfig {
    /// Largest σ a widened link's position constraint gets, metres: the size of the DG jumps to expect.
    pub sigma: f64,
}

impl Default for JumpDetectionConfig {
    fn default() -> Self {
        Self { sigma: 1.0 }
    }
}
