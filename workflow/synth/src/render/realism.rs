//! Sensor realism: what real cameras add to an ideal rendering. Per sensor (the street rig, the aerial
//! camera): white balance, a filmic tone curve over the camera's own, vignetting, signal-dependent noise and
//! the JPEG quality the images are written at. For a panorama stitched from a rig of sub-cameras: parallax at
//! the seams (each sub-camera looks from its own centre), exposure steps between sub-cameras, rolling-shutter
//! skew and motion blur at driving speed. Each level also names the world's changes between the epochs that
//! hide ground from one of them (crowns over the road in the aerial flight, pedestrians: [`EpochChanges`]), and
//! the ground's relief (hills, cross-fall, kerbs: [`Relief`]).
//!
//! Three levels. `Ideal` adds nothing: the world the method's figures were first measured on. `Default` is a
//! current survey rig (six global-shutter sub-cameras 4 cm from the rig's centre, matched exposures) and a
//! large-format aerial camera, both well white-balanced. `Harsh` is a rolling-shutter consumer rig at speed
//! (10 cm, 33 ms readout, 2 ms exposure, ±15 % between sub-cameras) and a flight in bluer light with a
//! stronger curve; the figures of each are in [`Realism::of`].

use crate::texture::{Rgb, unit};
use crate::world::{EpochChanges, Relief};

/// How much of real sensors' imperfection a simulation adds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum RealismLevel {
    /// None: ideal cameras (the accuracy tests' world).
    #[default]
    Ideal,
    /// A current survey rig and aerial camera.
    Default,
    /// A consumer rolling-shutter rig at speed, a flight in other light.
    Harsh,
}

/// The radiometry of one sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Radiometry {
    /// Gains on linear red, green and blue (a white-balance error).
    pub white_balance: [f32; 3],
    /// Strength of a filmic S-curve blended over the camera's tone curve: 0 none, 1 the full smoothstep.
    pub s_curve: f32,
    /// Share of brightness lost at the edge of the field (quadratic in the off-axis angle).
    pub vignetting: f32,
    /// Standard deviation of the sensor noise at mid-grey, 8-bit levels (shot noise: ∝ √signal).
    pub noise: f32,
    /// JPEG quality the images are written at, 1–100.
    pub jpeg_quality: u8,
}

impl Radiometry {
    /// No white-balance error, no curve, no vignetting, no noise, JPEG quality 90.
    pub const IDEAL: Self =
        Self { white_balance: [1.0; 3], s_curve: 0.0, vignetting: 0.0, noise: 0.0, jpeg_quality: 90 };

    /// True when the rendering is untouched (the JPEG quality aside).
    pub fn is_ideal(&self) -> bool {
        self.white_balance == [1.0; 3] && self.s_curve == 0.0 && self.vignetting == 0.0 && self.noise == 0.0
    }

    /// Linear radiance with the white balance and a gain applied.
    pub fn balance(&self, c: Rgb, gain: f32) -> Rgb {
        [c[0] * self.white_balance[0] * gain, c[1] * self.white_balance[1] * gain, c[2] * self.white_balance[2] * gain]
    }

    /// The S-curve over a tone-mapped value in 0–255.
    pub fn curve(&self, x: f32) -> f32 {
        let u = (x / 255.0).clamp(0.0, 1.0);
        let s = u * u * (3.0 - 2.0 * u);
        (u + self.s_curve * (s - u)) * 255.0
    }

    /// The vignetting gain at `edge_share` of the way from the optical axis to the field's edge (beyond the
    /// edge — a sub-camera's corners — the loss grows on to 1.2² times the edge's).
    pub fn vignette(&self, edge_share: f64) -> f32 {
        1.0 - self.vignetting * (edge_share.abs().min(1.2_f64).powi(2)) as f32
    }

    /// A value in 0–255 with the sensor noise of pixel channel `idx` added (not clamped).
    pub fn noisy(&self, v: f32, seed: u64, idx: i64) -> f32 {
        if self.noise == 0.0 {
            return v;
        }
        v + gaussian(seed, idx) as f32 * self.noise * (v.max(16.0) / 128.0).sqrt()
    }
}

