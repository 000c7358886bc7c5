//! The offset and the assignment of one frame: hypotheses from the frame's detection–cadastre pairs in the
//! gate, support counted over the tracks of the surrounding frames, rival offsets, then per detection the
//! nearest cadastre pole after the offset with the ratio test, and duplicates resolved.

use plumbline_campaign::CadastreFeature;

use super::index::Grid;
use super::{Match, MatchConfig, MatchInput, MatchedFrame, Unmatched, UnmatchedReason};
use crate::detect::Detection;

/// Bearing margin of the view sector for unseen poles, radians (2°).
const VIEW_MARGIN_RAD: f64 = 0.035;
/// Offsets closer than this are the same hypothesis, metres.
const SAME_OFFSET_M: f64 = 0.3;

/// A detection of the window around the frame: its frame distance, track and values.
struct Voter<'a> {
    lag: usize,
    track: usize,
    detection: &'a Detection,
}

/// A candidate offset with its support (tracks) and cost (sum of squared normalised residuals).
#[derive(Clone, Copy, Debug)]
struct Hypothesis {
    offset: [f64; 2],
    support: usize,
    cost: f64,
}

fn diameter_ok(d: &Detection, f: &CadastreFeature, c: &MatchConfig) -> bool {
    f.diameter_m
        .is_none_or(|listed| (d.diameter_m - listed).abs() <= c.diameter_sigmas * d.diameter_sigma_m.hypot(0.02) + 0.05)
}

/// Inlier tolerance of a detection–cadastre pair `lag` frames from the frame.
fn tolerance(d: &Detection, f: &CadastreFeature, lag: usize, c: &MatchConfig) -> f64 {
    let drift = c.relative_sigma_m * (lag as f64).max(1.0);
    c.inlier_sigmas * (d.sigma().powi(2) + f.accuracy_m.powi(2) + drift.powi(2)).sqrt()
}

/// The cadastre poles a detection can be before any offset is known: within the DG gate (`gate_sigmas` DG
/// σ, clamped) plus `inlier_sigmas` of the pair's own σ — the detection's and the cadastre object's
/// accuracy together, so a pole surveyed to ±0.5 m is looked for that much farther — nearest first.
fn gated(
    grid: &Grid<'_>,
    feats: &[CadastreFeature],
    input: &MatchInput,
    d: &Detection,
    c: &MatchConfig,
) -> Vec<(usize, f64)> {
    let dg = (c.gate_sigmas * input.dg_sigma_m).clamp(c.min_gate_m, c.max_gate_m);
    let gate = |accuracy: f64| dg + c.inlier_sigmas * d.sigma().hypot(accuracy);
    let mut near = candidates(grid, feats, d, d.centre, gate(grid.max_accuracy_m), c);
    near.retain(|&(i, dist)| dist <= gate(if feats[i].accuracy_m.is_finite() { feats[i].accuracy_m } else { 0.0 }));
    near
}

/// Candidates of a (shifted) detection: compatible cadastre features within `radius`, nearest first.
fn candidates(
    grid: &Grid<'_>,
    feats: &[CadastreFeature],
    d: &Detection,
    at: [f64; 2],
    radius: f64,
    c: &MatchConfig,
) -> Vec<(usize, f64)> {
    grid.within(at, radius).into_iter().filter(|(i, _)| diameter_ok(d, &feats[*i], c)).collect()
}

fn shifted(d: &Detection, t: [f64; 2]) -> [f64; 2] {
    [d.centre[0] + t[0], d.centre[1] + t[1]]
}

