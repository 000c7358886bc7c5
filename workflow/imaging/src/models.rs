//! 2-D transform models fitted by least squares: similarity, affine, and the normalised-DLT homography
//! refined by Gauss–Newton on the transfer error. All are 3×3 matrices mapping A pixels to B pixels.

use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2};

use crate::error::ImagingError;
use crate::warp::apply_h;

/// A point correspondence: the same feature at `a` in image A and at `b` in image B (continuous pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correspondence {
    /// Position in image A.
    pub a: [f64; 2],
    /// Position in image B.
    pub b: [f64; 2],
}

/// Which transform to fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Model {
    /// Rotation, uniform scale and translation (4 parameters).
    Similarity,
    /// General affine (6 parameters).
    Affine,
    /// Plane projective (8 parameters).
    Homography,
}

impl Model {
    /// Smallest sample that determines the model.
    pub fn min_samples(self) -> usize {
        match self {
            Model::Similarity => 2,
            Model::Affine => 3,
            Model::Homography => 4,
        }
    }

    /// Name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Model::Similarity => "similarity",
            Model::Affine => "affine",
            Model::Homography => "homography",
        }
    }

    /// Least-squares fit to all `pairs`.
    pub fn fit(self, pairs: &[Correspondence]) -> Result<Matrix3<f64>, ImagingError> {
        if pairs.len() < self.min_samples() {
            return Err(ImagingError::TooFew { what: self.name(), needed: self.min_samples(), got: pairs.len() });
        }
        match self {
            Model::Similarity => fit_similarity(pairs),
            Model::Affine => fit_affine(pairs),
            Model::Homography => fit_homography(pairs),
        }
    }
}

/// Transfer error |H a − b| of one correspondence (infinite beyond the horizon).
pub fn transfer_error(h: &Matrix3<f64>, c: &Correspondence) -> f64 {
    apply_h(h, c.a[0], c.a[1]).map_or(f64::INFINITY, |(u, v)| (u - c.b[0]).hypot(v - c.b[1]))
}

/// Centroids of both point sets.
fn centroids(pairs: &[Correspondence]) -> (Vector2<f64>, Vector2<f64>) {
    let n = pairs.len() as f64;
    let sum = pairs
        .iter()
        .fold((Vector2::zeros(), Vector2::zeros()), |(sa, sb), c| (sa + Vector2::from(c.a), sb + Vector2::from(c.b)));
    (sum.0 / n, sum.1 / n)
}

/// Matrix of x' = M x + t.
fn from_linear(m: &Matrix2<f64>, t: &Vector2<f64>) -> Matrix3<f64> {
    Matrix3::new(m[(0, 0)], m[(0, 1)], t.x, m[(1, 0)], m[(1, 1)], t.y, 0.0, 0.0, 1.0)
}

/// Closed-form least squares on centred coordinates: a = Σ(p·q)/Σ|p|², b = Σ(p × q)/Σ|p|².
fn fit_similarity(pairs: &[Correspondence]) -> Result<Matrix3<f64>, ImagingError> {
    let (ca, cb) = centroids(pairs);
    let (mut dot, mut cross, mut norm) = (0.0, 0.0, 0.0);
    for c in pairs {
        let (p, q) = (Vector2::from(c.a) - ca, Vector2::from(c.b) - cb);
        dot += p.dot(&q);
        cross += p.x * q.y - p.y * q.x;
        norm += p.norm_squared();
    }
    if norm < 1e-12 {
        return Err(ImagingError::Degenerate { what: "similarity fit", reason: "all points in A coincide" });
    }
    let m = Matrix2::new(dot / norm, -cross / norm, cross / norm, dot / norm);
    Ok(from_linear(&m, &(cb - m * ca)))
}

/// Least squares on centred coordinates: M = (Σ q pᵀ)(Σ p pᵀ)⁻¹, t = b̄ − M ā.
fn fit_affine(pairs: &[Correspondence]) -> Result<Matrix3<f64>, ImagingError> {
    let (ca, cb) = centroids(pairs);
    let (mut pp, mut qp) = (Matrix2::zeros(), Matrix2::zeros());
    for c in pairs {
        let (p, q) = (Vector2::from(c.a) - ca, Vector2::from(c.b) - cb);
        pp += p * p.transpose();
        qp += q * p.transpose();
    }
    let scale = pp.trace().max(1e-300);
    if pp.determinant() < 1e-10 * scale * scale {
        return Err(ImagingError::Degenerate { what: "affine fit", reason: "the points in A are collinear" });
    }
    let m = qp * pp.try_inverse().ok_or(ImagingError::Degenerate { what: "affine fit", reason: "singular" })?;
    Ok(from_linear(&m, &(cb - m * ca)))
}

