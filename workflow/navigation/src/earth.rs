//! The Earth the mechanisation runs on: the simulator's flat, non-rotating world, or the WGS 84 ellipsoid
//! with Earth rotation, transport rate and normal gravity.
//!
//! The map frame is the projected east-north-up frame of the fixes, taken as the local-level frame at the
//! campaign's latitude. Its north is grid north, which differs from true north by the meridian convergence
//! γ (grid heading = true heading − γ; up to 3° inside a UTM zone, which would put 0.8 °/h of Earth rate on
//! the wrong axis): [`Earth::Wgs84`] carries γ and turns the Earth-rate and transport-rate vectors into the
//! grid frame. The latitude is the campaign's, not the state's (10 km north moves it by 0.09°).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::NavError;

/// Earth rotation rate (WGS 84), rad/s.
pub const EARTH_RATE: f64 = 7.292_115e-5;
/// WGS 84 semi-major axis, m.
const A: f64 = 6_378_137.0;
/// WGS 84 flattening.
const F: f64 = 1.0 / 298.257_223_563;
/// WGS 84 first eccentricity squared.
const E2: f64 = F * (2.0 - F);
/// Normal gravity at the equator, m/s² (Somigliana, WGS 84).
const GAMMA_EQUATOR: f64 = 9.780_325_335_9;
/// Somigliana's constant k = (b·γ_p − a·γ_e) / (a·γ_e).
const SOMIGLIANA_K: f64 = 0.001_931_852_652_41;
/// m = ω²a²b / GM (WGS 84).
const M_RATIO: f64 = 0.003_449_786_506_84;

/// The Earth model of the mechanisation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Earth {
    /// Flat and not rotating, gravity of this magnitude (m/s²) along −z: the simulator's world.
    Flat {
        /// Gravity, m/s².
        gravity: f64,
    },
    /// WGS 84 at this geodetic latitude (rad): Earth rotation, transport rate and normal gravity at the
    /// state's height.
    Wgs84 {
        /// Geodetic latitude of the campaign, rad.
        latitude: f64,
        /// Meridian convergence of the map frame, rad (grid heading = true heading − γ; 0 when the map's
        /// north is true north).
        #[serde(default)]
        convergence: f64,
    },
}

impl Earth {
    /// Check the parameters; the error names the bad one.
    pub fn check(&self) -> Result<(), NavError> {
        match *self {
            Self::Flat { gravity } if !(gravity.is_finite() && gravity > 0.0) => {
                Err(NavError::Config { field: "earth.gravity", value: gravity, expected: "a finite number > 0" })
            }
            Self::Wgs84 { latitude, .. } if !(latitude.is_finite() && latitude.abs() < 89f64.to_radians()) => {
                let value = latitude.to_degrees();
                Err(NavError::Config { field: "earth.latitude", value, expected: "a latitude within ±89°" })
            }
            Self::Wgs84 { convergence, .. } if !(convergence.is_finite() && convergence.abs() < 0.5) => {
                let value = convergence.to_degrees();
                Err(NavError::Config { field: "earth.convergence", value, expected: "a convergence within ±28°" })
            }
            _ => Ok(()),
        }
    }

    /// Earth rotation in the map frame (east, north, up), rad/s.
    pub fn earth_rate(&self) -> Vector3<f64> {
        match *self {
            Self::Flat { .. } => Vector3::zeros(),
            Self::Wgs84 { latitude, convergence } => {
                to_grid(convergence, EARTH_RATE * Vector3::new(0.0, latitude.cos(), latitude.sin()))
            }
        }
    }

    /// Rotation of the local-level frame moving over the ellipsoid at `velocity` (east, north, up; m/s) and
    /// height `height` (m), rad/s.
    pub fn transport_rate(&self, velocity: &Vector3<f64>, height: f64) -> Vector3<f64> {
        match *self {
            Self::Flat { .. } => Vector3::zeros(),
            Self::Wgs84 { latitude, convergence } => {
                let (m, n) = radii(latitude);
                let (re, rn) = (n + height, m + height);
                let v = to_grid(-convergence, *velocity);
                to_grid(convergence, Vector3::new(-v.y / rn, v.x / re, v.x * latitude.tan() / re))
            }
        }
    }

    /// Magnitude of gravity at height `height` (m), m/s².
    pub fn gravity(&self, height: f64) -> f64 {
        match *self {
            Self::Flat { gravity } => gravity,
            Self::Wgs84 { latitude, .. } => normal_gravity(latitude, height),
        }
    }
}

/// A true east-north-up vector in the grid frame of convergence γ: true north (azimuth 0) lies at grid
/// azimuth −γ, a turn of +γ counter-clockwise about up.
fn to_grid(convergence: f64, v: Vector3<f64>) -> Vector3<f64> {
    let (s, c) = convergence.sin_cos();
    Vector3::new(v.x * c - v.y * s, v.x * s + v.y * c, v.z)
}

