//! Where the DG trajectory may carry a jump offset, so its weak absolute prior must not hold it: the spans
//! between detected DG breaks (flagged weak links, standstills over which the DG moves) that are short enough
//! to be one fault — a multipath jump appears with one break and vanishes with the next (Cazzaniga et al. 2007 §1.2).
//! There the reported DG σ says nothing about the offset (a solution blind to multipath reports its usual
//! centimetres), so the prior's position σ is floored at the size of such jumps and the control decides. The
//! offset is one for the whole span, so the floor counts once per span, not once per node: a node standing
//! for Δt seconds of a span lasting D gets σ_floor · √(D / Δt), and the nodes together hold the span's
//! common offset with σ_floor whatever their number.

/// The spans of possible faults: every break itself, and the span from one break to the next when they are
/// at most `max_duration` apart. `breaks` are (start, end) intervals in any order.
pub(crate) fn fault_spans(breaks: &[(f64, f64)], max_duration: f64) -> Vec<(f64, f64)> {
    let mut sorted: Vec<(f64, f64)> = breaks.iter().copied().filter(|(a, b)| a.is_finite() && b >= a).collect();
    sorted.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut out: Vec<(f64, f64)> = sorted.clone();
    for pair in sorted.windows(2) {
        if pair[1].0 - pair[0].1 <= max_duration {
            out.push((pair[0].0, pair[1].1));
        }
    }
    out
}

/// The duration of the longest of `spans` containing `t`, if any.
pub(crate) fn containing(spans: &[(f64, f64)], t: f64) -> Option<f64> {
    spans.iter().filter(|(a, b)| t >= *a && t <= *b).map(|(a, b)| b - a).reduce(f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_join_breaks_close_enough_to_be_one_fault() {
        let spans = fault_spans(&[(100.0, 101.0), (10.0, 12.0), (40.0, 41.0)], 50.0);
        // Each break, 10–41 (28 s apart) joined; 41 → 100 is 59 s: two separate faults' edges.
        assert_eq!(containing(&spans, 25.0), Some(31.0));
        assert_eq!(containing(&spans, 11.0), Some(31.0));
        assert_eq!(containing(&spans, 100.5), Some(1.0));
        assert!([70.0, 5.0, 105.0].iter().all(|t| containing(&spans, *t).is_none()));
    }
}