/// A panorama rig of sub-cameras around the horizon, each covering an equal slice of the panorama's columns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rig {
    /// Sub-cameras around the horizon; 0 for one ideal camera.
    pub sub_cameras: u32,
    /// Distance of each sub-camera's centre from the panorama's centre, metres (parallax at the seams).
    pub radius_m: f64,
    /// Largest exposure difference between sub-cameras: each gets a gain in 1 ± this.
    pub exposure_step: f32,
    /// Exposure time, seconds: motion blur is the speed times this.
    pub exposure_s: f64,
    /// Rolling-shutter readout from the top row to the bottom row, seconds; 0 for a global shutter.
    pub readout_s: f64,
}

impl Rig {
    /// One ideal camera.
    pub const IDEAL: Self = Self { sub_cameras: 0, radius_m: 0.0, exposure_step: 0.0, exposure_s: 0.0, readout_s: 0.0 };

    /// True for one ideal camera.
    pub fn is_ideal(&self) -> bool {
        self.sub_cameras == 0 && self.exposure_s == 0.0 && self.readout_s == 0.0
    }

    /// Sub-cameras used (at least one).
    pub fn count(&self) -> u32 {
        self.sub_cameras.max(1)
    }

    /// The sub-camera imaging column `col` of a panorama `width` pixels wide.
    pub fn sector(&self, col: u32, width: u32) -> u32 {
        ((u64::from(col) * u64::from(self.count())) / u64::from(width.max(1))) as u32
    }

    /// The column on sub-camera `k`'s optical axis (a fraction: the middle of its slice).
    pub fn axis_column(&self, k: u32, width: u32) -> f64 {
        (f64::from(k) + 0.5) * f64::from(width) / f64::from(self.count())
    }

    /// Sub-camera `k`'s exposure gain, in 1 ± `exposure_step`, fixed by `seed`.
    pub fn gain(&self, k: u32, seed: u64) -> f32 {
        1.0 + self.exposure_step * (2.0 * unit(seed ^ 0x5EA3, i64::from(k), 0) - 1.0)
    }

    /// When row `row` of a panorama `height` pixels high is read out, relative to the panorama's time, seconds.
    pub fn row_time(&self, row: u32, height: u32) -> f64 {
        self.readout_s * ((f64::from(row) + 0.5) / f64::from(height.max(1)) - 0.5)
    }

    /// How far pixel (`col`, `row`) lies from its sub-camera's axis as a share of the way to the field's edge:
    /// sideways the slice's border, up and down 60° (a portrait sensor); 1 on that ellipse.
    pub fn edge_share(&self, col: u32, row: u32, width: u32, height: u32) -> f64 {
        let k = self.sector(col, width);
        let azimuth = (f64::from(col) + 0.5 - self.axis_column(k, width)) * std::f64::consts::TAU / f64::from(width);
        let elevation = (f64::from(height) / 2.0 - f64::from(row) - 0.5) * std::f64::consts::PI / f64::from(height);
        let side = azimuth / (std::f64::consts::PI / f64::from(self.count()));
        side.hypot(elevation / 60f64.to_radians())
    }
}

/// The realism of a simulated campaign's cameras.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Realism {
    /// Which level this is.
    pub level: RealismLevel,
    /// The street rig's radiometry.
    pub street: Radiometry,
    /// The aerial camera's radiometry (on top of its optics' blur and noise).
    pub aerial: Radiometry,
    /// The panorama rig.
    pub rig: Rig,
    /// What the world changes between the epochs (crowns over the road, pedestrians); the world is made
    /// with it (`WorldConfig::changes`).
    pub world: EpochChanges,
    /// The ground's hills, cross-fall and kerbs (`WorldConfig::relief`).
    pub relief: Relief,
}

