//! Stacking the dips of the height slices into vertical structures: a run joins the structure whose top run
//! overlaps it in bearing and agrees in range within the noise.

use super::DetectConfig;
use super::profile::Run;

/// Bins of bearing slack between runs of one structure.
const BEARING_SLACK: usize = 1;
/// Range slack added to the combined noise, metres.
const RANGE_SLACK_M: f64 = 0.3;
/// Height a structure may skip (occluded by a sign plate, or a noisy slice), metres.
const MAX_SKIP_M: f64 = 0.4;

/// A vertical structure: runs of distinct slices.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Stack {
    /// Its runs, lowest slice first.
    pub runs: Vec<Run>,
}

impl Stack {
    fn top(&self) -> &Run {
        &self.runs[self.runs.len() - 1]
    }
    fn accepts(&self, r: &Run, max_skip: usize) -> Option<f64> {
        let t = self.top();
        let overlap = r.bins.0 <= t.bins.1 + BEARING_SLACK && t.bins.0 <= r.bins.1 + BEARING_SLACK;
        let dr = (r.range - t.range).abs();
        let ok = r.slice > t.slice
            && r.slice <= t.slice + 1 + max_skip
            && overlap
            && dr <= 3.0 * r.sigma.hypot(t.sigma) + RANGE_SLACK_M;
        ok.then_some(dr)
    }
    /// Number of distinct slices.
    pub fn slices(&self) -> usize {
        self.runs.len()
    }
    /// First and last bin over all runs.
    pub fn bins(&self) -> (usize, usize) {
        let lo = self.runs.iter().map(|r| r.bins.0).min().unwrap_or(0);
        let hi = self.runs.iter().map(|r| r.bins.1).max().unwrap_or(0);
        (lo, hi)
    }
}

/// The structures spanning at least `min_slices` slices.
pub(super) fn stack(mut runs: Vec<Run>, c: &DetectConfig) -> Vec<Stack> {
    runs.sort_by(|a, b| a.slice.cmp(&b.slice).then(a.bins.0.cmp(&b.bins.0)));
    let max_skip = (MAX_SKIP_M / c.slice_m).round() as usize;
    let mut stacks: Vec<Stack> = Vec::new();
    for r in runs {
        let best = stacks
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.accepts(&r, max_skip).map(|d| (i, d)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i);
        match best {
            Some(i) => stacks[i].runs.push(r),
            None => stacks.push(Stack { runs: vec![r] }),
        }
    }
    stacks.retain(|s| s.slices() >= c.min_slices);
    stacks
}
