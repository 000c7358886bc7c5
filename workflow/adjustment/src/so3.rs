//! Small-angle rotation helpers on SO(3): exponential map, skew matrix and the left/right Jacobians.

use nalgebra::{Matrix3, Rotation3, Vector3};

/// The skew-symmetric matrix [v]× with [v]× w = v × w.
pub(crate) fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Exp(θ): the rotation by |θ| about θ/|θ|.
pub(crate) fn exp(theta: &Vector3<f64>) -> Matrix3<f64> {
    Rotation3::new(*theta).into_inner()
}

/// Left Jacobian J_l(θ) with Exp(θ + dθ) ≈ Exp(J_l(θ) dθ) · Exp(θ).
pub(crate) fn left_jacobian(theta: &Vector3<f64>) -> Matrix3<f64> {
    let a = theta.norm();
    let k = skew(theta);
    if a < 1e-6 {
        // Series to second order; exact enough below 1e-6 rad.
        return Matrix3::identity() + k * 0.5 + k * k / 6.0;
    }
    Matrix3::identity() + k * ((1.0 - a.cos()) / (a * a)) + k * k * ((a - a.sin()) / (a * a * a))
}

/// Right Jacobian J_r(θ) = J_l(−θ).
pub(crate) fn right_jacobian(theta: &Vector3<f64>) -> Matrix3<f64> {
    left_jacobian(&(-theta))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn left_jacobian_matches_finite_differences_of_exp() {
        let theta = Vector3::new(0.3, -0.2, 0.5);
        let v = Vector3::new(1.0, 2.0, -0.5);
        let analytic = -skew(&(exp(&theta) * v)) * left_jacobian(&theta);
        let h = 1e-6;
        for c in 0..3 {
            let mut d = Vector3::zeros();
            d[c] = h;
            let numeric = (exp(&(theta + d)) * v - exp(&(theta - d)) * v) / (2.0 * h);
            assert!((numeric - analytic.column(c)).norm() < 1e-8, "column {c}");
        }
        // Near zero the series branch is used and must agree with the closed form just above it.
        let tiny = Vector3::new(2e-6, 0.0, 0.0);
        assert!((left_jacobian(&(tiny * 0.1)) - left_jacobian(&tiny)).norm() < 1e-5);
    }
}
