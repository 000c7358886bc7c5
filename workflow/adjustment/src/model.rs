//! Observation equations: whitened residuals and analytic Jacobians of each observation type with respect
//! to the pose correction δ = [δp; δθ] at its epoch (and the tie point's coordinates).
//!
//! The corrected pose is p' = p + δp, R' = Exp(δθ) · R (δθ a rotation vector in the mapping frame). Every
//! residual is whitened (divided by its standard deviation or multiplied by the inverse Cholesky factor of
//! its covariance), so a correct model gives unit-variance residuals.

use nalgebra::{Matrix3, Matrix3x6, Vector2, Vector3, Vector6};
use plumbline_geo::dg::CameraMount;
use plumbline_geo::{MapFromBody, Point3, Rotation};

use crate::so3::{exp, left_jacobian, right_jacobian, skew};

/// The DG pose of the body at an observation epoch.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DgPose {
    /// Body origin in the mapping frame.
    pub p: Vector3<f64>,
    /// R_B^M.
    pub r: Matrix3<f64>,
}

/// One observation linearised at the current estimate: whitened residual e = S (h(x) − z) and its Jacobians.
/// Rows at and beyond `dim` are zero.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Linearized {
    pub dim: usize,
    pub e: Vector3<f64>,
    pub j_pose: Matrix3x6<f64>,
    pub j_point: Matrix3<f64>,
}

impl Linearized {
    fn new(dim: usize) -> Self {
        Self { dim, e: Vector3::zeros(), j_pose: Matrix3x6::zeros(), j_point: Matrix3::zeros() }
    }
}

fn split(delta: &Vector6<f64>) -> (Vector3<f64>, Vector3<f64>) {
    (delta.fixed_rows::<3>(0).into_owned(), delta.fixed_rows::<3>(3).into_owned())
}

/// A body-fixed offset ℓ (already rotated into the map by the DG attitude) moved with the correction:
/// p + δp + Exp(δθ) ℓ, with its Jacobian [I | −[Exp(δθ)ℓ]× J_l(δθ)].
fn moved_offset(dg: &DgPose, delta: &Vector6<f64>, offset_map: &Vector3<f64>) -> (Vector3<f64>, Matrix3x6<f64>) {
    let (dp, dth) = split(delta);
    let rotated = exp(&dth) * offset_map;
    let mut j = Matrix3x6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
    j.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(&rotated) * left_jacobian(&dth)));
    (dg.p + dp + rotated, j)
}

/// Pole CUPT (Meyer et al. 2023 §3.4.2): the observed pole moves with the corrected pose; residual against the
/// cadastre position in easting/northing, σ from Meyer et al. 2023 eq. (1).
pub(crate) fn pole(
    dg: &DgPose,
    delta: &Vector6<f64>,
    observed: &Vector3<f64>,
    cadastre: &Vector2<f64>,
    sigma: f64,
) -> Linearized {
    let (h, j) = moved_offset(dg, delta, &(observed - dg.p));
    let mut out = Linearized::new(2);
    for row in 0..2 {
        out.e[row] = (h[row] - cadastre[row]) / sigma;
        out.j_pose.set_row(row, &(j.row(row) / sigma));
    }
    out
}

/// GNSS antenna position: p' + R' a against the measured position, per-axis σ.
pub(crate) fn gnss(
    dg: &DgPose,
    delta: &Vector6<f64>,
    lever_arm: &Vector3<f64>,
    measured: &Vector3<f64>,
    sigma: &Vector3<f64>,
) -> Linearized {
    let (h, j) = moved_offset(dg, delta, &(dg.r * lever_arm));
    let mut out = Linearized::new(3);
    for row in 0..3 {
        out.e[row] = (h[row] - measured[row]) / sigma[row];
        out.j_pose.set_row(row, &(j.row(row) / sigma[row]));
    }
    out
}

/// The orthonormal tangents (across, elevation) of the unit camera-frame direction `d` that a tie ray's two σ
/// refer to ([`crate::TieRay::tangents`]): elevation is the camera's up axis made perpendicular to `d`.
pub(crate) fn tangent_basis(d: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    crate::observations::ray_tangents(d)
}

