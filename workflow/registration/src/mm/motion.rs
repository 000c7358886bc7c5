//! The vehicle's motion between two neighbouring panoramas as their ortho-images measure it (Jende et al. 2017 §3.3,
//! Cazzaniga et al. 2007 §4.1): the KAZE + RANSAC similarity between the ortho-images, read as the displacement of the
//! body origin and the heading change, with σ, independently of the DG trajectory's relative accuracy.
//!
//! Derivation (Jende et al. 2017 §3.3, Cazzaniga et al. 2007 §4.1). Over flat ground, an ortho-image made with a pose P
//! (horizontal camera centre c, yaw θ counter-clockwise from east) of a panorama taken at the true pose P*
//! shows the ground point g at
//!     x = c + R(θ − θ*) (g − c*) = P ∘ P*⁻¹ (g),   with P(l) = c + R(θ) l.
//! (A height error moves the ortho plane with the camera and cancels; roll and pitch are applied by the
//! ortho-projection and leave their error only.) From A's ortho-image to B's the ground therefore moves by
//! the rigid map-frame transformation
//!     M = P_B ∘ P*_B⁻¹ ∘ P*_A ∘ P_A⁻¹,
//! which is the KAZE similarity H read in map coordinates, M = G_B · H · G_A⁻¹ (G: the grids'
//! map-from-pixel matrices; the DG orientation predicts M = identity), here re-fitted to H's inliers in map
//! coordinates (below). Keeping B at its DG pose, A's pose as the images see it is M ∘ P_A (then
//! P_B⁻¹ ∘ M ∘ P_A = P*_B⁻¹ ∘ P*_A, the true relative pose). The body origin o is rigid in P's frame (its
//! horizontal offset from the camera centre is the rotated lever arm), so A's body origin as the images see
//! it is M(o_A) and
//!     displacement = o_B − M(o_A) = (o_B − o_A) − (M(o_A) − o_A):
//! the DG displacement minus where the transformation moves the ground point under A's body origin
//! relative to the orientation-based prediction. The rotation of M is rot(M) = (θ_B − θ_A) − (θ*_B − θ*_A)
//! and θ = π/2 − ψ with ψ the Applanix heading (clockwise from north), so
//!     Δψ* = (ψ_B − ψ_A) + rot(M).
//! What remains is B's absolute DG heading error times the displacement (0.01° × 5 m < 1 mm).
//!
//! σ: the similarity is re-fitted to the RANSAC inliers by weighted least squares in map coordinates around
//! o_A (q = o_A + S (p − o_A) + t, so t = M(o_A) − o_A). A feature's ortho position is as sharp as the
//! panorama's ground footprint, which grows as (r² + h²)/h with its distance r from the camera (h: camera
//! height), so each correspondence is weighted by 1 / ((r_A² + h²)² + (r_B² + h²)²); correspondences whose
//! normalised residual fails the χ²₂ test at 0.1 % are dropped and the fit repeated. The covariance is
//! σ₀² N⁻¹ with σ₀² the weighted sum of squared residuals (metres: pixels × GSD) over 2n − 4 degrees of
//! freedom — at the inliers' centroid σ₀/√n per axis; o_A lies under the vehicle, off the centroid, which N
//! accounts for. Features of the same marking share their errors (the same blur at the same ranges), so n
//! does not average everything away: a floor ([`MmConfig::motion_std_floor`]) is added in quadrature.

use nalgebra::{Matrix3, Matrix4, Vector2, Vector3, Vector4};
use plumbline_geo::Attitude;
use plumbline_geo::angle::wrap;
use plumbline_imaging::models::Correspondence;
use plumbline_navigation::ImageMotion;

use super::ortho::OrthoPatch;
use super::transform::FeatureFit;
use super::{MmConfig, Panorama};

#[cfg(test)]
mod tests;

/// χ²₂ at 0.1 %: the largest normalised squared residual a correspondence may keep.
const CHI2_2_999: f64 = 13.816;

/// The body-origin displacement and heading change between panoramas `a` and `b` measured by the inliers of
/// `fit` (A's ortho pixels to B's; the similarity is re-fitted to them), in time order (start = the earlier exposure; a backward pair is
/// reversed). `camera_height` is the rig's camera height above the road (metres, weights by range). `None`
/// when the exposure times coincide or fewer than three consistent inliers remain.
pub fn image_motion(
    a: (&Panorama, &OrthoPatch),
    b: (&Panorama, &OrthoPatch),
    fit: &FeatureFit,
    camera_height: f64,
    config: &MmConfig,
) -> Option<ImageMotion> {
    let (oa, ob) = (a.0.pose.translation, b.0.pose.translation);
    let origin = Vector2::new(oa.x(), oa.y());
    let rows = weighted_rows(origin, (a.1, b.1), &fit.inliers, camera_height)?;
    let similarity = fit_similarity(&rows)?;
    // Cazzaniga et al. 2007 §4.1: displacement = (o_B − o_A) − (M(o_A) − o_A); Δψ = (ψ_B − ψ_A) + rot(M).
    let shift = similarity.shift;
    let displacement = [ob.x() - oa.x() - shift.x, ob.y() - oa.y() - shift.y];
    let heading = |p: &Panorama| Attitude::from_rotation(&p.pose.rotation).heading;
    let heading_change = wrap(heading(b.0) - heading(a.0) + similarity.rotation);
    let [floor_m, floor_rad] = config.motion_std_floor;
    let [se, sn, sr] = similarity.std;
    let std = [se.hypot(floor_m), sn.hypot(floor_m), sr.hypot(floor_rad)];
    let motion = ImageMotion { start: a.0.time, end: b.0.time, displacement, heading_change, std };
    let finite = displacement.iter().chain(&std).all(|v| v.is_finite()) && heading_change.is_finite();
    if !finite || a.0.time == b.0.time {
        return None;
    }
    Some(if b.0.time < a.0.time { reversed(motion) } else { motion })
}

