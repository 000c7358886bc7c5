//! Observation messages shared by the registration and pole workers and the adjuster: tie points (panorama
//! rays to aerial-triangulated points), pole coordinate updates, GNSS positions and the image-derived motion
//! between consecutive panoramas, versioned on the wire.
//!
//! All coordinates are in the campaign's mapping frame (`Map`: easting, northing, height, metres); ray
//! directions are unit vectors in the panorama's camera frame (x right, y down, z centre column); times are
//! on the trajectory's time scale (seconds). Standard deviations are one-sigma.

use serde::{Deserialize, Serialize};

/// A versioned set of observations, as one tile (or one file) delivers them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(tag = "version")]
pub enum ObservationSet {
    /// Version 1.
    #[serde(rename = "1")]
    V1(ObservationSetV1),
}

impl ObservationSet {
    /// The observations of the newest version (upgrading older ones when there are any).
    pub fn into_latest(self) -> ObservationSetV1 {
        match self {
            ObservationSet::V1(v) => v,
        }
    }
}

/// Version 1 of the observation set.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ObservationSetV1 {
    /// Tie points: a ground point seen in two or more panoramas, optionally triangulated in aerial images.
    #[serde(default)]
    pub ties: Vec<TiePoint>,
    /// Pole coordinate updates (2D control from cadastres).
    #[serde(default)]
    pub poles: Vec<PoleUpdate>,
    /// GNSS antenna positions.
    #[serde(default)]
    pub gnss: Vec<GnssPosition>,
    /// Which tie points' aerial coordinates come from the same aerial frames (they share those frames'
    /// orientation errors, so their heights share one bias). Optional: sets written before this field
    /// existed parse unchanged, and their aerial heights are then weighted as independent.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub aerial_frame_sets: Vec<AerialFrameSet>,
    /// The motion between consecutive panoramas measured by the images (MM↔MM registration, Jende et al. 2017
    /// §3.3), a relative observation of the corrected trajectory. Optional: older sets parse unchanged.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub motions: Vec<RelativeMotion>,
}

impl ObservationSetV1 {
    /// Append another set's observations.
    pub fn extend(&mut self, other: ObservationSetV1) {
        self.ties.extend(other.ties);
        self.poles.extend(other.poles);
        self.gnss.extend(other.gnss);
        self.aerial_frame_sets.extend(other.aerial_frame_sets);
        self.motions.extend(other.motions);
    }
}

/// Tie points whose aerial coordinates were triangulated from one set of aerial frames (Jende et al. 2017 §3.9).
/// With the base-to-height ratio of a few per cent of nadir frames, a small error in the frames' relative
/// orientation moves every height triangulated from them by the same decimetres: the adjustment gives each
/// set one height bias (a nuisance parameter) instead of trusting those heights as independent.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AerialFrameSet {
    /// The aerial frame ids, sorted.
    pub frames: Vec<String>,
    /// The tie points (with aerial coordinates) triangulated from these frames.
    pub ties: Vec<TiePointId>,
}

/// Identifier of a tie point, unique within a campaign.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(transparent)]
pub struct TiePointId(pub String);

/// A point observed as rays from two or more panoramas, with optional aerial-triangulated coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TiePoint {
    /// Campaign-unique id.
    pub id: TiePointId,
    /// The rays, one per panorama (at least two).
    pub rays: Vec<TieRay>,
    /// Coordinates from the aerial triangulation (Jende et al. 2017 §3.9), if the point was matched in aerial images.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aerial: Option<AerialPoint>,
}

/// One panorama's ray to a tie point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TieRay {
    /// Exposure time of the panorama.
    pub time: f64,
    /// Unit direction to the point in the camera frame.
    pub direction: [f64; 3],
    /// Angular standard deviation of the direction, radians: in every direction when `sigma_elevation` is
    /// absent, otherwise across the ray's vertical plane (along the tangent `direction × t_el`, see
    /// [`TieRay::tangents`]).
    pub sigma: f64,
    /// Angular standard deviation in the ray's vertical plane, radians: along the unit tangent `t_el` of
    /// increasing elevation, the camera's up axis (−y) projected perpendicular to `direction`. Absent: `sigma`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_elevation: Option<f64>,
}