/// Spherical collinearity: the unit direction from the corrected camera to the point, expressed in the
/// camera frame (inverse of Grejner-Brzezinska and Toth 2000 eq. (1) via [`CameraMount::to_camera`]), projected on the
/// tangent plane of the observed ray along (across, elevation) of [`tangent_basis`]; residuals in radians over
/// `sigma` = [σ across, σ elevation] (a diagonal covariance in that basis).
pub(crate) fn ray(
    dg: &DgPose,
    delta: &Vector6<f64>,
    mount: &CameraMount,
    point: &Vector3<f64>,
    direction: &Vector3<f64>,
    sigma: [f64; 2],
) -> Linearized {
    let (dp, dth) = split(delta);
    let r_corr = exp(&dth) * dg.r;
    let p_corr = dg.p + dp;
    let body = MapFromBody::new(Rotation::from_matrix(&r_corr), Point3::from_vector(p_corr));
    let v = mount.to_camera(&body, &Point3::from_vector(*point)).v;
    let norm = v.norm();
    let u = v / norm;
    let du_dv = (Matrix3::identity() - u * u.transpose()) / norm;
    let r_cb_t = mount.boresight.matrix().transpose();
    let dv_dx = r_cb_t * r_corr.transpose();
    let dv_dth = r_cb_t * dg.r.transpose() * skew(&(exp(&dth).transpose() * (point - p_corr))) * right_jacobian(&dth);
    let (b1, b2) = tangent_basis(direction);
    let mut out = Linearized::new(2);
    for (row, (b, sigma)) in [b1, b2].iter().zip(sigma).enumerate() {
        let g = b.transpose() * du_dv / sigma;
        out.e[row] = b.dot(&u) / sigma;
        out.j_pose.fixed_view_mut::<1, 3>(row, 0).copy_from(&(-g * dv_dx));
        out.j_pose.fixed_view_mut::<1, 3>(row, 3).copy_from(&(g * dv_dth));
        out.j_point.set_row(row, &(g * dv_dx));
    }
    out
}

/// Zero-velocity constraint over a standstill [s, e] (Meyer et al. 2023 §4.2.3: standstills are where the DG breaks):
/// with Δ = δ_e − δ_s (the node difference, built by interpolation weights −1 and +1), position
/// p_e + δp_e = p_s + δp_s, i.e. Δp + (p_e − p_s) = 0 (`offset` = p_e − p_s, 3 rows); or heading:
/// Exp(δθ_e) R_e = Exp(δθ_s) R_s about the vertical, to first order Δθ_up + Log(R_e R_sᵀ)_up = 0 (1 row;
/// roll and pitch are left free: the body settles on its suspension after braking). Residuals over σ.
pub(crate) fn standstill(delta: &Vector6<f64>, offset: &Vector3<f64>, sigma: f64, heading: bool) -> Linearized {
    if heading {
        let mut out = Linearized::new(1);
        out.e[0] = (delta[5] + offset.z) / sigma;
        out.j_pose[(0, 5)] = 1.0 / sigma;
        return out;
    }
    let mut out = Linearized::new(3);
    out.e = (delta.fixed_rows::<3>(0) + offset) / sigma;
    out.j_pose.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Matrix3::identity() / sigma));
    out
}

pub(crate) use plumbline_geo::angle::wrap;

/// Image-derived motion between two panoramas (Jende et al. 2017 §3.3 as the observation of
/// Cazzaniga et al. 2007 §4.1): with Δ = δ_end − δ_start (interpolation weights − at the start, + at the end), the
/// corrected displacement east, north is `dg` + Δp, and the corrected heading change `dg`_z − Δθ_up (a rotation about
/// up is counter-clockwise, the heading clockwise from north); residuals against `measured` over σ.
pub(crate) fn motion(
    delta: &Vector6<f64>,
    dg: &Vector3<f64>,
    measured: &Vector3<f64>,
    sigma: &Vector3<f64>,
) -> Linearized {
    let mut out = Linearized::new(3);
    for row in 0..2 {
        out.e[row] = (dg[row] + delta[row] - measured[row]) / sigma[row];
        out.j_pose[(row, row)] = 1.0 / sigma[row];
    }
    out.e[2] = wrap(dg.z - delta[5] - measured.z) / sigma.z;
    out.j_pose[(2, 5)] = -1.0 / sigma.z;
    out
}

