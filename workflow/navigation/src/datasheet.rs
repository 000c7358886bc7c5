//! IMU error models as datasheets state them (°/h, °/√h, mg, µg, m/s/√h, ppm), presets by class, and their
//! conversion to the filter's SI model ([`ImuModel`]).
//!
//! A datasheet's "bias instability" (the Allan-deviation floor) is taken as the σ of a first-order
//! Gauss–Markov bias with the stated correlation time; its turn-on bias (run-to-run repeatability) as the
//! initial σ of the bias states. Scale-factor errors are not states of the filter: the accelerometers'
//! error on gravity (the one specific force always present) joins their turn-on bias; the gyros' scale
//! factor is kept with the datasheet but not modelled (150 ppm of a 90° turn is 0.01°).

use std::fmt;
use std::str::FromStr;

use plumbline_geo::metrics::median;
use serde::{Deserialize, Serialize};

use crate::NavError;
use crate::config::{ImuModel, STANDARD_GRAVITY};
use crate::inputs::ImuSample;

const DEG: f64 = std::f64::consts::PI / 180.0;
const HOUR: f64 = 3600.0;
/// √(s per hour): a figure per √h is this many times smaller per √s.
const SQRT_HOUR: f64 = 60.0;

/// The classes of IMU the presets stand for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ImuClass {
    /// Navigation grade (ring-laser gyros; LN-100 class, the simulator's IMU).
    Navigation,
    /// Tactical grade (fibre-optic or small ring-laser gyros; HG1700 / LN-200 class): the default.
    Tactical,
    /// Industrial MEMS (ADIS16490 / STIM300 class).
    Industrial,
    /// Consumer MEMS (BMI160 class, as in phones and action cameras).
    Consumer,
}

impl ImuClass {
    /// Every class, best first.
    pub const ALL: [Self; 4] = [Self::Navigation, Self::Tactical, Self::Industrial, Self::Consumer];

    /// The class's name as the command line and files spell it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Navigation => "navigation",
            Self::Tactical => "tactical",
            Self::Industrial => "industrial",
            Self::Consumer => "consumer",
        }
    }

    /// Typical 1σ figures of the class.
    pub fn datasheet(self) -> ImuDatasheet {
        match self {
            // Litton LN-100 (the figures quoted in Grejner-Brzezinska and Toth 2000; the simulator's IMU).
            Self::Navigation => ImuDatasheet {
                gyro_bias_deg_per_h: 0.003,
                gyro_bias_instability_deg_per_h: 0.001,
                angle_random_walk_deg_per_sqrt_h: 0.001,
                gyro_scale_factor_ppm: 5.0,
                accel_bias_mg: 0.025,
                accel_bias_instability_ug: 5.0,
                velocity_random_walk_m_per_s_per_sqrt_h: 5e-6 * STANDARD_GRAVITY * SQRT_HOUR,
                accel_scale_factor_ppm: 50.0,
                bias_correlation_time_s: 3600.0,
            },
            // Honeywell HG1700 class: 1 °/h gyro bias, 0.125 °/√h ARW, 1 mg accelerometer bias.
            Self::Tactical => ImuDatasheet {
                gyro_bias_deg_per_h: 1.0,
                gyro_bias_instability_deg_per_h: 0.35,
                angle_random_walk_deg_per_sqrt_h: 0.125,
                gyro_scale_factor_ppm: 150.0,
                accel_bias_mg: 1.0,
                accel_bias_instability_ug: 50.0,
                velocity_random_walk_m_per_s_per_sqrt_h: 0.05,
                accel_scale_factor_ppm: 300.0,
                bias_correlation_time_s: 1800.0,
            },
            // ADIS16490 / STIM300 class: in-run stability under 2 °/h, ARW 0.1–0.2 °/√h.
            Self::Industrial => ImuDatasheet {
                gyro_bias_deg_per_h: 10.0,
                gyro_bias_instability_deg_per_h: 2.0,
                angle_random_walk_deg_per_sqrt_h: 0.2,
                gyro_scale_factor_ppm: 500.0,
                accel_bias_mg: 2.0,
                accel_bias_instability_ug: 50.0,
                velocity_random_walk_m_per_s_per_sqrt_h: 0.08,
                accel_scale_factor_ppm: 1000.0,
                bias_correlation_time_s: 600.0,
            },
            // Bosch BMI160 datasheet: zero-rate offset ±3 °/s and zero-g offset ±40 mg as 3σ, noise densities
            // 0.007 °/s/√Hz and 180 µg/√Hz, sensitivity tolerance ±1 % as 3σ; bias instability 10 °/h and
            // 0.1 mg over 5 min (typical MEMS; not in the datasheet).
            Self::Consumer => ImuDatasheet {
                gyro_bias_deg_per_h: 1.0 * HOUR,
                gyro_bias_instability_deg_per_h: 10.0,
                angle_random_walk_deg_per_sqrt_h: 0.007 * SQRT_HOUR,
                gyro_scale_factor_ppm: 1e4 / 3.0,
                accel_bias_mg: 40.0 / 3.0,
                accel_bias_instability_ug: 100.0,
                velocity_random_walk_m_per_s_per_sqrt_h: 180e-6 * STANDARD_GRAVITY * SQRT_HOUR,
                accel_scale_factor_ppm: 1e4 / 3.0,
                bias_correlation_time_s: 300.0,
            },
        }
    }
}