impl TieRay {
    /// An isotropic ray: `sigma` in every direction.
    pub fn new(time: f64, direction: [f64; 3], sigma: f64) -> Self {
        Self { time, direction, sigma, sigma_elevation: None }
    }

    /// The standard deviations along [`TieRay::tangents`]: [across, elevation], radians.
    pub fn sigmas(&self) -> [f64; 2] {
        [self.sigma, self.sigma_elevation.unwrap_or(self.sigma)]
    }

    /// The orthonormal tangents of the direction the two σ refer to, in the camera frame: [`direction × t_el`,
    /// `t_el`] with `t_el` the camera's up axis (−y) made perpendicular to the direction (increasing elevation;
    /// the across tangent points to increasing azimuth, camera +x for a ray along +z). For a ray within
    /// 1e-9 of the camera's vertical axis, where elevation has no direction, any orthonormal pair.
    pub fn tangents(&self) -> [[f64; 3]; 2] {
        let (across, elevation) = ray_tangents(&nalgebra::Vector3::from(self.direction));
        [across.into(), elevation.into()]
    }
}

/// [`TieRay::tangents`] of a unit direction `d`: (across, elevation).
pub(crate) fn ray_tangents(d: &nalgebra::Vector3<f64>) -> (nalgebra::Vector3<f64>, nalgebra::Vector3<f64>) {
    let up = -nalgebra::Vector3::y();
    let elevation = (up - d * d.dot(&up)).try_normalize(1e-9).unwrap_or_else(|| {
        let helper = if d.x.abs() < 0.9 { nalgebra::Vector3::x() } else { nalgebra::Vector3::z() };
        d.cross(&helper).normalize()
    });
    (d.cross(&elevation), elevation)
}

/// Mapping-frame coordinates of a point from aerial triangulation with their covariance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AerialPoint {
    /// Easting, northing, height, metres.
    pub position: [f64; 3],
    /// 3×3 covariance, m², row-major, symmetric positive definite.
    pub covariance: [[f64; 3]; 3],
}

/// A pole coordinate update (CUPT, Meyer et al. 2023 §3.4.2): a cadastre pole observed from the vehicle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PoleUpdate {
    /// Id of the pole in its cadastre.
    pub cadastre_id: String,
    /// Epoch of the depth image the pole was measured in.
    pub time: f64,
    /// The pole's cadastre position: easting, northing.
    pub cadastre: [f64; 2],
    /// The pole's position as observed with the DG pose at `time`: easting, northing.
    pub observed: [f64; 2],
    /// Standard deviation of the observation by the mapping sensor (err_cam), metres.
    pub sigma_camera: f64,
    /// Standard deviation of the cadastre position (err_pole), metres.
    pub sigma_pole: f64,
}

impl PoleUpdate {
    /// err_{x,y} = √(err_cam² + err_pole²), per horizontal coordinate.
    pub fn sigma(&self) -> f64 {
        // Meyer et al. 2023 eq. (1)
        self.sigma_camera.hypot(self.sigma_pole)
    }

    /// The coordinate update: cadastre minus observed position (easting, northing).
    pub fn difference(&self) -> [f64; 2] {
        [self.cadastre[0] - self.observed[0], self.cadastre[1] - self.observed[1]]
    }
}

/// The motion of the body origin between two panoramas as the images measured it (the ortho-projected
/// neighbouring panoramas registered to each other, Jende et al. 2017 §3.3): it observes the corrected trajectory's
/// relative motion independently of the DG, so it bridges a DG jump between them (Cazzaniga et al. 2007 §4.1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RelativeMotion {
    /// Exposure time of the first panorama, s.
    pub start: f64,
    /// Exposure time of the second panorama, s.
    pub end: f64,
    /// Displacement of the body origin east and north, m.
    pub displacement: [f64; 2],
    /// Heading change (clockwise from north, Applanix), rad.
    pub heading_change: f64,
    /// σ of the east and north displacement (m) and of the heading change (rad).
    pub std: [f64; 3],
}

/// A GNSS antenna position.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GnssPosition {
    /// Epoch.
    pub time: f64,
    /// Easting, northing, height, metres.
    pub position: [f64; 3],
    /// Standard deviations of easting, northing, height, metres.
    pub sigma: [f64; 3],
    /// Antenna phase centre in the body frame (x forward, y right, z down), metres.
    #[serde(default)]
    pub lever_arm: [f64; 3],
}

