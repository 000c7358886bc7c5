//! Attitude angle conventions (Applanix, NovAtel, omega-phi-kappa) and their exact rotation matrices.
//!
//! This is the one place where angle conventions are defined; everything else works with
//! [`Rotation`]s. All angles are radians.
//!
//! - **Applanix** (SBET, POSPac exports): body frame x forward, y right, z down; local level NED;
//!   R_B^NED = Rz(heading) · Ry(pitch) · Rx(roll). Heading is clockwise from (grid) north, pitch positive
//!   nose up, roll positive right side down. This is plumbline's canonical [`Attitude`].
//! - **NovAtel** (SPAN INSPVA/INSATT): body frame x right, y forward, z up; local level ENU;
//!   R_Bnov^ENU = Rz(−azimuth) · Rx(pitch) · Ry(roll). Azimuth clockwise from north, pitch positive nose up,
//!   roll positive right side down (right-handed about the forward y axis).
//! - **Omega-phi-kappa** (aerial frames, photogrammetric camera: x right, y up in the image, z away from the
//!   scene): R_Cphoto^M = Rx(ω) · Ry(φ) · Rz(κ). plumbline's [`Camera`] frame is the computer-vision one
//!   (y down, z toward the scene), so R_C^M = R_Cphoto^M · diag(1, −1, −1).
//!
//! The mapping frame is east-north-up, so NED and ENU differ by the fixed swap `T` below.
//!
//! Applanix and NovAtel label the body axes differently but rotate in the same physical sequence (heading
//! about the vertical, then pitch about the right axis, then roll about the forward axis), so equal angles
//! give the same rotation in both. The two matrices are derived independently here and a property test holds
//! them equal, which catches a swapped axis or sign in either derivation.

use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::frames::{Body, Camera, Map, Rotation};

/// NED ↔ ENU axis swap (its own inverse).
fn ned_to_enu() -> Matrix3<f64> {
    Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0)
}

/// NovAtel body (x right, y forward, z up) from canonical body (x forward, y right, z down); its own inverse.
fn novatel_from_canonical_body() -> Matrix3<f64> {
    ned_to_enu()
}

fn rx(a: f64) -> Matrix3<f64> {
    Rotation3::from_axis_angle(&Vector3::x_axis(), a).into_inner()
}
fn ry(a: f64) -> Matrix3<f64> {
    Rotation3::from_axis_angle(&Vector3::y_axis(), a).into_inner()
}
fn rz(a: f64) -> Matrix3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), a).into_inner()
}

/// Vehicle attitude in the Applanix convention (plumbline's canonical one), radians.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Attitude {
    /// Roll about the forward axis, positive right side down.
    pub roll: f64,
    /// Pitch about the right axis, positive nose up.
    pub pitch: f64,
    /// Heading clockwise from grid north.
    pub heading: f64,
}

impl Attitude {
    /// Build from roll, pitch, heading in radians.
    pub fn new(roll: f64, pitch: f64, heading: f64) -> Self {
        Self { roll, pitch, heading }
    }

    /// Build from degrees.
    pub fn from_degrees(roll: f64, pitch: f64, heading: f64) -> Self {
        Self::new(roll.to_radians(), pitch.to_radians(), heading.to_radians())
    }

    /// True when all angles are finite.
    pub fn is_finite(&self) -> bool {
        self.roll.is_finite() && self.pitch.is_finite() && self.heading.is_finite()
    }

    /// R_B^M: body vectors into the (east-north-up) mapping frame.
    pub fn to_rotation(&self) -> Rotation<Map, Body> {
        let r_ned = rz(self.heading) * ry(self.pitch) * rx(self.roll);
        Rotation::from_matrix(&(ned_to_enu() * r_ned))
    }

    /// The angles of a body-to-map rotation; heading in [0, 2π), roll in (−π, π], pitch in [−π/2, π/2].
    pub fn from_rotation(r: &Rotation<Map, Body>) -> Self {
        let m = ned_to_enu() * r.matrix();
        let pitch = (-m[(2, 0)]).clamp(-1.0, 1.0).asin();
        let roll = m[(2, 1)].atan2(m[(2, 2)]);
        let heading = m[(1, 0)].atan2(m[(0, 0)]).rem_euclid(std::f64::consts::TAU);
        Self { roll, pitch, heading }
    }
}