impl Realism {
    /// The figures of a level.
    ///
    /// | | `Default` | `Harsh` |
    /// |---|---|---|
    /// | street white balance (R, G, B) | 1.05, 1, 0.94 | 1.15, 1, 0.82 |
    /// | street S-curve / vignetting / noise / JPEG | 0.25 / 12 % / 1.5 / 85 | 0.6 / 35 % / 4 / 70 |
    /// | aerial white balance (R, G, B) | 0.96, 1, 1.04 | 0.9, 1, 1.12 |
    /// | aerial S-curve / vignetting / noise / JPEG | 0.15 / 8 % / 1 / 90 | 0.4 / 25 % / 3 / 75 |
    /// | rig: sub-cameras, radius | 6, 4 cm | 6, 10 cm |
    /// | rig: exposure step, exposure, readout | ±4 %, 0.5 ms, global | ±15 %, 2 ms, 33 ms |
    /// | aerial crowns spread / pedestrians per 100 m | 1.2 / 4 | 1.6 / 12 |
    /// | hills' steepest grade / cross-fall / kerb | 4 % / 2 % / 10 cm | 8 % / 2.5 % / 15 cm |
    pub fn of(level: RealismLevel) -> Self {
        let radiometry = |white_balance, s_curve, vignetting, noise, jpeg_quality| Radiometry {
            white_balance,
            s_curve,
            vignetting,
            noise,
            jpeg_quality,
        };
        match level {
            RealismLevel::Ideal => {
                let (street, aerial) = (Radiometry::IDEAL, Radiometry::IDEAL);
                Self { level, street, aerial, rig: Rig::IDEAL, world: EpochChanges::NONE, relief: Relief::FLAT }
            }
            RealismLevel::Default => Self {
                level,
                street: radiometry([1.05, 1.0, 0.94], 0.25, 0.12, 1.5, 85),
                aerial: radiometry([0.96, 1.0, 1.04], 0.15, 0.08, 1.0, 90),
                rig: Rig { sub_cameras: 6, radius_m: 0.04, exposure_step: 0.04, exposure_s: 0.0005, readout_s: 0.0 },
                world: EpochChanges { crown_spread: 1.2, pedestrians_per_100m: 4.0 },
                relief: Relief { grade: 0.04, cross_fall: 0.02, kerb_m: 0.10 },
            },
            RealismLevel::Harsh => Self {
                level,
                street: radiometry([1.15, 1.0, 0.82], 0.6, 0.35, 4.0, 70),
                aerial: radiometry([0.9, 1.0, 1.12], 0.4, 0.25, 3.0, 75),
                rig: Rig { sub_cameras: 6, radius_m: 0.10, exposure_step: 0.15, exposure_s: 0.002, readout_s: 0.033 },
                world: EpochChanges { crown_spread: 1.6, pedestrians_per_100m: 12.0 },
                relief: Relief { grade: 0.08, cross_fall: 0.025, kerb_m: 0.15 },
            },
        }
    }
}

/// A standard normal deviate, a pure function of (seed, index).
pub(crate) fn gaussian(seed: u64, idx: i64) -> f64 {
    let u1 = f64::from(unit(seed ^ 71, idx, 0)).max(1e-7);
    let u2 = f64::from(unit(seed ^ 72, idx, 1));
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rig_splits_the_columns_and_times_the_rows() {
        let rig = Realism::of(RealismLevel::Harsh).rig;
        assert_eq!((0..1024).map(|c| rig.sector(c, 1024)).max(), Some(5));
        assert_eq!(rig.sector(170, 1024), 0);
        assert_eq!(rig.sector(171, 1024), 1);
        assert!(rig.edge_share(85, 256, 1024, 512) < 0.01);
        assert!((rig.edge_share(0, 256, 1024, 512) - 1.0).abs() < 0.02);
        // 60° up on the axis.
        assert!((rig.edge_share(85, 85, 1024, 512) - 1.0).abs() < 0.02);
        assert!((rig.row_time(0, 512) + 0.0165).abs() < 1e-4 && (rig.row_time(511, 512) - 0.0165).abs() < 1e-4);
        let gains: Vec<f32> = (0..6).map(|k| rig.gain(k, 7)).collect();
        assert!(gains.iter().all(|g| (0.85..=1.15).contains(g)) && gains.iter().any(|g| (g - 1.0).abs() > 0.03));
    }

    #[test]
    fn radiometry_curves_vignettes_and_adds_noise_of_its_size() {
        let r = Realism::of(RealismLevel::Harsh).street;
        assert!(r.curve(64.0) < 64.0 && r.curve(192.0) > 192.0 && (r.curve(127.5) - 127.5).abs() < 1e-3);
        assert!((r.vignette(1.0) - 0.65).abs() < 1e-6 && r.vignette(0.0) == 1.0);
        let n = 20_000;
        let d: Vec<f32> = (0..n).map(|i| r.noisy(128.0, 3, i) - 128.0).collect();
        let mean = d.iter().sum::<f32>() / n as f32;
        let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / n as f32).sqrt();
        assert!(mean.abs() < 0.1 && (sd - 4.0).abs() < 0.15, "mean {mean}, sd {sd}");
        assert!(Radiometry::IDEAL.is_ideal() && !r.is_ideal() && Realism::of(RealismLevel::Ideal).rig.is_ideal());
    }
}
