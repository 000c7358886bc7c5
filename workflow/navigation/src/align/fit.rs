//! The motion of the antenna over the alignment window from the GNSS fixes: a weighted least-squares
//! quadratic p(τ) = p₀ + v·τ + ½a·τ² per axis (σ from the fixes), and the test of the standstill hypothesis
//! (v = a = 0) against it.

use nalgebra::{Matrix3, Vector3};

use crate::chi2::chi2_critical;
use crate::inputs::GnssFix;

/// The antenna's motion at the start of the window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Motion {
    /// Position at τ = 0, m.
    pub position: Vector3<f64>,
    /// Velocity at τ = 0, m/s (zero when standing).
    pub velocity: Vector3<f64>,
    /// Mean acceleration over the window, m/s² (zero when standing).
    pub acceleration: Vector3<f64>,
    /// σ of position, velocity and acceleration per axis (largest axis), scaled by the a-posteriori
    /// variance factor when the fixes scatter more than their σ say.
    pub std: [f64; 3],
    /// Whether the standstill hypothesis was accepted.
    pub standing: bool,
}

/// One axis: weighted quadratic fit and the weighted sums of squares of the constant and quadratic models.
struct Axis {
    coef: Vector3<f64>,
    inverse: Matrix3<f64>,
    mean: f64,
    mean_var: f64,
    ssr_constant: f64,
    ssr_quadratic: f64,
}

fn fit_axis(samples: &[(f64, f64, f64)]) -> Option<Axis> {
    let (mut n, mut b) = (Matrix3::zeros(), Vector3::zeros());
    let (mut sw, mut swy) = (0.0, 0.0);
    for &(tau, y, w) in samples {
        let row = Vector3::new(1.0, tau, 0.5 * tau * tau);
        n += w * row * row.transpose();
        b += w * y * row;
        sw += w;
        swy += w * y;
    }
    let inverse = n.try_inverse()?;
    let coef = inverse * b;
    let mean = swy / sw;
    let ssr = |f: &dyn Fn(f64) -> f64| samples.iter().map(|&(t, y, w)| w * (y - f(t)).powi(2)).sum::<f64>();
    let ssr_constant = ssr(&|_| mean);
    let ssr_quadratic = ssr(&|t| coef[0] + coef[1] * t + 0.5 * coef[2] * t * t);
    Some(Axis { coef, inverse, mean, mean_var: 1.0 / sw, ssr_constant, ssr_quadratic })
}

/// Fit the fixes (at least 4, σ > 0) relative to `t0`; `alpha` is the significance of the standstill test.
/// `None` when the fixes do not determine a quadratic (fewer than 3 distinct times).
pub(crate) fn fit(fixes: &[&GnssFix], t0: f64, alpha: f64) -> Option<Motion> {
    let axes: Vec<Axis> = (0..3)
        .map(|i| {
            let samples: Vec<_> = fixes.iter().map(|f| (f.time - t0, f.position.p[i], f.std[i].powi(-2))).collect();
            fit_axis(&samples)
        })
        .collect::<Option<_>>()?;
    let dof = 3.0 * (fixes.len() as f64 - 3.0);
    let ssr: f64 = axes.iter().map(|a| a.ssr_quadratic).sum();
    // A-posteriori variance factor: canyon fixes may scatter more than their stated σ.
    let factor = (ssr / dof).max(1.0);
    // Standstill H0: v = a = 0; the drop in the weighted SSR is χ² with 6 degrees of freedom under H0.
    let drop: f64 = axes.iter().map(|a| a.ssr_constant - a.ssr_quadratic).sum();
    let standing = drop / factor < chi2_critical(6.0, alpha);
    let largest = |f: &dyn Fn(&Axis) -> f64| axes.iter().map(f).fold(0.0f64, f64::max).sqrt();
    if standing {
        return Some(Motion {
            position: Vector3::from_fn(|i, _| axes[i].mean),
            velocity: Vector3::zeros(),
            acceleration: Vector3::zeros(),
            // The velocity resolution of the test: a slower creep would have passed as standing.
            std: [largest(&|a| a.mean_var * factor), largest(&|a| a.inverse[(1, 1)] * factor), 0.0],
            standing,
        });
    }
    Some(Motion {
        position: Vector3::from_fn(|i, _| axes[i].coef[0]),
        velocity: Vector3::from_fn(|i, _| axes[i].coef[1]),
        acceleration: Vector3::from_fn(|i, _| axes[i].coef[2]),
        std: [0, 1, 2].map(|k| largest(&|a| a.inverse[(k, k)] * factor)),
        standing,
    })
}
