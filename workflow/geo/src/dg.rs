//! The direct-georeferencing formula with lever arm and boresight (Grejner-Brzezinska and Toth 2000 eq. (1))
//! and its inverse.
//!
//! r_M = r_INS + R_B^M · (s · R_C^B · r_C + b), where r_INS and R_B^M come from the trajectory, b is the
//! lever arm (camera projection centre in the body frame), R_C^B the boresight rotation, r_C the ray in the
//! camera frame and s its scale (the range along a unit ray).

use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

use crate::camera::{CameraModel, Pixel};
use crate::frames::{Body, BodyFromCamera, Camera, Map, MapFromBody, MapFromCamera, Point3, Rotation, Vec3};

/// Angles of a camera's boresight misalignment, radians: applied about the body axes to the nominal,
/// forward-looking mounting (camera z = body forward, camera x = body right, camera y = body down).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Boresight {
    /// About the body x (forward) axis.
    pub roll: f64,
    /// About the body y (right) axis.
    pub pitch: f64,
    /// About the body z (down) axis; +90° turns a forward-looking camera to look right.
    pub yaw: f64,
}

impl Boresight {
    /// Build from degrees.
    pub fn from_degrees(roll: f64, pitch: f64, yaw: f64) -> Self {
        Self { roll: roll.to_radians(), pitch: pitch.to_radians(), yaw: yaw.to_radians() }
    }

    /// R_C^B = Rz(yaw) · Ry(pitch) · Rx(roll) · R_nominal.
    pub fn to_rotation(&self) -> Rotation<Body, Camera> {
        let misalignment = nalgebra::Rotation3::from_euler_angles(self.roll, self.pitch, self.yaw).into_inner();
        // Columns: camera x → body right, camera y → body down, camera z → body forward.
        let nominal = Matrix3::new(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        Rotation::from_matrix(&(misalignment * nominal))
    }
}

/// How a camera is mounted on the vehicle: lever arm b and boresight R_C^B.
#[derive(Clone, Copy, Debug)]
pub struct CameraMount {
    /// Camera projection centre in the body frame, metres.
    pub lever_arm: Vec3<Body>,
    /// Camera-to-body rotation.
    pub boresight: Rotation<Body, Camera>,
}

impl CameraMount {
    /// Build from a lever arm (metres, body frame) and boresight angles.
    pub fn new(lever_arm: [f64; 3], boresight: &Boresight) -> Self {
        Self { lever_arm: Vec3::new(lever_arm[0], lever_arm[1], lever_arm[2]), boresight: boresight.to_rotation() }
    }

    /// The body-from-camera pose.
    pub fn body_from_camera(&self) -> BodyFromCamera {
        BodyFromCamera::new(self.boresight, Point3::origin() + self.lever_arm)
    }

    /// The camera's exterior orientation for a vehicle pose: centre r_INS + R_B^M b, rotation R_B^M R_C^B.
    pub fn camera_pose(&self, body: &MapFromBody) -> MapFromCamera {
        body.then_from(&self.body_from_camera())
    }

    /// Grejner-Brzezinska and Toth 2000 eq. (1): the mapping-frame point at scale `s` along the camera-frame ray `r_c`.
    pub fn georeference(&self, body: &MapFromBody, r_c: &Vec3<Camera>, s: f64) -> Point3<Map> {
        let in_body = self.boresight.apply(r_c) * s + self.lever_arm;
        body.translation + body.rotation.apply(&in_body)
    }

    /// Inverse of eq. (1): the camera-frame vector s · r_C from the camera centre to a mapping-frame point.
    pub fn to_camera(&self, body: &MapFromBody, p: &Point3<Map>) -> Vec3<Camera> {
        let in_body = body.rotation.inverse().apply(&(*p - body.translation)) - self.lever_arm;
        self.boresight.inverse().apply(&in_body)
    }

    /// The pixel a mapping-frame point images to, if it does.
    pub fn project<C: CameraModel>(&self, camera: &C, body: &MapFromBody, p: &Point3<Map>) -> Option<Pixel> {
        camera.project(&self.to_camera(body, p))
    }