/// Hartley normalisation: centroid to the origin, mean distance √2.
fn normaliser(points: impl Iterator<Item = Vector2<f64>> + Clone) -> Matrix3<f64> {
    let n = points.clone().count() as f64;
    let c = points.clone().fold(Vector2::zeros(), |s, p| s + p) / n;
    let mean = points.map(|p| (p - c).norm()).sum::<f64>() / n;
    let s = if mean > 1e-12 { std::f64::consts::SQRT_2 / mean } else { 1.0 };
    Matrix3::new(s, 0.0, -s * c.x, 0.0, s, -s * c.y, 0.0, 0.0, 1.0)
}

/// Normalised DLT (Hartley & Zisserman alg. 4.2), then Gauss–Newton on the transfer error.
fn fit_homography(pairs: &[Correspondence]) -> Result<Matrix3<f64>, ImagingError> {
    let degenerate = ImagingError::Degenerate { what: "homography fit", reason: "points collinear or coincident" };
    let ta = normaliser(pairs.iter().map(|c| Vector2::from(c.a)));
    let tb = normaliser(pairs.iter().map(|c| Vector2::from(c.b)));
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for c in pairs {
        let p = ta * nalgebra::Vector3::new(c.a[0], c.a[1], 1.0);
        let q = tb * nalgebra::Vector3::new(c.b[0], c.b[1], 1.0);
        let r1 = SVector::<f64, 9>::from([0.0, 0.0, 0.0, -p.x, -p.y, -1.0, q.y * p.x, q.y * p.y, q.y]);
        let r2 = SVector::<f64, 9>::from([p.x, p.y, 1.0, 0.0, 0.0, 0.0, -q.x * p.x, -q.x * p.y, -q.x]);
        ata += r1 * r1.transpose() + r2 * r2.transpose();
    }
    let eig = ata.symmetric_eigen();
    let mut order: Vec<usize> = (0..9).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    // A unique solution needs a one-dimensional null space: the second-smallest eigenvalue must stand clear.
    if eig.eigenvalues[order[1]] < 1e-10 * eig.eigenvalues[order[8]].max(1e-300) {
        return Err(degenerate);
    }
    let h = eig.eigenvectors.column(order[0]);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let h = tb.try_inverse().ok_or(degenerate.clone())? * hn * ta;
    if h[(2, 2)].abs() < 1e-12 {
        return Err(degenerate);
    }
    Ok(refine_homography(&(h / h[(2, 2)]), pairs))
}

/// A few Gauss–Newton steps on Σ |H a − b|² over h11…h32 (h33 = 1); keeps the input if a step fails.
fn refine_homography(h0: &Matrix3<f64>, pairs: &[Correspondence]) -> Matrix3<f64> {
    let mut h = *h0;
    for _ in 0..5 {
        let mut n = SMatrix::<f64, 8, 8>::zeros();
        let mut g = SVector::<f64, 8>::zeros();
        for c in pairs {
            let (x, y) = (c.a[0], c.a[1]);
            let w = h[(2, 0)] * x + h[(2, 1)] * y + 1.0;
            if w.abs() < 1e-12 {
                return *h0;
            }
            let u = (h[(0, 0)] * x + h[(0, 1)] * y + h[(0, 2)]) / w;
            let v = (h[(1, 0)] * x + h[(1, 1)] * y + h[(1, 2)]) / w;
            let ju = SVector::<f64, 8>::from([x / w, y / w, 1.0 / w, 0.0, 0.0, 0.0, -u * x / w, -u * y / w]);
            let jv = SVector::<f64, 8>::from([0.0, 0.0, 0.0, x / w, y / w, 1.0 / w, -v * x / w, -v * y / w]);
            n += ju * ju.transpose() + jv * jv.transpose();
            g += ju * (c.b[0] - u) + jv * (c.b[1] - v);
        }
        let Some(d) = n.cholesky().map(|ch| ch.solve(&g)) else { return h };
        for (i, di) in d.iter().enumerate() {
            h[(i / 3, i % 3)] += di;
        }
        if d.norm() < 1e-12 {
            break;
        }
    }
    h
}
