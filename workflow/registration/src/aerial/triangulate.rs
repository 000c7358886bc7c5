//! Step 8 of Jende et al. 2017 (§3.9): least-squares multi-image triangulation of one point from its aerial image
//! coordinates, minimising reprojection errors in pixels, with blunder checks (the worst ray is removed and
//! the point re-solved while a reprojection error exceeds the bound) and the covariance from the normal
//! matrix.

use nalgebra::{Matrix3, Vector3};
use plumbline_geo::camera::Pinhole;
use plumbline_geo::camera::{CameraModel, Pixel};
use plumbline_geo::{MapFromCamera, Point3};

/// One observation of the point: an aerial image coordinate with the frame's interior and exterior
/// orientation.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Interior orientation.
    pub camera: Pinhole,
    /// Exterior orientation.
    pub pose: MapFromCamera,
    /// The measured continuous pixel.
    pub pixel: [f64; 2],
}

impl Ray {
    /// Pixel of a mapping point, if it images.
    fn project(&self, x: &Vector3<f64>) -> Option<Vector3<f64>> {
        let c = self.pose.inverse().transform_point(&Point3::from_vector(*x));
        let p = self.camera.project(&(c - Point3::origin()))?;
        Some(Vector3::new(p.u - self.pixel[0], p.v - self.pixel[1], 0.0))
    }

    /// Origin and unit direction in the map frame.
    pub(super) fn line(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let d = self.camera.unproject(Pixel::new(self.pixel[0], self.pixel[1]))?;
        Some((self.pose.translation.p, self.pose.rotation.apply(&d).v))
    }
}

/// A triangulated point.
#[derive(Clone, Debug, PartialEq)]
pub struct Triangulated {
    /// E, N, H.
    pub position: [f64; 3],
    /// Covariance, m²: the inverse normal matrix (weights 1/σ_px²) scaled by max(1, σ̂0²).
    pub covariance: [[f64; 3]; 3],
    /// Which rays were kept (the others were removed as blunders).
    pub used: Vec<bool>,
    /// Reprojection error of every ray at the final point, pixels.
    pub residuals_px: Vec<f64>,
    /// A-posteriori σ0 (reprojection RMS / σ_px); 0 without redundancy.
    pub sigma0: f64,
}

/// Why a point could not be triangulated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TriangulationError {
    /// Fewer than two usable rays.
    #[error("triangulation needs at least two rays, {usable} usable")]
    TooFewRays {
        /// Rays left.
        usable: usize,
    },
    /// The rays are (nearly) parallel or a ray does not image the point.
    #[error("triangulation is degenerate: {reason}")]
    Degenerate {
        /// What went wrong.
        reason: &'static str,
    },
    /// Only two rays are left and they still disagree by more than the bound: the blunder cannot be located.
    #[error("two rays left with reprojection error {worst_px:.2} px above {bound_px} px")]
    Blunder {
        /// Largest reprojection error, pixels.
        worst_px: f64,
        /// The bound, pixels.
        bound_px: f64,
    },
}

/// Triangulate from `rays` (Jende et al. 2017 §3.9): linear intersection, Gauss–Newton on the reprojection errors
/// (weights 1/`pixel_sigma`²), and while a reprojection error exceeds `max_reprojection_px` the worst ray
/// is removed and the point re-solved; two rays that still disagree are an error.
pub fn triangulate(
    rays: &[Ray],
    pixel_sigma: f64,
    max_reprojection_px: f64,
) -> Result<Triangulated, TriangulationError> {
    let mut used = vec![true; rays.len()];
    loop {
        let active: Vec<Ray> = rays.iter().zip(&used).filter(|p| *p.1).map(|p| *p.0).collect();
        if active.len() < 2 {
            return Err(TriangulationError::TooFewRays { usable: active.len() });
        }
        let x = gauss_newton(&active, linear(&active)?)?;
        let residuals: Vec<f64> = rays.iter().map(|r| r.project(&x).map_or(f64::INFINITY, |e| e.norm())).collect();
        let worst = (0..rays.len()).filter(|&i| used[i]).max_by(|&a, &b| residuals[a].total_cmp(&residuals[b]));
        let Some(worst) = worst else { return Err(TriangulationError::TooFewRays { usable: 0 }) };
        if residuals[worst] <= max_reprojection_px {
            return finish(&active, x, used, residuals, pixel_sigma);
        }
        if active.len() == 2 {
            return Err(TriangulationError::Blunder { worst_px: residuals[worst], bound_px: max_reprojection_px });
        }
        used[worst] = false; // Jende et al. 2017 §3.9: blunder removal, then re-solve
    }
}

