//! Frame-tagged vectors, points, rotations and poses: the frame a coordinate lives in is part of its type.
//!
//! The frames (see `ARCHITECTURE.md` § Conventions for the full statement):
//! - [`Map`]: the campaign's mapping frame, a projected CRS: x = easting, y = northing, z = height (up), metres.
//! - [`Body`]: the vehicle (IMU) body frame as Applanix exports it: x forward, y right, z down.
//! - [`Camera`]: a camera frame in the computer-vision convention: x right, y down (in the image), z along the
//!   viewing direction. Equirectangular panoramas use the same axes, z being the panorama's centre column.
//!
//! A `Rotation<To, From>` maps vectors of frame `From` into frame `To` (R_From^To in the paper notation), and a
//! `Pose<To, From>` maps points: `p_to = R · p_from + t`, where `t` is the origin of `From` expressed in `To`.

use std::fmt;
use std::marker::PhantomData;
use std::ops::{Add, Mul, Neg, Sub};

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// Marker trait of a coordinate frame.
pub trait Frame: Copy + fmt::Debug + 'static {
    /// Short name used in Debug output.
    const NAME: &'static str;
}

/// The mapping frame: projected CRS easting, northing, height (metres).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Map;
/// The vehicle body frame (IMU): x forward, y right, z down.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Body;
/// A camera frame: x right, y down, z viewing direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Camera;

impl Frame for Map {
    const NAME: &'static str = "map";
}
impl Frame for Body {
    const NAME: &'static str = "body";
}
impl Frame for Camera {
    const NAME: &'static str = "camera";
}

/// A free vector (direction or displacement) in frame `F`.
pub struct Vec3<F: Frame> {
    /// The components in frame `F`.
    pub v: Vector3<f64>,
    frame: PhantomData<F>,
}

/// A point (position) in frame `F`.
pub struct Point3<F: Frame> {
    /// The coordinates in frame `F`.
    pub p: Vector3<f64>,
    frame: PhantomData<F>,
}

macro_rules! impl_common {
    ($ty:ident, $field:ident) => {
        impl<F: Frame> $ty<F> {
            /// Build from components in frame `F`.
            pub fn new(x: f64, y: f64, z: f64) -> Self {
                Self::from_vector(Vector3::new(x, y, z))
            }
            /// Wrap a raw vector whose components are in frame `F`.
            pub fn from_vector($field: Vector3<f64>) -> Self {
                Self { $field, frame: PhantomData }
            }
            /// The x component.
            pub fn x(&self) -> f64 {
                self.$field.x
            }
            /// The y component.
            pub fn y(&self) -> f64 {
                self.$field.y
            }
            /// The z component.
            pub fn z(&self) -> f64 {
                self.$field.z
            }
            /// True when every component is finite.
            pub fn is_finite(&self) -> bool {
                self.$field.iter().all(|c| c.is_finite())
            }
        }
        impl<F: Frame> Clone for $ty<F> {
            fn clone(&self) -> Self {
                *self
            }
        }
        impl<F: Frame> Copy for $ty<F> {}
        impl<F: Frame> PartialEq for $ty<F> {
            fn eq(&self, other: &Self) -> bool {
                self.$field == other.$field
            }
        }
        impl<F: Frame> fmt::Debug for $ty<F> {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                let [x, y, z] = [self.$field.x, self.$field.y, self.$field.z];
                write!(f, "{}<{}>({x}, {y}, {z})", stringify!($ty), F::NAME)
            }
        }
    };
}
impl_common!(Vec3, v);
impl_common!(Point3, p);

impl<F: Frame> Vec3<F> {
    /// The zero vector.
    pub fn zeros() -> Self {
        Self::from_vector(Vector3::zeros())
    }
    /// Euclidean length.
    pub fn norm(&self) -> f64 {
        self.v.norm()
    }
    /// Unit vector in the same direction, or `None` for a (near) zero vector.
    pub fn normalize(&self) -> Option<Self> {
        let n = self.v.norm();
        (n > f64::MIN_POSITIVE && n.is_finite()).then(|| Self::from_vector(self.v / n))
    }
    /// Dot product.
    pub fn dot(&self, other: &Self) -> f64 {
        self.v.dot(&other.v)
    }
}

impl<F: Frame> Point3<F> {
    /// The frame origin.
    pub fn origin() -> Self {
        Self::from_vector(Vector3::zeros())
    }
}