/// The same motion from B to A.
fn reversed(m: ImageMotion) -> ImageMotion {
    let displacement = [-m.displacement[0], -m.displacement[1]];
    ImageMotion { start: m.end, end: m.start, displacement, heading_change: -m.heading_change, std: m.std }
}

/// One correspondence in map coordinates: weight, the Jacobian rows of east and north, and q − origin.
struct Row {
    weight: f64,
    east: Vector4<f64>,
    north: Vector4<f64>,
    target: Vector2<f64>,
}

impl Row {
    /// Weighted squared residual under the parameters x = (a, b, t_e, t_n).
    fn residual(&self, x: &Vector4<f64>) -> f64 {
        self.weight * ((self.target.x - self.east.dot(x)).powi(2) + (self.target.y - self.north.dot(x)).powi(2))
    }
}

/// The inliers as map-coordinate observation rows of q = origin + [a −b; b a] (p − origin) + t.
fn weighted_rows(
    origin: Vector2<f64>,
    (pa, pb): (&OrthoPatch, &OrthoPatch),
    inliers: &[Correspondence],
    camera_height: f64,
) -> Option<Vec<Row>> {
    let (ga, gb) = (pa.grid.map_from_pixel(), pb.grid.map_from_pixel());
    let (ca, cb) = (Vector2::from(pa.grid.centre), Vector2::from(pb.grid.centre));
    let h2 = camera_height * camera_height;
    inliers
        .iter()
        .map(|c| {
            let (p, q) = (apply(&ga, Vector2::from(c.a))?, apply(&gb, Vector2::from(c.b))?);
            // The ground footprint of a panorama pixel grows as (r² + h²)/h with the distance r.
            let weight = 1.0 / (((p - ca).norm_squared() + h2).powi(2) + ((q - cb).norm_squared() + h2).powi(2));
            let d = p - origin;
            let (east, north) = (Vector4::new(d.x, -d.y, 1.0, 0.0), Vector4::new(d.y, d.x, 0.0, 1.0));
            Some(Row { weight, east, north, target: q - origin })
        })
        .collect()
}

/// A similarity in map coordinates around the origin.
struct MapSimilarity {
    /// M(origin) − origin, metres.
    shift: Vector2<f64>,
    /// Rotation of M, counter-clockwise, radians.
    rotation: f64,
    /// Formal σ of the shift (east, north) and of the rotation.
    std: [f64; 3],
}

/// The weighted least-squares similarity of `rows`, repeated without the correspondences that fail the
/// χ²₂ test on their normalised residual until the set is stable.
fn fit_similarity(rows: &[Row]) -> Option<MapSimilarity> {
    let mut keep = vec![true; rows.len()];
    for _ in 0..5 {
        let kept = || rows.iter().zip(&keep).filter(|(_, k)| **k).map(|(r, _)| r);
        let n = kept().count();
        if n < 3 {
            return None;
        }
        let (mut normal, mut rhs) = (Matrix4::<f64>::zeros(), Vector4::<f64>::zeros());
        for r in kept() {
            normal += r.weight * (r.east * r.east.transpose() + r.north * r.north.transpose());
            rhs += r.weight * (r.east * r.target.x + r.north * r.target.y);
        }
        let inverse = normal.try_inverse()?;
        let x = inverse * rhs;
        // σ₀² = Σ w |r|² / (2n − 4)
        let s0_sq = kept().map(|r| r.residual(&x)).sum::<f64>() / (2 * n - 4) as f64;
        let next: Vec<bool> = rows.iter().map(|r| r.residual(&x) <= CHI2_2_999 * s0_sq).collect();
        if next != keep && next.iter().filter(|&&k| k).count() >= 3 {
            keep = next;
            continue;
        }
        let cov = inverse * s0_sq;
        let (a, b) = (x[0], x[1]);
        // θ = atan2(b, a): ∂θ/∂(a, b) = (−b, a) / (a² + b²)
        let g = Vector4::new(-b, a, 0.0, 0.0) / (a * a + b * b);
        let var_rotation = (g.transpose() * cov * g)[(0, 0)];
        let std = [cov[(2, 2)].sqrt(), cov[(3, 3)].sqrt(), var_rotation.sqrt()];
        return Some(MapSimilarity { shift: Vector2::new(x[2], x[3]), rotation: b.atan2(a), std });
    }
    None
}

/// The affine image of a 2-D point.
fn apply(h: &Matrix3<f64>, p: Vector2<f64>) -> Option<Vector2<f64>> {
    let r = h * Vector3::new(p.x, p.y, 1.0);
    (r.z.abs() > 1e-12).then(|| Vector2::new(r.x / r.z, r.y / r.z))
}