/// Which observation of a set an item refers to.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ObservationRef {
    /// `poles[index]`.
    Pole { index: usize, cadastre_id: String },
    /// `gnss[index]`.
    Gnss { index: usize },
    /// Ray `ray` of `ties[index]`.
    TieRay { index: usize, point: TiePointId, ray: usize },
    /// The aerial coordinates of `ties[index]`.
    TieAerial { index: usize, point: TiePointId },
    /// The whole tie point `ties[index]`.
    Tie { index: usize, point: TiePointId },
}

/// A defect of one observation, naming it and the field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{item:?}: field `{field}` {problem}")]
pub struct ObservationError {
    /// The observation.
    pub item: ObservationRef,
    /// The offending field.
    pub field: &'static str,
    /// What is wrong with it.
    pub problem: String,
}

fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

fn check(out: &mut Vec<ObservationError>, ok: bool, item: &ObservationRef, field: &'static str, problem: &str) {
    if !ok {
        out.push(ObservationError { item: item.clone(), field, problem: problem.to_owned() });
    }
}

impl PoleUpdate {
    /// Every defect of this update.
    pub fn problems(&self, index: usize) -> Vec<ObservationError> {
        let item = ObservationRef::Pole { index, cadastre_id: self.cadastre_id.clone() };
        let mut out = Vec::new();
        check(&mut out, self.time.is_finite(), &item, "time", "is not finite");
        check(&mut out, finite(&self.cadastre), &item, "cadastre", "is not finite");
        check(&mut out, finite(&self.observed), &item, "observed", "is not finite");
        check(&mut out, self.sigma_camera >= 0.0, &item, "sigma_camera", "must be ≥ 0");
        check(&mut out, self.sigma_pole >= 0.0, &item, "sigma_pole", "must be ≥ 0");
        check(&mut out, self.sigma() > 0.0 && self.sigma().is_finite(), &item, "sigma_camera", "gives σ = 0");
        out
    }
}

impl GnssPosition {
    /// Every defect of this position.
    pub fn problems(&self, index: usize) -> Vec<ObservationError> {
        let item = ObservationRef::Gnss { index };
        let mut out = Vec::new();
        check(&mut out, self.time.is_finite(), &item, "time", "is not finite");
        check(&mut out, finite(&self.position), &item, "position", "is not finite");
        check(&mut out, finite(&self.lever_arm), &item, "lever_arm", "is not finite");
        let positive = self.sigma.iter().all(|s| *s > 0.0 && s.is_finite());
        check(&mut out, positive, &item, "sigma", "must be > 0 and finite");
        out
    }
}

/// A defect of one relative motion (`motions[index]`), naming the field. (Motions are not in
/// [`ObservationRef`], whose variants the services match exhaustively; they are reported on their own.)
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("motions[{index}]: field `{field}` {problem}")]
pub struct MotionError {
    /// Index in `motions`.
    pub index: usize,
    /// The offending field.
    pub field: &'static str,
    /// What is wrong with it.
    pub problem: String,
}

impl RelativeMotion {
    /// Every defect of this motion.
    pub fn problems(&self, index: usize) -> Vec<MotionError> {
        let mut out = Vec::new();
        let mut check = |ok: bool, field: &'static str, problem: &str| {
            if !ok {
                out.push(MotionError { index, field, problem: problem.to_owned() });
            }
        };
        check(finite(&[self.start, self.end]), "start", "is not finite");
        check(self.end > self.start, "end", "must be after start");
        check(finite(&self.displacement), "displacement", "is not finite");
        check(self.heading_change.is_finite(), "heading_change", "is not finite");
        check(self.std.iter().all(|s| *s > 0.0 && s.is_finite()), "std", "must be > 0 and finite");
        out
    }
}