/// Meridian and prime-vertical radii of curvature at `latitude` (rad), m.
fn radii(latitude: f64) -> (f64, f64) {
    let w2 = 1.0 - E2 * latitude.sin().powi(2);
    (A * (1.0 - E2) / w2.powf(1.5), A / w2.sqrt())
}

/// Normal gravity of WGS 84 at `latitude` (rad) and ellipsoidal height `height` (m): Somigliana's formula on
/// the ellipsoid and its second-order expansion above it (NIMA TR8350.2, eq. 4-1 and 4-3), m/s².
pub fn normal_gravity(latitude: f64, height: f64) -> f64 {
    let s2 = latitude.sin().powi(2);
    let surface = GAMMA_EQUATOR * (1.0 + SOMIGLIANA_K * s2) / (1.0 - E2 * s2).sqrt();
    surface * (1.0 - 2.0 / A * (1.0 + F + M_RATIO - 2.0 * F * s2) * height + 3.0 * height * height / (A * A))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Normal gravity against WGS 84's published values: 9.7803253359 at the equator, 9.8321849379 at the
    /// poles (TR8350.2 table 3.4), about 9.80620 at 45°; the free-air gradient is about −3.086 µm/s² per m.
    #[test]
    fn normal_gravity_matches_wgs84() {
        assert!((normal_gravity(0.0, 0.0) - 9.780_325_335_9).abs() < 1e-9);
        assert!((normal_gravity(90f64.to_radians(), 0.0) - 9.832_184_937_9).abs() < 1e-7);
        assert!((normal_gravity(45f64.to_radians(), 0.0) - 9.806_199).abs() < 1e-5);
        let gradient = normal_gravity(49f64.to_radians(), 1000.0) - normal_gravity(49f64.to_radians(), 0.0);
        assert!((gradient / 1000.0 + 3.086e-6).abs() < 0.01e-6, "{gradient}");
    }

    /// Earth rate: 15.04 °/h about the axis, split north and up by the latitude; none on the flat Earth.
    #[test]
    fn earth_rate_splits_by_latitude() {
        let rate = Earth::Wgs84 { latitude: 49f64.to_radians(), convergence: 0.0 }.earth_rate();
        let deg_per_h = |r: f64| r.to_degrees() * 3600.0;
        assert!((deg_per_h(rate.norm()) - 15.041).abs() < 1e-3);
        assert!((deg_per_h(rate.y) - 15.041 * 49f64.to_radians().cos()).abs() < 1e-3);
        assert!((deg_per_h(rate.z) - 15.041 * 49f64.to_radians().sin()).abs() < 1e-3);
        assert_eq!(rate.x, 0.0);
        assert_eq!(Earth::Flat { gravity: 9.8 }.earth_rate(), Vector3::zeros());
        // 10 m/s east at 49°: the frame turns about north by v/R (≈ 1.57e-6 rad/s) and about up by v·tanφ/R.
        let transport = Earth::Wgs84 { latitude: 49f64.to_radians(), convergence: 0.0 }
            .transport_rate(&Vector3::new(10.0, 0.0, 0.0), 0.0);
        assert!((transport.y - 10.0 / 6_390_000.0).abs() < 0.01e-6, "{transport:?}");
        assert!((transport.z / transport.y - 49f64.to_radians().tan()).abs() < 1e-12);
        assert!(
            Earth::Wgs84 { latitude: 1.6, convergence: 0.0 }.check().is_err()
                && Earth::Flat { gravity: 0.0 }.check().is_err()
        );
    }

    /// In a grid frame of convergence γ the Earth rate's horizontal part points to true north, at grid
    /// azimuth −γ; the transport rate of a drive due true north equals the true-frame one turned the same way.
    #[test]
    fn grid_convergence_turns_the_rates_into_the_grid_frame() {
        let (latitude, gamma) = (49f64.to_radians(), 2f64.to_radians());
        let true_frame = Earth::Wgs84 { latitude, convergence: 0.0 };
        let grid = Earth::Wgs84 { latitude, convergence: gamma };
        let (t, g) = (true_frame.earth_rate(), grid.earth_rate());
        assert!((g.norm() - t.norm()).abs() < 1e-18 && (g.z - t.z).abs() < 1e-18);
        assert!((g.x + t.y * gamma.sin()).abs() < 1e-15 && (g.y - t.y * gamma.cos()).abs() < 1e-15, "{g:?}");
        // 10 m/s due true north: grid velocity (−10 sin γ, 10 cos γ).
        let north_true = true_frame.transport_rate(&Vector3::new(0.0, 10.0, 0.0), 0.0);
        let north_grid = grid.transport_rate(&Vector3::new(-10.0 * gamma.sin(), 10.0 * gamma.cos(), 0.0), 0.0);
        let expected = to_grid(gamma, north_true);
        assert!((north_grid - expected).norm() < 1e-15, "{north_grid:?} vs {expected:?}");
        assert!((north_true.x + 10.0 / radii(latitude).0).abs() < 1e-15);
        let bad = Earth::Wgs84 { latitude, convergence: 1.0 }.check().unwrap_err();
        assert!(matches!(bad, NavError::Config { field: "earth.convergence", .. }), "{bad}");
    }
}