/// The point closest to all rays: Σ (I − d dᵀ) X = Σ (I − d dᵀ) o.
fn linear(rays: &[Ray]) -> Result<Vector3<f64>, TriangulationError> {
    let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
    for ray in rays {
        let (o, d) = ray.line().ok_or(TriangulationError::Degenerate { reason: "a pixel forms no ray" })?;
        let p = Matrix3::identity() - d * d.transpose();
        a += p;
        b += p * o;
    }
    let inv = a.try_inverse().ok_or(TriangulationError::Degenerate { reason: "the rays are parallel" })?;
    Ok(inv * b)
}

/// Per ray: the reprojection residual (u, v) and the gradients of u and of v with respect to the point.
type Linearised = (Vec<[f64; 2]>, Vec<[Vector3<f64>; 2]>);

/// Reprojection residuals (2 per ray) and their Jacobian by central differences (1 cm steps).
fn linearise(rays: &[Ray], x: &Vector3<f64>) -> Result<Linearised, TriangulationError> {
    let none = TriangulationError::Degenerate { reason: "a ray does not image the point" };
    let mut res = Vec::with_capacity(rays.len());
    let mut jac = Vec::with_capacity(rays.len());
    for ray in rays {
        let e = ray.project(x).ok_or(none.clone())?;
        let mut j = [Vector3::zeros(); 2];
        for k in 0..3 {
            let mut step = Vector3::zeros();
            step[k] = 0.01;
            let (plus, minus) = (ray.project(&(x + step)), ray.project(&(x - step)));
            let (p, m) = plus.zip(minus).ok_or(none.clone())?;
            j[0][k] = (p.x - m.x) / 0.02;
            j[1][k] = (p.y - m.y) / 0.02;
        }
        res.push([e.x, e.y]);
        jac.push(j);
    }
    Ok((res, jac))
}

/// The normal matrix Σ JᵀJ of unit weights.
fn normal(jac: &[[Vector3<f64>; 2]]) -> Matrix3<f64> {
    jac.iter().flat_map(|j| j.iter()).map(|g| g * g.transpose()).sum()
}

fn gauss_newton(rays: &[Ray], mut x: Vector3<f64>) -> Result<Vector3<f64>, TriangulationError> {
    for _ in 0..20 {
        let (res, jac) = linearise(rays, &x)?;
        let n = normal(&jac);
        let g: Vector3<f64> = res.iter().zip(&jac).map(|(r, j)| j[0] * r[0] + j[1] * r[1]).sum();
        let step =
            n.cholesky().ok_or(TriangulationError::Degenerate { reason: "singular normal matrix" })?.solve(&(-g));
        x += step;
        if step.norm() < 1e-6 {
            break;
        }
    }
    Ok(x)
}