impl fmt::Display for ImuClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ImuClass {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL.into_iter().find(|c| c.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|c| c.name()).collect();
            format!("unknown IMU class `{s}`; expected one of {}", names.join(", "))
        })
    }
}

/// An IMU's error figures in the units datasheets use, each 1σ.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImuDatasheet {
    /// Turn-on (run-to-run) gyro bias, °/h.
    pub gyro_bias_deg_per_h: f64,
    /// Gyro bias instability (in-run stability), °/h.
    pub gyro_bias_instability_deg_per_h: f64,
    /// Angle random walk, °/√h.
    pub angle_random_walk_deg_per_sqrt_h: f64,
    /// Gyro scale-factor error, ppm.
    pub gyro_scale_factor_ppm: f64,
    /// Turn-on accelerometer bias, mg.
    pub accel_bias_mg: f64,
    /// Accelerometer bias instability, µg.
    pub accel_bias_instability_ug: f64,
    /// Velocity random walk, m/s/√h (a noise density in µg/√Hz times 9.81 · 60 · 10⁻⁶).
    pub velocity_random_walk_m_per_s_per_sqrt_h: f64,
    /// Accelerometer scale-factor error, ppm.
    pub accel_scale_factor_ppm: f64,
    /// Correlation time of the bias instabilities, s.
    pub bias_correlation_time_s: f64,
}

impl ImuDatasheet {
    /// The figures by name, for checks and messages.
    fn fields(&self) -> [(&'static str, f64); 9] {
        [
            ("gyro_bias_deg_per_h", self.gyro_bias_deg_per_h),
            ("gyro_bias_instability_deg_per_h", self.gyro_bias_instability_deg_per_h),
            ("angle_random_walk_deg_per_sqrt_h", self.angle_random_walk_deg_per_sqrt_h),
            ("gyro_scale_factor_ppm", self.gyro_scale_factor_ppm),
            ("accel_bias_mg", self.accel_bias_mg),
            ("accel_bias_instability_ug", self.accel_bias_instability_ug),
            ("velocity_random_walk_m_per_s_per_sqrt_h", self.velocity_random_walk_m_per_s_per_sqrt_h),
            ("accel_scale_factor_ppm", self.accel_scale_factor_ppm),
            ("bias_correlation_time_s", self.bias_correlation_time_s),
        ]
    }

    /// Check every figure (finite, ≥ 0; the correlation time > 0; the random walks > 0, since a filter
    /// without process noise trusts its prediction forever); the error names the first bad one.
    pub fn check(&self) -> Result<(), NavError> {
        for (field, value) in self.fields() {
            let positive = matches!(
                field,
                "bias_correlation_time_s"
                    | "angle_random_walk_deg_per_sqrt_h"
                    | "velocity_random_walk_m_per_s_per_sqrt_h"
            );
            let ok = value.is_finite() && if positive { value > 0.0 } else { value >= 0.0 };
            if !ok {
                let expected = if positive { "a finite number > 0" } else { "a finite number >= 0" };
                return Err(NavError::Config { field, value, expected });
            }
        }
        Ok(())
    }

    /// The filter's model in SI units. The accelerometers' scale-factor error on gravity (1 g when level)
    /// acts as a bias at the start and joins the turn-on bias.
    pub fn model(&self) -> ImuModel {
        let accel_bias = self.accel_bias_mg * 1e-3 * STANDARD_GRAVITY;
        let accel_scale_factor = self.accel_scale_factor_ppm * 1e-6;
        ImuModel {
            gyro_bias: self.gyro_bias_deg_per_h * DEG / HOUR,
            gyro_bias_instability: self.gyro_bias_instability_deg_per_h * DEG / HOUR,
            gyro_random_walk: self.angle_random_walk_deg_per_sqrt_h * DEG / SQRT_HOUR,
            accel_bias: accel_bias.hypot(accel_scale_factor * STANDARD_GRAVITY),
            accel_bias_instability: self.accel_bias_instability_ug * 1e-6 * STANDARD_GRAVITY,
            accel_random_walk: self.velocity_random_walk_m_per_s_per_sqrt_h / SQRT_HOUR,
            bias_correlation_time: self.bias_correlation_time_s,
        }
    }
}

/// The white noise of an IMU measured from its own records, worst axis, SI units.
///
/// Datasheets state the sensor on a bench; mounted in a vehicle, engine and road vibration add white noise
/// the filter must know of, or it trusts its prediction over good fixes. Over three consecutive samples a
/// vehicle's rate or specific force is nearly a straight line, so the spread of their second differences
/// x₊ − 2x + x₋ is the noise: σ_sample = 1.4826 · MAD / √6 (white noise), and the density is σ_sample · √dt.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct MeasuredNoise {
    /// Angle random walk, rad/√s.
    pub gyro_random_walk: f64,
    /// Velocity random walk, m/s/√s.
    pub accel_random_walk: f64,
    /// Runs of three consecutive samples measured.
    pub triples: usize,
}