/// Aerial-triangulated coordinates of a tie point: S (X − z) with Sᵀ S = C⁻¹.
pub(crate) fn aerial(point: &Vector3<f64>, measured: &Vector3<f64>, whitening: &Matrix3<f64>) -> Linearized {
    let mut out = Linearized::new(3);
    out.e = whitening * (point - measured);
    out.j_point = *whitening;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::Attitude;
    use plumbline_geo::dg::Boresight;

    /// Central differences of the whitened residual against the analytic Jacobian, at a non-zero state.
    fn check(f: impl Fn(&Vector6<f64>, &Vector3<f64>) -> Linearized, delta: Vector6<f64>, x: Vector3<f64>) {
        let lin = f(&delta, &x);
        let h = 1e-6;
        for c in 0..9 {
            let (mut dp, mut dm, mut xp, mut xm) = (delta, delta, x, x);
            if c < 6 {
                dp[c] += h;
                dm[c] -= h;
            } else {
                xp[c - 6] += h;
                xm[c - 6] -= h;
            }
            let numeric = (f(&dp, &xp).e - f(&dm, &xm).e) / (2.0 * h);
            let analytic =
                if c < 6 { lin.j_pose.column(c).into_owned() } else { lin.j_point.column(c - 6).into_owned() };
            let scale = analytic.norm().max(1.0);
            assert!((numeric - analytic).norm() < 1e-6 * scale, "column {c}: {numeric} vs {analytic}");
        }
    }

    fn dg() -> DgPose {
        DgPose { p: Vector3::new(1000.0, 2000.0, 50.0), r: Attitude::new(0.02, -0.03, 1.1).to_rotation().matrix() }
    }

    fn delta() -> Vector6<f64> {
        Vector6::new(0.3, -0.2, 0.1, 0.01, -0.02, 0.03)
    }

    #[test]
    fn jacobians_match_finite_differences_for_every_observation_type() {
        let observed = Vector3::new(1008.0, 2005.0, 50.0);
        let cadastre = Vector2::new(1008.2, 2004.9);
        check(|d, _| pole(&dg(), d, &observed, &cadastre, 0.1), delta(), Vector3::zeros());
        let lever = Vector3::new(-0.5, 0.2, -1.5);
        let sigma = Vector3::new(0.02, 0.03, 0.05);
        check(|d, _| gnss(&dg(), d, &lever, &Vector3::new(1000.0, 2000.0, 52.0), &sigma), delta(), Vector3::zeros());
        let mount = CameraMount::new([0.5, 0.1, -2.0], &Boresight::from_degrees(0.5, -0.3, 40.0));
        let dir = Vector3::new(0.3, 0.4, 0.8).normalize();
        for sigma in [[1e-3; 2], [1e-3, 7e-3]] {
            check(|d, x| ray(&dg(), d, &mount, x, &dir, sigma), delta(), Vector3::new(1010.0, 2008.0, 48.0));
        }
        let w = Matrix3::new(10.0, 0.0, 0.0, 2.0, 12.0, 0.0, -1.0, 3.0, 20.0);
        check(|_, x| aerial(x, &Vector3::new(1.0, 2.0, 3.0), &w), delta(), Vector3::new(1.2, 1.9, 3.3));
        let offset = Vector3::new(0.1, -0.5, 0.02);
        for heading in [false, true] {
            check(|d, _| standstill(d, &offset, 0.005, heading), delta(), Vector3::zeros());
        }
        let (dg_motion, measured) = (Vector3::new(4.0, 3.0, 0.2), Vector3::new(4.1, 2.9, 0.25));
        check(|d, _| motion(d, &dg_motion, &measured, &Vector3::new(0.02, 0.03, 1e-3)), delta(), Vector3::zeros());
    }

    #[test]
    fn residuals_vanish_for_the_true_correction() {
        // A pole observed with the DG pose is explained exactly by the correction that made the DG pose
        // (level vehicle, heading correction only: the observed lever stays horizontal, as the model takes it).
        let level = DgPose { p: dg().p, r: Attitude::new(0.0, 0.0, 1.1).to_rotation().matrix() };
        let d = Vector6::new(0.3, -0.2, 0.1, 0.0, 0.0, 0.03);
        let truth = DgPose { p: level.p + d.fixed_rows::<3>(0), r: exp(&d.fixed_rows::<3>(3).into_owned()) * level.r };
        let b = Vector3::new(8.0, 6.0, 0.0);
        let c = truth.p + truth.r * b;
        let lin = pole(&level, &d, &(level.p + level.r * b), &c.xy(), 0.1);
        assert!(lin.e.norm() < 1e-9, "{}", lin.e);
        // A different correction leaves a residual of the size it moves the pole.
        let wrong = pole(&level, &(d * 0.5), &(level.p + level.r * b), &c.xy(), 0.1);
        assert!(wrong.e.norm() > 1.0);
        // Tie ray from the true pose, any attitude correction.
        let mount = CameraMount::new([0.5, 0.1, -2.0], &Boresight::default());
        let x = Vector3::new(1010.0, 2008.0, 48.0);
        let truth = DgPose {
            p: dg().p + delta().fixed_rows::<3>(0),
            r: exp(&delta().fixed_rows::<3>(3).into_owned()) * dg().r,
        };
        let body = MapFromBody::new(Rotation::from_matrix(&truth.r), Point3::from_vector(truth.p));
        let dir = mount.to_camera(&body, &Point3::from_vector(x)).v.normalize();
        assert!(ray(&dg(), &delta(), &mount, &x, &dir, [1e-3, 4e-3]).e.norm() < 1e-9);
    }

    #[test]
    fn a_ray_residual_splits_into_across_and_elevation_over_their_own_sigmas() {
        // Camera at the DG pose; the point seen 20° below the horizon, 30° to the right. Observed rays turned
        // by a known small angle ε in azimuth or elevation give a residual of ε / σ in that row only.
        let mount = CameraMount::new([0.5, 0.1, -2.0], &Boresight::from_degrees(0.5, -0.3, 40.0));
        let level = DgPose { p: dg().p, r: Attitude::new(0.0, 0.0, 1.1).to_rotation().matrix() };
        let body = MapFromBody::new(Rotation::from_matrix(&level.r), Point3::from_vector(level.p));
        let (az, el, range) = (30f64.to_radians(), -20f64.to_radians(), 12.0);
        let along = |az: f64, el: f64| Vector3::new(el.cos() * az.sin(), -el.sin(), el.cos() * az.cos());
        let camera = mount.camera_pose(&body);
        let x = camera.translation.p + camera.rotation.matrix() * along(az, el) * range;
        let (sigma, eps) = ([1e-3, 5e-3], 2e-4);
        for (turned, want) in [(along(az + eps / el.cos(), el), [1.0, 0.0]), (along(az, el + eps), [0.0, 1.0])] {
            let e = ray(&level, &Vector6::zeros(), &mount, &x, &turned, sigma).e;
            // The residual is predicted − observed: the opposite sign of the turn.
            for row in 0..2 {
                let expect = -want[row] * eps / sigma[row];
                assert!((e[row] - expect).abs() < 1e-3 * eps / sigma[0], "row {row}: {} vs {expect}", e[row]);
            }
        }
    }

    #[test]
    fn a_motion_is_explained_by_the_true_corrections_at_its_ends() {
        // Truth: 0.4 rad of turn over 6 m; the DG carries different position and heading errors at both ends.
        let (h0, h1) = (1.1, 1.5);
        let (p0, p1) = (Vector3::new(100.0, 200.0, 50.0), Vector3::new(105.0, 203.0, 50.2));
        let (d0, d1) = (Vector6::new(0.3, -0.2, 0.1, 0.0, 0.0, 0.004), Vector6::new(-0.1, 0.5, 0.0, 0.0, 0.0, -0.006));
        let dg_end = |p: Vector3<f64>, h: f64, d: &Vector6<f64>| {
            let r = exp(&-d.fixed_rows::<3>(3).into_owned()) * Attitude::new(0.0, 0.0, h).to_rotation().matrix();
            (p - d.fixed_rows::<3>(0), Attitude::from_rotation(&Rotation::from_matrix(&r)).heading)
        };
        let ((a, ha), (b, hb)) = (dg_end(p0, h0, &d0), dg_end(p1, h1, &d1));
        let dg_motion = Vector3::new(b.x - a.x, b.y - a.y, wrap(hb - ha));
        let measured = Vector3::new(p1.x - p0.x, p1.y - p0.y, h1 - h0);
        let sigma = Vector3::new(0.02, 0.02, 1e-3);
        let lin = motion(&(d1 - d0), &dg_motion, &measured, &sigma);
        assert!(lin.e.norm() < 1e-6, "{}", lin.e);
        // Without the corrections the residual shows the DG's relative error (0.7 m north, 10 mrad of turn).
        let raw = motion(&Vector6::zeros(), &dg_motion, &measured, &sigma);
        assert!((raw.e[1] * 0.02 + 0.7).abs() < 1e-9 && (raw.e[2] * 1e-3 + 0.01).abs() < 1e-6, "{}", raw.e);
    }
}