/// Vehicle attitude as NovAtel SPAN exports it, radians.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct NovatelAttitude {
    /// Roll about the forward (y) axis, right-handed.
    pub roll: f64,
    /// Pitch about the right (x) axis, right-handed (nose up positive).
    pub pitch: f64,
    /// Azimuth clockwise from north (left-handed about z up).
    pub azimuth: f64,
}

impl NovatelAttitude {
    /// R_B^M in plumbline's canonical body frame.
    pub fn to_rotation(&self) -> Rotation<Map, Body> {
        let r_nov = rz(-self.azimuth) * rx(self.pitch) * ry(self.roll);
        Rotation::from_matrix(&(r_nov * novatel_from_canonical_body()))
    }

    /// The NovAtel angles of a canonical body-to-map rotation; azimuth in [0, 2π).
    pub fn from_rotation(r: &Rotation<Map, Body>) -> Self {
        let m = r.matrix() * novatel_from_canonical_body();
        let pitch = m[(2, 1)].clamp(-1.0, 1.0).asin();
        let roll = (-m[(2, 0)]).atan2(m[(2, 2)]);
        let a = (-m[(0, 1)]).atan2(m[(1, 1)]);
        Self { roll, pitch, azimuth: (-a).rem_euclid(std::f64::consts::TAU) }
    }

    /// The same physical attitude in the canonical (Applanix) angles.
    pub fn to_canonical(&self) -> Attitude {
        Attitude::from_rotation(&self.to_rotation())
    }
}

/// Exterior-orientation angles of an aerial frame camera, radians.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct OmegaPhiKappa {
    /// Rotation about the map x (east) axis.
    pub omega: f64,
    /// Rotation about the once-rotated y axis.
    pub phi: f64,
    /// Rotation about the twice-rotated z axis.
    pub kappa: f64,
}

impl OmegaPhiKappa {
    /// Build from degrees.
    pub fn from_degrees(omega: f64, phi: f64, kappa: f64) -> Self {
        Self { omega: omega.to_radians(), phi: phi.to_radians(), kappa: kappa.to_radians() }
    }

    /// R_C^M for plumbline's (computer-vision) camera frame.
    pub fn to_rotation(&self) -> Rotation<Map, Camera> {
        let r_photo = rx(self.omega) * ry(self.phi) * rz(self.kappa);
        Rotation::from_matrix(&(r_photo * cv_from_photo()))
    }

    /// The angles of a camera-to-map rotation; φ in [−π/2, π/2].
    pub fn from_rotation(r: &Rotation<Map, Camera>) -> Self {
        let m = r.matrix() * cv_from_photo();
        let phi = m[(0, 2)].clamp(-1.0, 1.0).asin();
        let omega = (-m[(1, 2)]).atan2(m[(2, 2)]);
        let kappa = (-m[(0, 1)]).atan2(m[(0, 0)]);
        Self { omega, phi, kappa }
    }
}