impl TiePoint {
    /// Every defect of this tie point.
    pub fn problems(&self, index: usize) -> Vec<ObservationError> {
        let item = ObservationRef::Tie { index, point: self.id.clone() };
        let mut out = Vec::new();
        let enough = self.rays.len() >= 2 || (!self.rays.is_empty() && self.aerial.is_some());
        check(&mut out, enough, &item, "rays", "needs ≥ 2 rays, or 1 ray and aerial coordinates");
        for r in &self.rays {
            check(&mut out, r.time.is_finite(), &item, "rays.time", "is not finite");
            let n = nalgebra::Vector3::from(r.direction).norm();
            check(&mut out, (n - 1.0).abs() < 1e-6, &item, "rays.direction", "is not a unit vector");
            check(&mut out, r.sigma > 0.0 && r.sigma.is_finite(), &item, "rays.sigma", "must be > 0 and finite");
            let elevation_ok = r.sigma_elevation.is_none_or(|s| s > 0.0 && s.is_finite());
            check(&mut out, elevation_ok, &item, "rays.sigma_elevation", "must be > 0 and finite");
        }
        if let Some(a) = &self.aerial {
            check(&mut out, finite(&a.position), &item, "aerial.position", "is not finite");
            let ok = aerial_whitening(&a.covariance).is_some();
            check(&mut out, ok, &item, "aerial.covariance", "is not symmetric positive definite");
        }
        out
    }
}

