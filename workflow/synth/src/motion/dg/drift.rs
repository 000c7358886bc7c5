//! Slowly varying errors: first-order Gauss–Markov processes sampled on knots (every `knot_interval`) and
//! interpolated linearly between them, so the error is smooth from epoch to epoch.
//!
//! x_j = φ x_{j−1} + √(1 − φ²) σ_j w_j with φ = exp(−Δt / τ), w_j ~ N(0, 1), x_0 = σ_0 w_0: stationary with
//! variance σ² where σ is constant; where σ changes (the street changes) the variance follows within ~τ.

use crate::motion::rng::Stream;

/// A Gauss–Markov series on knots `t0 + j·interval`.
#[derive(Clone, Debug)]
pub(crate) struct Knots {
    t0: f64,
    interval: f64,
    values: Vec<f64>,
}

impl Knots {
    /// Draw a series with correlation time `tau` whose σ at knot time t is `sigma(t)`.
    pub(crate) fn draw(
        t0: f64,
        t1: f64,
        interval: f64,
        tau: f64,
        sigma: impl Fn(f64) -> f64,
        rng: &mut Stream,
    ) -> Self {
        let n = ((t1 - t0) / interval).ceil().max(0.0) as usize + 2;
        let phi = (-interval / tau).exp();
        let drive = (1.0 - phi * phi).sqrt();
        let mut values = Vec::with_capacity(n);
        let mut x = sigma(t0) * rng.normal();
        for j in 0..n {
            if j > 0 {
                x = phi * x + drive * sigma(t0 + j as f64 * interval) * rng.normal();
            }
            values.push(x);
        }
        Self { t0, interval, values }
    }

    /// The value at time `t` (linear between knots, clamped at the ends).
    pub(crate) fn at(&self, t: f64) -> f64 {
        let x = ((t - self.t0) / self.interval).max(0.0);
        let j = (x.floor() as usize).min(self.values.len().saturating_sub(2));
        let w = (x - j as f64).clamp(0.0, 1.0);
        match (self.values.get(j), self.values.get(j + 1)) {
            (Some(a), Some(b)) => a + (b - a) * w,
            (Some(a), None) => *a,
            _ => 0.0,
        }
    }
}