impl<F: Frame> Sub for Point3<F> {
    type Output = Vec3<F>;
    fn sub(self, rhs: Self) -> Vec3<F> {
        Vec3::from_vector(self.p - rhs.p)
    }
}
impl<F: Frame> Add<Vec3<F>> for Point3<F> {
    type Output = Point3<F>;
    fn add(self, rhs: Vec3<F>) -> Point3<F> {
        Point3::from_vector(self.p + rhs.v)
    }
}
impl<F: Frame> Sub<Vec3<F>> for Point3<F> {
    type Output = Point3<F>;
    fn sub(self, rhs: Vec3<F>) -> Point3<F> {
        Point3::from_vector(self.p - rhs.v)
    }
}
impl<F: Frame> Add for Vec3<F> {
    type Output = Vec3<F>;
    fn add(self, rhs: Self) -> Self {
        Vec3::from_vector(self.v + rhs.v)
    }
}
impl<F: Frame> Sub for Vec3<F> {
    type Output = Vec3<F>;
    fn sub(self, rhs: Self) -> Self {
        Vec3::from_vector(self.v - rhs.v)
    }
}
impl<F: Frame> Neg for Vec3<F> {
    type Output = Vec3<F>;
    fn neg(self) -> Self {
        Vec3::from_vector(-self.v)
    }
}
impl<F: Frame> Mul<f64> for Vec3<F> {
    type Output = Vec3<F>;
    fn mul(self, s: f64) -> Self {
        Vec3::from_vector(self.v * s)
    }
}

/// A rotation taking vectors of frame `From` into frame `To` (R_From^To).
pub struct Rotation<To: Frame, From: Frame> {
    q: UnitQuaternion<f64>,
    frames: PhantomData<(To, From)>,
}

impl<To: Frame, From: Frame> Rotation<To, From> {
    /// The identity (the frames' axes coincide).
    pub fn identity() -> Self {
        Self::from_quaternion(UnitQuaternion::identity())
    }
    /// Wrap a unit quaternion rotating `From` vectors into `To`.
    pub fn from_quaternion(q: UnitQuaternion<f64>) -> Self {
        Self { q, frames: PhantomData }
    }
    /// From a rotation matrix whose columns are the `From` axes expressed in `To`.
    /// The matrix is re-orthonormalised (nearest rotation by SVD); it must be close to a proper rotation.
    pub fn from_matrix(m: &Matrix3<f64>) -> Self {
        // Closed form (not nalgebra's iterative fit, which does not converge for half turns).
        Self::from_quaternion(UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            nearest_rotation(m),
        )))
    }
    /// The quaternion.
    pub fn quaternion(&self) -> &UnitQuaternion<f64> {
        &self.q
    }
    /// The 3×3 matrix (columns: `From` axes in `To`).
    pub fn matrix(&self) -> Matrix3<f64> {
        self.q.to_rotation_matrix().into_inner()
    }
    /// The nalgebra rotation matrix type.
    pub fn rotation3(&self) -> Rotation3<f64> {
        self.q.to_rotation_matrix()
    }
    /// The inverse rotation R_To^From.
    pub fn inverse(&self) -> Rotation<From, To> {
        Rotation::from_quaternion(self.q.inverse())
    }
    /// Rotate a vector of `From` into `To`.
    pub fn apply(&self, v: &Vec3<From>) -> Vec3<To> {
        Vec3::from_vector(self.q * v.v)
    }
    /// Compose: (R_B^To) · (R_From'^B) = R_From'^To.
    pub fn then_from<Mid: Frame>(&self, inner: &Rotation<From, Mid>) -> Rotation<To, Mid> {
        Rotation::from_quaternion(self.q * inner.q)
    }
    /// Angle of the rotation taking `self` to `other`, radians in [0, π].
    pub fn angle_to(&self, other: &Self) -> f64 {
        self.q.angle_to(&other.q)
    }
    /// Spherical linear interpolation between two rotations, `t` in [0, 1].
    pub fn slerp(&self, other: &Self, t: f64) -> Self {
        // Shortest path: nalgebra's slerp already picks the short arc for unit quaternions.
        Self::from_quaternion(self.q.slerp(&other.q, t))
    }
}

impl<To: Frame, From: Frame> Clone for Rotation<To, From> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<To: Frame, From: Frame> Copy for Rotation<To, From> {}
impl<To: Frame, From: Frame> fmt::Debug for Rotation<To, From> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Rotation<{}←{}>({:?})", To::NAME, From::NAME, self.q.coords.as_slice())
    }
}

