//! Seeded random streams: one independent ChaCha8 stream per purpose, so adding draws to one model does not
//! change the numbers another model sees.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Which model a stream feeds (the stream number of the ChaCha generator).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Purpose {
    /// Stops at junctions and standstill durations.
    Stops = 1,
    /// Fault timeline: multipath jumps and GNSS outages.
    Faults = 2,
    /// Slowly varying DG drift and attitude errors.
    Drift = 3,
    /// White noise of the DG solution.
    DgNoise = 4,
    /// GNSS receiver noise and drift.
    Gnss = 5,
    /// IMU error states and noise.
    Imu = 6,
}

/// A deterministic random stream.
#[derive(Clone, Debug)]
pub(crate) struct Stream {
    rng: ChaCha8Rng,
}

impl Stream {
    /// The stream of `purpose` for campaign seed `seed`.
    pub(crate) fn new(seed: u64, purpose: Purpose) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(purpose as u64);
        Self { rng }
    }

    /// Uniform in [0, 1).
    pub(crate) fn unit(&mut self) -> f64 {
        self.rng.random::<f64>()
    }

    /// Uniform in [lo, hi).
    pub(crate) fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Log-uniform in [lo, hi) (lo > 0): every octave equally likely.
    pub(crate) fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.unit()).exp()
    }

    /// Standard normal by Box–Muller.
    pub(crate) fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.unit(); // (0, 1]
        let u2 = self.unit();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// True with probability `p`.
    pub(crate) fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    /// A direction in the horizontal plane, uniformly distributed: (east, north) unit vector.
    pub(crate) fn direction(&mut self) -> (f64, f64) {
        let a = self.uniform(0.0, std::f64::consts::TAU);
        (a.cos(), a.sin())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_has_unit_variance_and_streams_are_independent() {
        let mut s = Stream::new(7, Purpose::Drift);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| s.normal()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 1.0).abs() < 0.01, "{var}");
        let a = Stream::new(7, Purpose::Drift).unit();
        let b = Stream::new(7, Purpose::Gnss).unit();
        assert_ne!(a, b);
        assert_eq!(a, Stream::new(7, Purpose::Drift).unit());
    }
}