    /// The mapping-frame ray (camera centre, unit direction) through a pixel.
    pub fn ray<C: CameraModel>(
        &self,
        camera: &C,
        body: &MapFromBody,
        pixel: Pixel,
    ) -> Option<(Point3<Map>, Vec3<Map>)> {
        let d = camera.unproject(pixel)?;
        let pose = self.camera_pose(body);
        Some((pose.translation, pose.rotation.apply(&d)))
    }
}

/// Intersect a mapping-frame ray with the horizontal plane z = `height`; `None` if parallel or behind.
pub fn intersect_height(origin: &Point3<Map>, direction: &Vec3<Map>, height: f64) -> Option<Point3<Map>> {
    if direction.z().abs() < 1e-12 {
        return None;
    }
    let s = (height - origin.z()) / direction.z();
    (s > 0.0).then(|| *origin + *direction * s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Attitude;
    use crate::camera::{Equirectangular, Pinhole};
    use proptest::prelude::*;

    fn vehicle(e: f64, n: f64, h: f64, att: Attitude) -> MapFromBody {
        MapFromBody::new(att.to_rotation(), Point3::new(e, n, h))
    }

    #[test]
    fn lever_arm_goes_forward_right_and_down_in_the_map() {
        // Vehicle facing east: body forward = east, right = south, down = −up.
        let body = vehicle(1000.0, 2000.0, 50.0, Attitude::from_degrees(0.0, 0.0, 90.0));
        let mount = CameraMount::new([1.0, 0.5, -2.0], &Boresight::default());
        let c = mount.camera_pose(&body).translation;
        assert!((c - Point3::new(1001.0, 1999.5, 52.0)).norm() < 1e-12, "{c:?}");
        // The nominal camera looks forward: east.
        let view = mount.camera_pose(&body).rotation.apply(&Vec3::new(0.0, 0.0, 1.0));
        assert!((view.v - nalgebra::Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn side_looking_boresight_looks_right() {
        let body = vehicle(0.0, 0.0, 0.0, Attitude::from_degrees(0.0, 0.0, 0.0));
        let mount = CameraMount::new([0.0, 0.0, 0.0], &Boresight::from_degrees(0.0, 0.0, 90.0));
        let view = mount.camera_pose(&body).rotation.apply(&Vec3::new(0.0, 0.0, 1.0));
        // Facing north, right is east.
        assert!((view.v - nalgebra::Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12, "{view:?}");
    }

    #[test]
    fn ground_point_of_a_pixel_projects_back_to_it() {
        let cam = Equirectangular::new(4096, 2048).unwrap();
        let body = vehicle(500.0, 600.0, 1.0, Attitude::from_degrees(1.0, -2.0, 33.0));
        let mount = CameraMount::new([0.3, 0.0, -1.9], &Boresight::from_degrees(0.2, -0.1, 0.5));
        let px = Pixel::new(1700.3, 1500.7); // below the horizon
        let (o, d) = mount.ray(&cam, &body, px).unwrap();
        let ground = intersect_height(&o, &d, 0.0).unwrap();
        let back = mount.project(&cam, &body, &ground).unwrap();
        assert!((back.u - px.u).abs() < 1e-8 && (back.v - px.v).abs() < 1e-8, "{back:?}");
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(3), ..ProptestConfig::default() })]

        #[test]
        fn dg_and_its_inverse_agree(
            e in -1e5f64..1e5, n in -1e5f64..1e5, h in -10f64..500.0,
            roll in -0.3f64..0.3, pitch in -0.3f64..0.3, heading in 0.0f64..std::f64::consts::TAU,
            lx in -3.0f64..3.0, ly in -3.0f64..3.0, lz in -3.0f64..3.0,
            br in -0.05f64..0.05, bp in -0.05f64..0.05, by in -3.2f64..3.2,
            rx in -1.0f64..1.0, ry in -1.0f64..1.0, s in 0.5f64..80.0,
        ) {
            let body = vehicle(e, n, h, Attitude::new(roll, pitch, heading));
            let mount = CameraMount::new([lx, ly, lz], &Boresight { roll: br, pitch: bp, yaw: by });
            let r_c = Vec3::<Camera>::new(rx, ry, 1.0).normalize().unwrap();
            let p = mount.georeference(&body, &r_c, s);
            let back = mount.to_camera(&body, &p);
            prop_assert!((back - r_c * s).norm() < 1e-7);
            // And through a pinhole: the pixel of the ray round-trips.
            let cam = Pinhole::new(2000, 1500, 1200.0, 1200.0, 1000.0, 750.0, -0.05, 0.01).unwrap();
            if let Some(px) = cam.project(&r_c) {
                let q = mount.project(&cam, &body, &p).unwrap();
                prop_assert!((q.u - px.u).abs() < 1e-5 && (q.v - px.v).abs() < 1e-5);
            }
        }
    }
}