/// Photogrammetric camera axes from computer-vision ones (its own inverse).
fn cv_from_photo() -> Matrix3<f64> {
    Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Vec3;
    use proptest::prelude::*;

    fn body(x: f64, y: f64, z: f64) -> Vec3<Body> {
        Vec3::new(x, y, z)
    }

    fn close(a: &Vec3<Map>, e: [f64; 3]) -> bool {
        (a.v - Vector3::from(e)).norm() < 1e-12
    }

    #[test]
    fn applanix_axes_point_where_the_convention_says() {
        // Level vehicle facing north: forward = north, right = east, down = −up.
        let r = Attitude::new(0.0, 0.0, 0.0).to_rotation();
        assert!(close(&r.apply(&body(1.0, 0.0, 0.0)), [0.0, 1.0, 0.0]));
        assert!(close(&r.apply(&body(0.0, 1.0, 0.0)), [1.0, 0.0, 0.0]));
        assert!(close(&r.apply(&body(0.0, 0.0, 1.0)), [0.0, 0.0, -1.0]));
        // Heading 90°: forward = east.
        let r = Attitude::from_degrees(0.0, 0.0, 90.0).to_rotation();
        assert!(close(&r.apply(&body(1.0, 0.0, 0.0)), [1.0, 0.0, 0.0]));
        // Pitch +10° nose up: forward gains a positive up component.
        let r = Attitude::from_degrees(0.0, 10.0, 0.0).to_rotation();
        let f = r.apply(&body(1.0, 0.0, 0.0));
        assert!(f.z() > 0.17 && f.y() > 0.98);
        // Roll +10° right side down: the right axis gains a negative up component.
        let r = Attitude::from_degrees(10.0, 0.0, 0.0).to_rotation();
        let right = r.apply(&body(0.0, 1.0, 0.0));
        assert!(right.z() < -0.17 && right.x() > 0.98);
    }

    #[test]
    fn novatel_and_applanix_agree_on_single_axis_attitudes() {
        for (roll, pitch, heading) in [(0.0, 0.0, 37.0), (0.0, 5.0, 0.0), (3.0, 0.0, 0.0), (0.0, -4.0, 250.0)] {
            let a = Attitude::from_degrees(roll, pitch, heading).to_rotation();
            let n =
                NovatelAttitude { roll: roll.to_radians(), pitch: pitch.to_radians(), azimuth: heading.to_radians() }
                    .to_rotation();
            assert!(a.angle_to(&n) < 1e-12, "{roll} {pitch} {heading}");
        }
    }

    #[test]
    fn aerial_strips_flown_south_still_look_down() {
        // κ = 180°: a half turn, which an iterative matrix-to-quaternion fit gets wrong.
        let r = OmegaPhiKappa::from_degrees(0.0, 0.0, 180.0).to_rotation();
        let view = r.apply(&Vec3::<Camera>::new(0.0, 0.0, 1.0));
        assert!((view.v - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12, "{view:?}");
        let image_right = r.apply(&Vec3::<Camera>::new(1.0, 0.0, 0.0));
        assert!((image_right.v - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-12, "{image_right:?}");
    }

    #[test]
    fn nadir_aerial_camera_looks_down_with_image_top_north() {
        let r = OmegaPhiKappa::from_degrees(0.0, 0.0, 0.0).to_rotation();
        let view = r.apply(&Vec3::<Camera>::new(0.0, 0.0, 1.0));
        assert!((view.v - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
        let image_right = r.apply(&Vec3::<Camera>::new(1.0, 0.0, 0.0));
        assert!((image_right.v - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
        let image_down = r.apply(&Vec3::<Camera>::new(0.0, 1.0, 0.0));
        assert!((image_down.v - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 512, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..ProptestConfig::default() })]

        #[test]
        fn applanix_round_trip(roll in -3.1f64..3.1, pitch in -1.5f64..1.5, heading in 0.0f64..std::f64::consts::TAU) {
            let a = Attitude::new(roll, pitch, heading);
            let b = Attitude::from_rotation(&a.to_rotation());
            prop_assert!((a.roll - b.roll).abs() < 1e-9);
            prop_assert!((a.pitch - b.pitch).abs() < 1e-9);
            prop_assert!((a.heading - b.heading).abs() < 1e-9);
        }

        #[test]
        fn novatel_round_trip(roll in -3.1f64..3.1, pitch in -1.5f64..1.5, azimuth in 0.0f64..std::f64::consts::TAU) {
            let a = NovatelAttitude { roll, pitch, azimuth };
            let b = NovatelAttitude::from_rotation(&a.to_rotation());
            prop_assert!((a.roll - b.roll).abs() < 1e-9);
            prop_assert!((a.pitch - b.pitch).abs() < 1e-9);
            prop_assert!((a.azimuth - b.azimuth).abs() < 1e-9);
            // And through the canonical angles: same physical rotation.
            prop_assert!(a.to_canonical().to_rotation().angle_to(&a.to_rotation()) < 1e-9);
            // Both vendors' angles describe the same physical sequence, so they coincide.
            let c = Attitude::new(roll, pitch, azimuth).to_rotation();
            prop_assert!(c.angle_to(&a.to_rotation()) < 1e-9);
        }

        #[test]
        fn opk_round_trip(omega in -3.1f64..3.1, phi in -1.5f64..1.5, kappa in -3.1f64..3.1) {
            let a = OmegaPhiKappa { omega, phi, kappa };
            let b = OmegaPhiKappa::from_rotation(&a.to_rotation());
            prop_assert!((a.omega - b.omega).abs() < 1e-9);
            prop_assert!((a.phi - b.phi).abs() < 1e-9);
            prop_assert!((a.kappa - b.kappa).abs() < 1e-9);
        }
    }
}
