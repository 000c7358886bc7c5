//! Progress of long work, reported from synchronous code without knowing who listens: a terminal with bars,
//! a log, JSON lines, a distributed job's status, or nobody. Workflow code calls the trait; the services
//! implement it (`plumbline_runtime::progress`).

/// Receives progress of named stages (e.g. `registration` in tiles, `adjustment` in iterations).
///
/// Implementations are cheap to call from many threads at once; they throttle their own output.
pub trait Progress: Send + Sync {
    /// A stage begins with `total` items when known.
    fn begin(&self, stage: &str, total: Option<u64>);
    /// `n` more items of `stage` are done.
    fn advance(&self, stage: &str, n: u64);
    /// `n` items of `stage` were skipped (they count as handled for the rate and ETA).
    fn skip(&self, stage: &str, n: u64);
    /// A short status line for the stage (e.g. `iteration 4: σ0 1.08`).
    fn note(&self, stage: &str, text: &str);
    /// The stage is over.
    fn end(&self, stage: &str);
}

/// A [`Progress`] that discards everything.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn begin(&self, _: &str, _: Option<u64>) {}
    fn advance(&self, _: &str, _: u64) {}
    fn skip(&self, _: &str, _: u64) {}
    fn note(&self, _: &str, _: &str) {}
    fn end(&self, _: &str) {}
}