/// The proper rotation closest to `m` in the Frobenius norm (U·Vᵀ of its SVD, with the determinant fixed).
fn nearest_rotation(m: &Matrix3<f64>) -> Matrix3<f64> {
    if (m.transpose() * m - Matrix3::identity()).norm() < 1e-13 && m.determinant() > 0.0 {
        return *m; // already a rotation: the common case, no SVD needed
    }
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else { return *m };
    let r = u * v_t;
    if r.determinant() >= 0.0 { r } else { u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)) * v_t }
}

/// A rigid transformation taking points of frame `From` into frame `To`: `p_to = R · p_from + t`.
pub struct Pose<To: Frame, From: Frame> {
    /// Orientation R_From^To.
    pub rotation: Rotation<To, From>,
    /// The origin of `From` expressed in `To`.
    pub translation: Point3<To>,
}

impl<To: Frame, From: Frame> Pose<To, From> {
    /// Build from parts.
    pub fn new(rotation: Rotation<To, From>, translation: Point3<To>) -> Self {
        Self { rotation, translation }
    }
    /// Transform a point of `From` into `To`.
    pub fn transform_point(&self, p: &Point3<From>) -> Point3<To> {
        Point3::from_vector(self.rotation.quaternion() * p.p + self.translation.p)
    }
    /// Transform a vector (rotation only).
    pub fn transform_vector(&self, v: &Vec3<From>) -> Vec3<To> {
        self.rotation.apply(v)
    }
    /// The inverse pose, taking `To` points into `From`.
    pub fn inverse(&self) -> Pose<From, To> {
        let r_inv = self.rotation.inverse();
        let t = -(r_inv.quaternion() * self.translation.p);
        Pose::new(r_inv, Point3::from_vector(t))
    }
    /// Compose with an inner pose: (To ← From) ∘ (From ← Inner) = (To ← Inner).
    pub fn then_from<Inner: Frame>(&self, inner: &Pose<From, Inner>) -> Pose<To, Inner> {
        let rotation = self.rotation.then_from(&inner.rotation);
        Pose::new(rotation, self.transform_point(&inner.translation))
    }
}

impl<To: Frame, From: Frame> Clone for Pose<To, From> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<To: Frame, From: Frame> Copy for Pose<To, From> {}
impl<To: Frame, From: Frame> fmt::Debug for Pose<To, From> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Pose").field("rotation", &self.rotation).field("translation", &self.translation).finish()
    }
}

/// The world-from-body pose of the vehicle at one instant.
pub type MapFromBody = Pose<Map, Body>;
/// The body-from-camera pose of a mounted camera (lever arm + boresight).
pub type BodyFromCamera = Pose<Body, Camera>;
/// The world-from-camera pose (exterior orientation) of a camera.
pub type MapFromCamera = Pose<Map, Camera>;

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn pose_inverse_round_trips_points() {
        let r = Rotation::<Map, Body>::from_quaternion(UnitQuaternion::from_euler_angles(0.1, -0.2, 1.3));
        let pose = Pose::new(r, Point3::new(100.0, 200.0, 30.0));
        let p = Point3::<Body>::new(1.5, -0.3, 2.0);
        let back = pose.inverse().transform_point(&pose.transform_point(&p));
        assert!((back - p).norm() < 1e-12);
    }

    #[test]
    fn half_turn_matrices_convert_exactly() {
        // nalgebra's iterative `UnitQuaternion::from_matrix` starts at the identity and fails for 180° turns.
        for axis in [Vector3::x_axis(), Vector3::y_axis(), Vector3::z_axis()] {
            let m = Rotation3::from_axis_angle(&axis, std::f64::consts::PI).into_inner();
            let r = Rotation::<Map, Body>::from_matrix(&m);
            assert!((r.matrix() - m).norm() < 1e-12, "{axis:?}");
        }
        // A slightly non-orthonormal input is projected onto the nearest rotation.
        let m = Rotation3::from_euler_angles(0.3, -0.2, 2.0).into_inner() * 1.000_001;
        let r = Rotation::<Map, Body>::from_matrix(&m);
        assert!((r.matrix() - m / 1.000_001).norm() < 1e-9);
    }

    #[test]
    fn composition_applies_inner_first() {
        let yaw90 = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2);
        let outer = Pose::<Map, Body>::new(Rotation::from_quaternion(yaw90), Point3::new(10.0, 0.0, 0.0));
        let inner = Pose::<Body, Camera>::new(Rotation::identity(), Point3::new(1.0, 0.0, 0.0));
        let composed = outer.then_from(&inner);
        // Camera origin is 1 m along body x, which the 90° yaw turns into map +y.
        let c = composed.transform_point(&Point3::origin());
        assert!((c - Point3::new(10.0, 1.0, 0.0)).norm() < 1e-12);
    }
}
