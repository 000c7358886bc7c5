//! The error type of the imaging primitives: every variant names what failed.

/// Errors from image primitives.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ImagingError {
    /// An image or mask whose buffer does not match its size, or an empty one.
    #[error("{what}: {width}×{height} image with {len} samples (needs width·height > 0 samples)")]
    Shape { what: &'static str, width: usize, height: usize, len: usize },
    /// A parameter outside its domain.
    #[error("parameter `{field}` = {value}: {reason}")]
    Parameter { field: &'static str, value: f64, reason: &'static str },
    /// Too few correspondences or samples for an estimate.
    #[error("{what} needs at least {needed} correspondences, got {got}")]
    TooFew { what: &'static str, needed: usize, got: usize },
    /// A configuration with no unique solution (collinear points, flat template, singular normal matrix).
    #[error("{what} is degenerate: {reason}")]
    Degenerate { what: &'static str, reason: &'static str },
    /// A window that does not fit inside the image.
    #[error("{what}: window at ({x}, {y}) of half-size {half} leaves the {width}×{height} image")]
    OutOfBounds { what: &'static str, x: f64, y: f64, half: usize, width: usize, height: usize },
    /// An iterative estimate that did not converge.
    #[error("{what} did not converge in {iterations} iterations (last step {last_step:.3e})")]
    NoConvergence { what: &'static str, iterations: usize, last_step: f64 },
}

/// Return a [`ImagingError::Parameter`] unless `ok`.
pub(crate) fn require(ok: bool, field: &'static str, value: f64, reason: &'static str) -> Result<(), ImagingError> {
    if ok { Ok(()) } else { Err(ImagingError::Parameter { field, value, reason }) }
}