/// Fewest runs of three samples [`measure_noise`] needs.
const MIN_TRIPLES: usize = 100;

/// The noise of `imu` ([`MeasuredNoise`]): runs with an interval that differs from the typical one by more
/// than 10 % (gaps, rate changes) are left out; `None` with fewer than 100 runs left.
pub fn measure_noise(imu: &[ImuSample]) -> Option<MeasuredNoise> {
    let mut dts: Vec<f64> = imu.iter().map(|s| s.dt).filter(|dt| dt.is_finite() && *dt > 0.0).collect();
    if dts.len() < MIN_TRIPLES {
        return None;
    }
    let mid = dts.len() / 2;
    let dt = *dts.select_nth_unstable_by(mid, f64::total_cmp).1;
    let regular = |s: &ImuSample| (s.dt - dt).abs() <= 0.1 * dt;
    let triples: Vec<&[ImuSample]> = imu.windows(3).filter(|w| w.iter().all(regular)).collect();
    if triples.len() < MIN_TRIPLES {
        return None;
    }
    let density = |value: fn(&ImuSample) -> [f64; 3]| {
        (0..3)
            .map(|axis| {
                let mut d: Vec<f64> = triples
                    .iter()
                    .map(|w| value(&w[2])[axis] - 2.0 * value(&w[1])[axis] + value(&w[0])[axis])
                    .collect();
                let sigma = 1.4826 * median_abs_deviation(&mut d) / 6f64.sqrt();
                sigma * dt.sqrt()
            })
            .fold(0.0, f64::max)
    };
    let rate = |s: &ImuSample| (s.delta_theta.v / s.dt).into();
    let force = |s: &ImuSample| (s.delta_v.v / s.dt).into();
    let triples = triples.len();
    Some(MeasuredNoise { gyro_random_walk: density(rate), accel_random_walk: density(force), triples })
}

/// The median absolute deviation from the median (reorders `values`; not empty).
fn median_abs_deviation(values: &mut [f64]) -> f64 {
    let Some(centre) = median(values) else { return f64::NAN };
    values.iter_mut().for_each(|v| *v = (*v - centre).abs());
    median(values).unwrap_or(f64::NAN)
}

impl ImuModel {
    /// The model with its random walks raised to what the records show where they are noisier.
    pub fn with_noise_floor(&self, measured: &MeasuredNoise) -> Self {
        Self {
            gyro_random_walk: self.gyro_random_walk.max(measured.gyro_random_walk),
            accel_random_walk: self.accel_random_walk.max(measured.accel_random_walk),
            ..*self
        }
    }
}

/// A random walk in the datasheet's units: rad/√s → °/√h.
pub fn angle_random_walk_deg_per_sqrt_h(rad_per_sqrt_s: f64) -> f64 {
    rad_per_sqrt_s / DEG * SQRT_HOUR
}