/// S with Sᵀ S = C⁻¹ (inverse Cholesky factor) for a symmetric positive-definite covariance.
pub(crate) fn aerial_whitening(c: &[[f64; 3]; 3]) -> Option<nalgebra::Matrix3<f64>> {
    let m = nalgebra::Matrix3::from_fn(|i, j| c[i][j]);
    if !finite(m.as_slice()) || (m - m.transpose()).abs().max() > 1e-9 * m.abs().max().max(1e-300) {
        return None;
    }
    let l = nalgebra::Cholesky::new(m)?.l();
    l.try_inverse()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pole() -> PoleUpdate {
        PoleUpdate {
            cadastre_id: "p7".into(),
            time: 10.0,
            cadastre: [100.0, 200.0],
            observed: [100.3, 199.6],
            sigma_camera: 0.3,
            sigma_pole: 0.4,
        }
    }

    #[test]
    fn pole_sigma_adds_quadratically() {
        assert!((pole().sigma() - 0.5).abs() < 1e-15);
        let d = pole().difference();
        assert!((d[0] + 0.3).abs() < 1e-12 && (d[1] - 0.4).abs() < 1e-12);
    }

    #[test]
    fn sets_round_trip_through_json_with_their_version() {
        let set = ObservationSet::V1(ObservationSetV1 {
            ties: vec![TiePoint {
                id: TiePointId("t1".into()),
                rays: vec![TieRay::new(1.0, [0.0, 0.6, 0.8], 1e-3); 2],
                aerial: Some(AerialPoint { position: [1.0, 2.0, 3.0], covariance: [[0.01, 0.0, 0.0]; 3] }),
            }],
            poles: vec![pole()],
            gnss: vec![GnssPosition { time: 2.0, position: [1.0; 3], sigma: [0.02; 3], lever_arm: [0.0; 3] }],
            aerial_frame_sets: vec![AerialFrameSet {
                frames: vec!["a1".into(), "a2".into()],
                ties: vec![TiePointId("t1".into())],
            }],
            motions: vec![RelativeMotion {
                start: 1.0,
                end: 1.5,
                displacement: [4.0, 3.0],
                heading_change: 0.01,
                std: [0.02, 0.02, 1e-3],
            }],
        });
        let json = serde_json::to_string(&set).unwrap();
        assert!(json.starts_with(r#"{"version":"1""#), "{json}");
        assert_eq!(serde_json::from_str::<ObservationSet>(&json).unwrap(), set);
        assert!(serde_json::from_str::<ObservationSet>(r#"{"version":"9"}"#).is_err());
    }

    #[test]
    fn sets_without_frame_sets_still_parse() {
        let old = r#"{"version":"1","ties":[],"poles":[],"gnss":[]}"#;
        let set = serde_json::from_str::<ObservationSet>(old).unwrap().into_latest();
        assert!(set.aerial_frame_sets.is_empty() && set.motions.is_empty());
        let json = serde_json::to_string(&ObservationSet::V1(set)).unwrap();
        assert!(!json.contains("aerial_frame_sets"), "an empty list is not written: {json}");
        assert!(!json.contains("motions"), "an empty list is not written: {json}");
    }

    #[test]
    fn a_ray_with_an_elevation_sigma_round_trips_and_old_rays_keep_their_meaning() {
        let old: TieRay = serde_json::from_str(r#"{"time":1.0,"direction":[0.0,0.6,0.8],"sigma":0.002}"#).unwrap();
        assert_eq!(old, TieRay::new(1.0, [0.0, 0.6, 0.8], 0.002));
        assert_eq!(old.sigmas(), [0.002, 0.002]);
        assert!(!serde_json::to_string(&old).unwrap().contains("sigma_elevation"));
        let ray = TieRay { sigma_elevation: Some(0.005), ..old };
        assert_eq!(ray.sigmas(), [0.002, 0.005]);
        assert_eq!(serde_json::from_str::<TieRay>(&serde_json::to_string(&ray).unwrap()).unwrap(), ray);
        let tie = |sigma_elevation| TiePoint {
            id: TiePointId("t".into()),
            rays: vec![ray, TieRay { sigma_elevation, ..ray }],
            aerial: None,
        };
        for bad in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
            let fields: Vec<_> = tie(Some(bad)).problems(0).iter().map(|e| e.field).collect();
            assert_eq!(fields, ["rays.sigma_elevation"], "{bad}");
        }
        assert!(tie(None).problems(0).is_empty());
    }

    #[test]
    fn the_elevation_tangent_points_up_in_the_rays_vertical_plane() {
        let v = |a: [f64; 3]| nalgebra::Vector3::from(a);
        // A ray 30° below the horizon, 40° right of the centre column (camera: x right, y down, z forward).
        let (az, el) = (40f64.to_radians(), -30f64.to_radians());
        let d = [el.cos() * az.sin(), -el.sin(), el.cos() * az.cos()];
        let [across, elevation] = TieRay::new(0.0, d, 1e-3).tangents();
        // ∂d/∂elevation and ∂d/∂azimuth / cos(elevation) of the equirectangular parametrisation.
        let want_el = [-el.sin() * az.sin(), -el.cos(), -el.sin() * az.cos()];
        let want_az = [az.cos(), 0.0, -az.sin()];
        assert!((v(elevation) - v(want_el)).norm() < 1e-12, "{elevation:?}");
        assert!((v(across) - v(want_az)).norm() < 1e-12, "{across:?}");
        // Straight down: no elevation direction, still an orthonormal pair perpendicular to the ray.
        let [a, b] = TieRay::new(0.0, [0.0, 1.0, 0.0], 1e-3).tangents();
        let (a, b) = (v(a), v(b));
        assert!((a.norm() - 1.0).abs() < 1e-12 && (b.norm() - 1.0).abs() < 1e-12);
        assert!(a.dot(&b).abs() < 1e-12 && a.y.abs() < 1e-12 && b.y.abs() < 1e-12);
    }

    #[test]
    fn the_schema_requires_the_version_tag() {
        let schema = serde_json::to_value(schemars::schema_for!(ObservationSet)).unwrap();
        let text = schema.to_string();
        assert!(text.contains("\"version\"") && text.contains("\"1\""), "{text}");
        assert!(text.contains("sigma_camera") && text.contains("covariance"));
    }

    #[test]
    fn problems_name_the_item_and_field() {
        let mut p = pole();
        p.sigma_camera = -1.0;
        let problems = p.problems(4);
        assert_eq!(problems[0].field, "sigma_camera");
        assert!(problems[0].to_string().contains("index: 4"), "{}", problems[0]);
        let tie = TiePoint {
            id: TiePointId("t".into()),
            rays: vec![TieRay::new(1.0, [0.0, 0.0, 2.0], 1e-3)],
            aerial: Some(AerialPoint {
                position: [0.0; 3],
                covariance: [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            }),
        };
        let fields: Vec<_> = tie.problems(0).iter().map(|e| e.field).collect();
        assert_eq!(fields, ["rays.direction", "aerial.covariance"]);
        assert!(pole().problems(0).is_empty());
        let motion =
            RelativeMotion { start: 2.0, end: 1.0, displacement: [0.0; 2], heading_change: 0.0, std: [0.0; 3] };
        let problems = motion.problems(3);
        let fields: Vec<_> = problems.iter().map(|e| e.field).collect();
        assert_eq!(fields, ["end", "std"]);
        assert!(problems[0].to_string().starts_with("motions[3]: field `end`"), "{}", problems[0]);
    }
}