fn finish(
    rays: &[Ray],
    x: Vector3<f64>,
    used: Vec<bool>,
    residuals_px: Vec<f64>,
    pixel_sigma: f64,
) -> Result<Triangulated, TriangulationError> {
    let (res, jac) = linearise(rays, &x)?;
    let weight = 1.0 / (pixel_sigma * pixel_sigma);
    let inv = (normal(&jac) * weight)
        .try_inverse()
        .ok_or(TriangulationError::Degenerate { reason: "singular normal matrix" })?;
    let redundancy = 2 * rays.len() - 3;
    let vtpv: f64 = res.iter().map(|r| (r[0] * r[0] + r[1] * r[1]) * weight).sum();
    let sigma0 = if redundancy > 0 { (vtpv / redundancy as f64).sqrt() } else { 0.0 };
    let cov = inv * sigma0.powi(2).max(1.0); // Jende et al. 2017 §3.9: covariance from the normal matrix
    let covariance = [0, 1, 2].map(|i| [0, 1, 2].map(|j| cov[(i, j)]));
    Ok(Triangulated { position: [x.x, x.y, x.z], covariance, used, residuals_px, sigma0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_geo::OmegaPhiKappa;

    /// A nadir frame 1500 m above a ground at 8 m, 12 cm GSD, centred at (e, n), turned by κ degrees.
    fn frame(e: f64, n: f64, kappa_deg: f64) -> (Pinhole, MapFromCamera) {
        let cam = Pinhole::new(600, 450, 12_500.0, 12_500.0, 300.0, 225.0, 0.0, 0.0).unwrap();
        let rotation = OmegaPhiKappa::from_degrees(0.3, -0.2, kappa_deg).to_rotation();
        (cam, MapFromCamera::new(rotation, Point3::new(e, n, 1508.0)))
    }

    /// The exact pixel of `x` in a frame, plus `noise` pixels.
    fn observe(cam: Pinhole, pose: MapFromCamera, x: [f64; 3], noise: [f64; 2]) -> Ray {
        let c = pose.inverse().transform_point(&Point3::new(x[0], x[1], x[2]));
        let p = cam.project(&(c - Point3::origin())).unwrap();
        Ray { camera: cam, pose, pixel: [p.u + noise[0], p.v + noise[1]] }
    }

    fn block() -> Vec<(Pinhole, MapFromCamera)> {
        vec![
            frame(1000.0, 2000.0, 0.0),
            frame(1029.0, 2001.0, 0.0),
            frame(1012.0, 2030.0, 180.0),
            frame(990.0, 2020.0, 35.0),
        ]
    }

    #[test]
    fn exact_rays_return_the_point_and_its_covariance_follows_the_geometry() {
        let x = [1013.7, 2014.2, 8.4];
        let rays: Vec<Ray> = block().into_iter().map(|(c, p)| observe(c, p, x, [0.0, 0.0])).collect();
        let t = triangulate(&rays, 0.3, 1.0).unwrap();
        let err: f64 = (0..3).map(|k| (t.position[k] - x[k]).powi(2)).sum::<f64>().sqrt();
        assert!(err < 1e-4, "{:?}", t.position);
        assert!(t.used.iter().all(|&u| u) && t.residuals_px.iter().all(|&r| r < 1e-4));
        // Horizontal σ ≈ σ_px · GSD / √(rays) ≈ 0.3 · 0.12 / 2; the height is weaker by about H / B.
        let (sx, sz) = (t.covariance[0][0].sqrt(), t.covariance[2][2].sqrt());
        assert!(sx > 0.01 && sx < 0.03, "σE {sx}");
        assert!(sz > 10.0 * sx && sz < 2.0, "σH {sz}");
        // Two rays suffice; one does not.
        assert!(triangulate(&rays[..2], 0.3, 1.0).is_ok());
        assert_eq!(triangulate(&rays[..1], 0.3, 1.0), Err(TriangulationError::TooFewRays { usable: 1 }));
    }

    #[test]
    fn a_blundered_ray_is_removed_and_the_point_still_found() {
        let x = [1008.1, 2009.9, 7.6];
        let noise = [[0.1, -0.05], [-0.08, 0.12], [6.0, -4.0], [0.05, 0.07]];
        let rays: Vec<Ray> = block().into_iter().zip(noise).map(|((c, p), n)| observe(c, p, x, n)).collect();
        let t = triangulate(&rays, 0.3, 1.0).unwrap();
        assert_eq!(t.used, vec![true, true, false, true]);
        assert!(t.residuals_px[2] > 5.0 && t.residuals_px.iter().enumerate().all(|(i, &r)| i == 2 || r < 0.5));
        // With the blunder out, the horizontal position is good to a few centimetres.
        assert!((t.position[0] - x[0]).hypot(t.position[1] - x[1]) < 0.05, "{:?}", t.position);
        // Two rays that disagree cannot say which one is wrong.
        let pair = [rays[0], observe(rays[1].camera, rays[1].pose, x, [0.0, 5.0])];
        assert!(matches!(triangulate(&pair, 0.3, 1.0), Err(TriangulationError::Blunder { .. })));
    }
}
