//! GNSS environments (open / urban / canyon) from the street's height-to-width ratio, and the error
//! parameters of each.

use serde::{Deserialize, Serialize};

/// Ratio (building height / street width) from which a street counts as urban.
pub const URBAN_RATIO: f64 = 0.3;
/// Ratio from which a street counts as a deep canyon.
pub const CANYON_RATIO: f64 = 1.0;

/// How much sky the GNSS antenna sees.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Environment {
    /// Ratio below [`URBAN_RATIO`]: open sky, no multipath faults.
    Open,
    /// Ratio in [[`URBAN_RATIO`], [`CANYON_RATIO`]): inner-city streets.
    Urban,
    /// Ratio [`CANYON_RATIO`] and above: deep urban canyons.
    Canyon,
}

impl Environment {
    /// The environment of a street with height-to-width `ratio`.
    pub fn of_ratio(ratio: f64) -> Self {
        if ratio >= CANYON_RATIO {
            Self::Canyon
        } else if ratio >= URBAN_RATIO {
            Self::Urban
        } else {
            Self::Open
        }
    }

    /// Index into per-environment tables.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Open => "open",
            Self::Urban => "urban",
            Self::Canyon => "canyon",
        }
    }
}

/// The error parameters of one environment. Metres, seconds, radians; σ per axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentParameters {
    /// Stationary σ of the slow horizontal drift (Gauss–Markov), per axis, m.
    pub drift_horizontal: f64,
    /// Stationary σ of the slow height drift, m (Cazzaniga et al. 2007 §1.2: ~40 cm in height).
    pub drift_height: f64,
    /// Stationary σ of the roll and pitch error, rad.
    pub drift_roll_pitch: f64,
    /// Stationary σ of the heading error, rad.
    pub drift_heading: f64,
    /// Rate at which multipath jumps begin, per second (0: never).
    pub jump_rate: f64,
    /// Smallest and largest horizontal jump size, m (log-uniform between them).
    pub jump_size: (f64, f64),
    /// Shortest and longest jump duration, s of driving (uniform; standing still stretches it, see module doc).
    pub jump_duration: (f64, f64),
    /// Rate at which GNSS outages begin, per second (0: never).
    pub outage_rate: f64,
    /// Mean outage duration per unit of height-to-width ratio, s (exponential; grows with the ratio).
    pub outage_seconds_per_ratio: f64,
    /// Horizontal σ the solution reports, per axis, m (realistic in the open, optimistic elsewhere).
    pub reported_horizontal: f64,
    /// Height σ the solution reports, m.
    pub reported_height: f64,
}

impl EnvironmentParameters {
    /// Open sky: only a centimetre-level drift; reported σ matches it
    /// (Grejner-Brzezinska and Toth 2000 §2.1: 1–4 cm, 5–10″).
    pub const OPEN: Self = Self {
        drift_horizontal: 0.015,
        drift_height: 0.03,
        drift_roll_pitch: 0.0015 * DEG,
        drift_heading: 0.003 * DEG,
        jump_rate: 0.0,
        jump_size: (0.1, 0.5),
        jump_duration: (3.0, 20.0),
        outage_rate: 0.0,
        outage_seconds_per_ratio: 10.0,
        reported_horizontal: 0.015,
        reported_height: 0.03,
    };

    /// Inner-city streets: jumps of decimetres for seconds (Cazzaniga et al. 2007 §1.2), short outages.
    pub const URBAN: Self = Self {
        drift_horizontal: 0.03,
        drift_height: 0.08,
        drift_roll_pitch: 0.0025 * DEG,
        drift_heading: 0.006 * DEG,
        jump_rate: 1.0 / 90.0,
        jump_size: (0.1, 0.5),
        jump_duration: (3.0, 20.0),
        outage_rate: 1.0 / 240.0,
        outage_seconds_per_ratio: 10.0,
        reported_horizontal: 0.02,
        reported_height: 0.035,
    };

    /// Deep canyons: frequent jumps of decimetres to metres lasting tens of seconds, longer outages.
    pub const CANYON: Self = Self {
        drift_horizontal: 0.05,
        drift_height: 0.15,
        drift_roll_pitch: 0.004 * DEG,
        drift_heading: 0.01 * DEG,
        jump_rate: 1.0 / 45.0,
        jump_size: (0.2, 1.5),
        jump_duration: (5.0, 40.0),
        outage_rate: 1.0 / 60.0,
        outage_seconds_per_ratio: 10.0,
        reported_horizontal: 0.025,
        reported_height: 0.04,
    };
}

const DEG: f64 = std::f64::consts::PI / 180.0;