/// A random walk in the datasheet's units: m/s/√s → m/s/√h.
pub fn velocity_random_walk_m_per_s_per_sqrt_h(m_per_s_per_sqrt_s: f64) -> f64 {
    m_per_s_per_sqrt_s * SQRT_HOUR
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit conversions against figures worked by hand.
    #[test]
    fn datasheet_units_convert_to_si() {
        let m = ImuClass::Tactical.datasheet().model();
        // 1 °/h = 4.848e-6 rad/s; 0.125 °/√h = 0.125 · 0.017453 / 60 rad/√s = 3.636e-5.
        assert!((m.gyro_bias - 4.848_137e-6).abs() < 1e-11);
        assert!((m.gyro_random_walk - 3.636_103e-5).abs() < 1e-10);
        // 0.05 m/s/√h = 8.333e-4 m/s/√s; 50 µg = 4.903e-4 m/s².
        assert!((m.accel_random_walk - 8.333_333e-4).abs() < 1e-10);
        assert!((m.accel_bias_instability - 4.903_325e-4).abs() < 1e-10);
        // 1 mg with 300 ppm of g beside it: hypot(9.80665, 2.94200) mm/s².
        assert!((m.accel_bias - 0.010_238_45).abs() < 1e-7, "{}", m.accel_bias);
    }

    /// The consumer preset is the BMI160 datasheet: 0.007 °/s/√Hz is 0.007 °/√s, 180 µg/√Hz is 1.765 mm/s/√s.
    #[test]
    fn consumer_noise_densities_are_the_bmi160_figures() {
        let m = ImuClass::Consumer.datasheet().model();
        assert!((m.gyro_random_walk - 0.007 * DEG).abs() < 1e-12);
        assert!((m.accel_random_walk - 180e-6 * STANDARD_GRAVITY).abs() < 1e-12);
        assert!((m.gyro_bias - DEG).abs() < 1e-12);
    }

    /// Classes are ordered: each preset's figures are no better than the class above it.
    #[test]
    fn presets_get_worse_class_by_class() {
        for pair in ImuClass::ALL.windows(2) {
            let (a, b) = (pair[0].datasheet(), pair[1].datasheet());
            for ((field, x), (_, y)) in a.fields().iter().zip(b.fields()) {
                if *field != "bias_correlation_time_s" {
                    assert!(x <= &y, "{field}: {} {x} > {} {y}", pair[0], pair[1]);
                }
            }
            a.check().unwrap();
        }
    }

    /// Class names parse, and an unknown one lists them.
    #[test]
    fn classes_parse_by_name() {
        for class in ImuClass::ALL {
            assert_eq!(class.name().parse::<ImuClass>().unwrap(), class);
        }
        assert!("strategic".parse::<ImuClass>().unwrap_err().contains("navigation, tactical, industrial, consumer"));
    }

    /// White noise of known density on a brisk manoeuvre (a 0.2 Hz slalom at 0.3 rad/s, 100 Hz: the rate
    /// changes more per sample than the noise) is measured within 5 % on the noisiest axis; the motion alone
    /// measures as (almost) nothing; gaps are left out.
    #[test]
    fn noise_is_measured_from_second_differences_despite_the_motion() {
        use rand::{RngExt as _, SeedableRng as _};
        let (dt, arw, vrw) = (0.01, 1e-4, 1e-3);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let gauss = |rng: &mut rand_chacha::ChaCha8Rng| {
            let u1: f64 = rng.random::<f64>().max(1e-300);
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * rng.random::<f64>()).cos()
        };
        let samples = |noisy: bool, rng: &mut rand_chacha::ChaCha8Rng| -> Vec<ImuSample> {
            (1..=20_000)
                .map(|k| {
                    let t = k as f64 * dt;
                    let turn = 0.3 * (std::f64::consts::TAU * 0.2 * t).sin();
                    let mut n = || if noisy { gauss(rng) } else { 0.0 };
                    // Per-sample σ of a rate is density / √dt; the increment is the rate times dt.
                    let rate = [n() * arw / dt.sqrt(), n() * 0.5 * arw / dt.sqrt(), turn + n() * arw / dt.sqrt()];
                    let force =
                        [2.0 * turn + n() * vrw / dt.sqrt(), n() * vrw / dt.sqrt(), -9.81 + n() * vrw / dt.sqrt()];
                    ImuSample {
                        time: t + if k > 10_000 { 5.0 } else { 0.0 },
                        dt: if k == 10_001 { 5.0 + dt } else { dt },
                        delta_theta: plumbline_geo::Vec3::new(rate[0] * dt, rate[1] * dt, rate[2] * dt),
                        delta_v: plumbline_geo::Vec3::new(force[0] * dt, force[1] * dt, force[2] * dt),
                    }
                })
                .collect()
        };
        let m = measure_noise(&samples(true, &mut rng)).unwrap();
        assert!((m.gyro_random_walk / arw - 1.0).abs() < 0.05, "ARW {} vs {arw}", m.gyro_random_walk);
        assert!((m.accel_random_walk / vrw - 1.0).abs() < 0.05, "VRW {} vs {vrw}", m.accel_random_walk);
        assert_eq!(m.triples, 19_998 - 3, "the three runs holding the 5 s gap are left out");
        let quiet = measure_noise(&samples(false, &mut rng)).unwrap();
        assert!(quiet.gyro_random_walk < 0.03 * arw && quiet.accel_random_walk < 0.03 * vrw, "{quiet:?}");
        let floor = ImuClass::Navigation.datasheet().model().with_noise_floor(&m);
        assert_eq!((floor.gyro_random_walk, floor.accel_random_walk), (m.gyro_random_walk, m.accel_random_walk));
        let consumer = ImuClass::Consumer.datasheet().model();
        assert_eq!(consumer.with_noise_floor(&m), consumer, "a noisier datasheet stays");
        assert!(measure_noise(&samples(true, &mut rng)[..50]).is_none());
    }
}