/// Support and cost of an offset over the window's tracks.
fn score(
    t: [f64; 2],
    voters: &[Voter<'_>],
    grid: &Grid<'_>,
    feats: &[CadastreFeature],
    c: &MatchConfig,
) -> (usize, f64) {
    let mut best_per_track: std::collections::BTreeMap<usize, f64> = std::collections::BTreeMap::new();
    for v in voters {
        let at = shifted(v.detection, t);
        let Some(&(i, dist)) = candidates(grid, feats, v.detection, at, c.max_gate_m, c).first() else { continue };
        let tol = tolerance(v.detection, &feats[i], v.lag, c);
        if dist <= tol {
            let q = (dist * c.inlier_sigmas / tol).powi(2);
            let e = best_per_track.entry(v.track).or_insert(f64::INFINITY);
            *e = e.min(q);
        }
    }
    (best_per_track.len(), best_per_track.values().sum())
}

/// Match frame `k`.
pub(super) fn frame(
    k: usize,
    frames: &[MatchInput],
    tracks: &[Vec<usize>],
    feats: &[CadastreFeature],
    grid: &Grid<'_>,
    c: &MatchConfig,
) -> MatchedFrame {
    let input = &frames[k];
    let dets = &input.detections.detections;
    let voters: Vec<Voter<'_>> = (k.saturating_sub(c.window)..=(k + c.window).min(frames.len() - 1))
        .flat_map(|j| {
            // Only detections within the sensor's reliable range propose and support offsets.
            frames[j].detections.detections.iter().enumerate().filter(|(_, d)| d.reliable).map(move |(i, d)| Voter {
                lag: j.abs_diff(k),
                track: tracks[j][i],
                detection: d,
            })
        })
        .collect();
    let mut hypotheses: Vec<Hypothesis> = Vec::new();
    for d in dets.iter().filter(|d| d.reliable) {
        for (i, _) in gated(grid, feats, input, d, c) {
            let offset = [feats[i].easting - d.centre[0], feats[i].northing - d.centre[1]];
            let (support, cost) = score(offset, &voters, grid, feats, c);
            hypotheses.push(Hypothesis { offset, support, cost });
        }
    }
    let best = hypotheses.iter().copied().max_by(|a, b| a.support.cmp(&b.support).then(b.cost.total_cmp(&a.cost)));
    let rival = best.is_some_and(|b| {
        hypotheses.iter().any(|h| {
            h.support >= b.support && (h.offset[0] - b.offset[0]).hypot(h.offset[1] - b.offset[1]) > SAME_OFFSET_M
        })
    });
    let offset = best.filter(|b| !rival && b.support > 0);
    let mut out = MatchedFrame {
        offset: offset.map(|b| b.offset),
        support: offset.map_or(0, |b| b.support),
        ..MatchedFrame::default()
    };
    for (i, d) in dets.iter().enumerate() {
        let track = tracks[k][i];
        let reason = match offset {
            None if gated(grid, feats, input, d, c).is_empty() => Some(UnmatchedReason::NoCandidate),
            None => Some(UnmatchedReason::AmbiguousOffset),
            Some(b) => match assign_one(d, b.offset, grid, feats, c) {
                Ok((cadastre, residual)) => {
                    out.matches.push(Match { detection: i, cadastre, track, residual });
                    None
                }
                Err(reason) => Some(reason),
            },
        };
        if let Some(reason) = reason {
            out.unmatched.push(Unmatched { detection: i, track, reason });
        }
    }
    resolve_duplicates(&mut out);
    out.unseen = unseen(input, &out, grid, feats);
    out
}

/// The cadastre pole of one detection after the offset, with the ratio test.
fn assign_one(
    d: &Detection,
    t: [f64; 2],
    grid: &Grid<'_>,
    feats: &[CadastreFeature],
    c: &MatchConfig,
) -> Result<(usize, [f64; 2]), UnmatchedReason> {
    let at = shifted(d, t);
    let near = candidates(grid, feats, d, at, c.max_gate_m, c);
    let Some(&(i, e1)) = near.first() else { return Err(UnmatchedReason::NoCandidate) };
    let tol = tolerance(d, &feats[i], 0, c);
    if e1 > tol {
        return Err(UnmatchedReason::InconsistentWithOffset);
    }
    if let Some(&(j, e2)) = near.get(1)
        && (e2 <= tolerance(d, &feats[j], 0, c) || e2 < c.ratio * e1)
    {
        return Err(UnmatchedReason::AmbiguousPole);
    }
    Ok((i, [feats[i].easting - at[0], feats[i].northing - at[1]]))
}

/// Of two detections matched to one cadastre pole, the one with the larger residual is a duplicate.
fn resolve_duplicates(out: &mut MatchedFrame) {
    let norm = |m: &Match| m.residual[0].hypot(m.residual[1]);
    let mut keep: Vec<Match> = Vec::with_capacity(out.matches.len());
    let mut sorted = std::mem::take(&mut out.matches);
    sorted.sort_by(|a, b| norm(a).total_cmp(&norm(b)));
    for m in sorted {
        if keep.iter().any(|k| k.cadastre == m.cadastre) {
            out.unmatched.push(Unmatched {
                detection: m.detection,
                track: m.track,
                reason: UnmatchedReason::Duplicate,
            });
        } else {
            keep.push(m);
        }
    }
    keep.sort_by_key(|m| m.detection);
    out.matches = keep;
    out.unmatched.sort_by_key(|u| u.detection);
}

/// Cadastre poles inside the frame's view sector (shifted into the DG frame by the offset) not matched.
fn unseen(input: &MatchInput, out: &MatchedFrame, grid: &Grid<'_>, feats: &[CadastreFeature]) -> Vec<usize> {
    let view = &input.detections.view;
    let t = out.offset.unwrap_or([0.0; 2]);
    grid.within(view.origin, view.max_range_m + t[0].hypot(t[1]))
        .into_iter()
        .filter(|(i, _)| {
            let p = [feats[*i].easting - t[0], feats[*i].northing - t[1]];
            view.contains(p, VIEW_MARGIN_RAD) && !out.matches.iter().any(|m| m.cadastre == *i)
        })
        .map(|(i, _)| i)
        .collect()
}
