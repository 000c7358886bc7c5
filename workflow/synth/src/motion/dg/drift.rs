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

/// A Gauss–Markov series drawn leg by leg on the knots `t0 + j·interval` of the whole drive: each leg's
/// [`Knots`] start with the last knots of the previous leg, so the series is continuous across legs.
#[derive(Clone, Debug)]
pub(crate) struct KnotStream {
    interval: f64,
    tau: f64,
    /// Time of knot 0 (the first leg's start).
    t0: Option<f64>,
    /// Index of the first kept knot and the kept values.
    first: usize,
    tail: Vec<f64>,
}

/// Knots kept from one leg for the next (the next leg starts within the last of them).
const KEEP: usize = 3;

impl KnotStream {
    pub(crate) fn new(interval: f64, tau: f64) -> Self {
        Self { interval, tau, t0: None, first: 0, tail: Vec::new() }
    }

    /// The knots covering up to `t1` (and one beyond), from `t_start` on for the first leg.
    pub(crate) fn extend(&mut self, t_start: f64, t1: f64, sigma: impl Fn(f64) -> f64, rng: &mut Stream) -> Knots {
        let t0 = *self.t0.get_or_insert(t_start);
        let (phi, interval) = ((-self.interval / self.tau).exp(), self.interval);
        let drive = (1.0 - phi * phi).sqrt();
        let last = ((t1 - t0) / interval).ceil().max(0.0) as usize + 1;
        let mut values = std::mem::take(&mut self.tail);
        if values.is_empty() {
            values.push(sigma(t0) * rng.normal());
        }
        let first = self.first;
        while first + values.len() <= last {
            let j = first + values.len();
            let x = values.last().copied().unwrap_or(0.0);
            values.push(phi * x + drive * sigma(t0 + j as f64 * interval) * rng.normal());
        }
        let keep = values.len().min(KEEP);
        self.first = first + values.len() - keep;
        self.tail = values[values.len() - keep..].to_vec();
        Knots { t0: t0 + first as f64 * interval, interval, values }
    }
}
