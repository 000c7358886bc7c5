//! Normalised residuals (residual / σ per component) of the observations the adjustment kept, evaluated at
//! its solution: the node corrections interpolated to each epoch and the adjusted tie points, with the
//! adjustment's own observation models (pole CUPT, spherical collinearity, aerial and GNSS coordinates).

use std::collections::{HashMap, HashSet};

use nalgebra::{Matrix3, Rotation3, Vector3, Vector6};
use plumbline_adjustment::{Adjustment, ObservationRef, ObservationSetV1, TiePoint};
use plumbline_geo::dg::CameraMount;
use plumbline_geo::{MapFromBody, Point3, PositionInterpolation, Rotation, Trajectory};
use plumbline_report::Residuals;

/// The observations left out of the solution: rejected by snooping or skipped as broken.
#[derive(Debug, Default)]
struct Excluded {
    whole: HashSet<(&'static str, usize)>,
    rays: HashSet<(usize, usize)>,
    aerial: HashSet<usize>,
}

impl Excluded {
    fn of(result: &Adjustment) -> Self {
        let mut out = Self::default();
        let items = result.rejected.iter().map(|r| &r.item).chain(result.skipped.iter().map(|s| &s.item));
        for item in items {
            match item {
                ObservationRef::TieRay { index, ray, .. } => _ = out.rays.insert((*index, *ray)),
                ObservationRef::TieAerial { index, .. } => _ = out.aerial.insert(*index),
                other => _ = out.whole.insert(crate::refs::owner(other)),
            }
        }
        out
    }
}

/// The corrected body pose at `t` as the adjustment models it: p' = p + δp, R' = Exp(δθ) R, with the DG pose
/// interpolated linearly and δ interpolated between nodes.
fn corrected_pose(dg: &Trajectory, result: &Adjustment, t: f64) -> Option<(Vector3<f64>, Matrix3<f64>, Vector6<f64>)> {
    let rec = dg.interpolate(t, PositionInterpolation::Linear).ok()?;
    let (d, _) = result.correction_at(t)?;
    let r = rec.attitude.to_rotation().matrix();
    Some((rec.position.p, r, d))
}

/// Normalised residuals of poles, tie points (rays and aerial coordinates) and GNSS positions; a kind without
/// kept observations is left out.
pub fn normalised_residuals(
    set: &ObservationSetV1,
    result: &Adjustment,
    dg: &Trajectory,
    mount: &CameraMount,
) -> Vec<Residuals> {
    let ex = Excluded::of(result);
    let mut poles = Vec::new();
    for (_, p) in set.poles.iter().enumerate().filter(|(i, _)| !ex.whole.contains(&("pole", *i))) {
        let Some((pos, _, d)) = corrected_pose(dg, result, p.time) else { continue };
        // Meyer et al. 2023 eq. (1): the observed pole moves with the corrected pose, σ = √(err_cam² + err_pole²)
        let offset = Vector3::new(p.observed[0], p.observed[1], pos.z) - pos;
        let moved = pos + d.fixed_rows::<3>(0) + Rotation3::new(d.fixed_rows::<3>(3).into_owned()) * offset;
        poles.extend([(moved.x - p.cadastre[0]) / p.sigma(), (moved.y - p.cadastre[1]) / p.sigma()]);
    }
    let points: HashMap<&str, Vector3<f64>> =
        result.points.iter().map(|p| (p.id.0.as_str(), Vector3::from(p.position))).collect();
    let mut ties = Vec::new();
    for (i, tie) in set.ties.iter().enumerate().filter(|(i, _)| !ex.whole.contains(&("tie", *i))) {
        let Some(x) = points.get(tie.id.0.as_str()) else { continue };
        tie_residuals(tie, i, x, &ex, dg, result, mount, &mut ties);
    }
    let mut gnss = Vec::new();
    for (_, g) in set.gnss.iter().enumerate().filter(|(i, _)| !ex.whole.contains(&("gnss", *i))) {
        let Some((pos, r, d)) = corrected_pose(dg, result, g.time) else { continue };
        let arm = Rotation3::new(d.fixed_rows::<3>(3).into_owned()) * (r * Vector3::from(g.lever_arm));
        let h = pos + d.fixed_rows::<3>(0) + arm;
        gnss.extend((0..3).map(|k| (h[k] - g.position[k]) / g.sigma[k]));
    }
    [("tie", ties), ("pole", poles), ("gnss", gnss)]
        .into_iter()
        .filter(|(_, v)| !v.is_empty())
        .map(|(kind, normalised)| Residuals { kind: kind.into(), normalised })
        .collect()
}

/// The residuals of one tie point's kept rays (two tangent components each) and aerial coordinates.
#[allow(clippy::too_many_arguments)]
fn tie_residuals(
    tie: &TiePoint,
    index: usize,
    x: &Vector3<f64>,
    ex: &Excluded,
    dg: &Trajectory,
    result: &Adjustment,
    mount: &CameraMount,
    out: &mut Vec<f64>,
) {
    for (_, ray) in tie.rays.iter().enumerate().filter(|(k, _)| !ex.rays.contains(&(index, *k))) {
        let Some((pos, r, d)) = corrected_pose(dg, result, ray.time) else { continue };
        let r_corr = Rotation3::new(d.fixed_rows::<3>(3).into_owned()).matrix() * r;
        let body = MapFromBody::new(Rotation::from_matrix(&r_corr), Point3::from_vector(pos + d.fixed_rows::<3>(0)));
        // Grejner-Brzezinska and Toth 2000 eq. (1) inverted: the direction to the point in the camera frame
        let u = mount.to_camera(&body, &Point3::from_vector(*x)).v.normalize();
        // across and elevation over their own σ, as the adjustment whitens them
        let ([b1, b2], [s1, s2]) = (ray.tangents().map(Vector3::from), ray.sigmas());
        out.extend([b1.dot(&u) / s1, b2.dot(&u) / s2]);
    }
    if let Some(a) = tie.aerial.filter(|_| !ex.aerial.contains(&index)) {
        out.extend((0..3).map(|k| (x[k] - a.position[k]) / a.covariance[k][k].sqrt()));
    }
}
