//! Scoring pieces against true painted elements (a simulator's geometry or an agency's marking layer):
//! how much of the true paint was recovered, how much of the extracted paint is real, and how close the
//! piece vertices lie to the true centre lines.

use std::collections::HashMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::geometry::{add_scaled, dist, line_angle, midpoints, resample, segment_distance, sub, unit};
use crate::lines::LineKind;
use crate::piece::Piece;

/// Spacing of the samples along true and extracted centre lines, metres.
const SAMPLE_M: f64 = 0.1;
/// Largest angle between a sample's direction and the segment that matches it, degrees.
const ANGLE_DEG: f64 = 10.0;

/// A true painted element (from a simulator's geometry or an agency's marking layer).
#[derive(Clone, Debug, PartialEq)]
pub struct TruthElement {
    /// The marking's identity in its layer (its parts within reach of the drive share it).
    pub id: String,
    /// What it is; `Other` (arrows, symbols) makes extracted paint correct but is not expected to be found.
    pub kind: LineKind,
    /// Centre-line vertices, easting/northing, metres.
    pub points: Vec<[f64; 2]>,
    /// Painted width, metres.
    pub width_m: f64,
}

/// Settings of the evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct EvaluateConfig {
    /// A piece within this of a truth centre line is the same element, metres.
    pub match_m: f64,
    /// A matched vertex within this of the truth centre line is accurate, metres.
    pub accuracy_m: f64,
}

impl Default for EvaluateConfig {
    fn default() -> Self {
        Self { match_m: 0.25, accuracy_m: 0.05 }
    }
}

/// How pieces compare with the truth. Lengths are sums over samples every 0.1 m (at most) along the centre
/// lines, each standing for its share of the length; a sample "matches" a centre line when a segment of it
/// lies within `match_m` with a direction within 10°.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct LineScore {
    /// Total centre-line length of the truth elements that are not `Other`, metres.
    pub truth_length_m: f64,
    /// The part of `truth_length_m` matched by some piece, metres.
    pub recovered_length_m: f64,
    /// Total centre-line length of the pieces, metres.
    pub extracted_length_m: f64,
    /// The part of `extracted_length_m` matched by some truth element (of any kind), metres.
    pub correct_length_m: f64,
    /// Number of piece vertices within `match_m` of a truth centre line (any kind, any direction).
    pub vertices: usize,
    /// Number of those within `accuracy_m`.
    pub vertices_within: usize,
    /// 95 % quantile (`plumbline_geo::metrics::quantile`) of those vertices' distances to the nearest truth centre line, metres.
    pub vertex_error_q95_m: f64,
}

impl LineScore {
    /// recovered / truth length (0 without truth).
    pub fn recovered_share(&self) -> f64 {
        share(self.recovered_length_m, self.truth_length_m)
    }

    /// correct / extracted length (0 without pieces).
    pub fn correct_share(&self) -> f64 {
        share(self.correct_length_m, self.extracted_length_m)
    }

    /// vertices within `accuracy_m` / matched vertices (0 without matched vertices).
    pub fn within_share(&self) -> f64 {
        share(self.vertices_within as f64, self.vertices as f64)
    }
}

fn share(part: f64, whole: f64) -> f64 {
    if whole > 0.0 { part / whole } else { 0.0 }
}

/// The parts of `truth` within `radius` of some point of `centres` (e.g. the panoramas' camera positions and
/// the range the extraction keeps): paint the drive never came near is not counted as missed. Each element is
/// cut into its runs of centre-line samples (every 0.1 m) inside the reach.
pub fn within_reach(truth: &[TruthElement], centres: &[[f64; 2]], radius: f64) -> Vec<TruthElement> {
    let cell = radius.max(1e-3);
    let key = |p: [f64; 2]| ((p[0] / cell).floor() as i64, (p[1] / cell).floor() as i64);
    let mut grid: HashMap<(i64, i64), Vec<[f64; 2]>> = HashMap::new();
    for c in centres.iter().filter(|c| c[0].is_finite() && c[1].is_finite()) {
        grid.entry(key(*c)).or_default().push(*c);
    }
    let inside = |p: [f64; 2]| {
        let (i, j) = key(p);
        (i - 1..=i + 1).any(|a| {
            (j - 1..=j + 1).any(|b| grid.get(&(a, b)).is_some_and(|v| v.iter().any(|c| dist(*c, p) <= radius)))
        })
    };
    let mut out = Vec::new();
    for t in truth {
        let mut run: Vec<[f64; 2]> = Vec::new();
        for s in resample(&t.points, SAMPLE_M) {
            if inside(s.p) {
                run.push(s.p);
            } else if run.len() >= 2 {
                out.push(TruthElement { points: std::mem::take(&mut run), ..t.clone() });
            } else {
                run.clear();
            }
        }
        if run.len() >= 2 {
            out.push(TruthElement { points: run, ..t.clone() });
        }
    }
    out
}

/// Score `pieces` against `truth` (see [`LineScore`] for what each figure means).
pub fn evaluate(pieces: &[Piece], truth: &[TruthElement], config: &EvaluateConfig) -> LineScore {
    let reach = config.match_m.max(0.0);
    let truth_index = SegmentIndex::new(truth.iter().map(|t| t.points.as_slice()), reach);
    let piece_index = SegmentIndex::new(pieces.iter().map(|p| p.vertices.as_slice()), reach);
    let mut score = LineScore::default();
    for t in truth.iter().filter(|t| t.kind != LineKind::Other) {
        for s in midpoints(&t.points, SAMPLE_M) {
            score.truth_length_m += s.weight;
            if piece_index.matches(s.p, s.t, reach) {
                score.recovered_length_m += s.weight;
            }
        }
    }
    let mut errors = Vec::new();
    for p in pieces {
        for s in midpoints(&p.vertices, SAMPLE_M) {
            score.extracted_length_m += s.weight;
            if truth_index.matches(s.p, s.t, reach) {
                score.correct_length_m += s.weight;
            }
        }
        errors.extend(p.vertices.iter().filter_map(|&v| truth_index.nearest(v, reach)));
    }
    score.vertices = errors.len();
    score.vertices_within = errors.iter().filter(|&&e| e <= config.accuracy_m).count();
    score.vertex_error_q95_m = plumbline_geo::metrics::quantile(&mut errors, 0.95).unwrap_or(0.0);
    score
}

/// How one marking of the reference fared against the pieces.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ElementScore {
    /// The marking's id.
    pub id: String,
    /// Its kind.
    pub kind: &'static str,
    /// Its centre-line length within reach, metres.
    pub length_m: f64,
    /// The part of it some piece matches, metres.
    pub recovered_length_m: f64,
    /// Median over its matched samples (every 0.1 m) of the distance to the piece that matches them, metres;
    /// `None` when nothing matched.
    pub deviation_median_m: Option<f64>,
    /// The largest of those distances, metres.
    pub deviation_max_m: Option<f64>,
}

/// A marking is found when at least this share of its length is recovered.
pub const FOUND_SHARE: f64 = 0.5;

impl ElementScore {
    /// recovered / length (0 for a marking of no length).
    pub fn recovered_share(&self) -> f64 {
        share(self.recovered_length_m, self.length_m)
    }

    /// Whether [`FOUND_SHARE`] of its length or more is recovered.
    pub fn is_found(&self) -> bool {
        self.recovered_share() >= FOUND_SHARE
    }
}

/// Score every marking of `truth` that is not `Other` (parts with one id taken together, in order of first
/// appearance): how much of it the pieces recovered and how far the matching pieces lie from it.
pub fn per_element(pieces: &[Piece], truth: &[TruthElement], config: &EvaluateConfig) -> Vec<ElementScore> {
    let reach = config.match_m.max(0.0);
    let piece_index = SegmentIndex::new(pieces.iter().map(|p| p.vertices.as_slice()), reach);
    let mut order: Vec<String> = Vec::new();
    let mut by_id: HashMap<String, (ElementScore, Vec<f64>)> = HashMap::new();
    for t in truth.iter().filter(|t| t.kind != LineKind::Other) {
        let (score, deviations) = by_id.entry(t.id.clone()).or_insert_with(|| {
            order.push(t.id.clone());
            let score = ElementScore {
                id: t.id.clone(),
                kind: t.kind.as_str(),
                length_m: 0.0,
                recovered_length_m: 0.0,
                deviation_median_m: None,
                deviation_max_m: None,
            };
            (score, Vec::new())
        });
        for s in midpoints(&t.points, SAMPLE_M) {
            score.length_m += s.weight;
            if let Some(d) = piece_index.nearest_matching(s.p, s.t, reach) {
                score.recovered_length_m += s.weight;
                deviations.push(d);
            }
        }
    }
    order
        .into_iter()
        .filter_map(|id| by_id.remove(&id))
        .map(|(mut score, mut deviations)| {
            score.deviation_median_m = plumbline_geo::metrics::quantile(&mut deviations, 0.5);
            score.deviation_max_m = deviations.iter().copied().max_by(f64::total_cmp);
            score
        })
        .collect()
}

/// Polyline segments (cut to at most 1 m) in a grid of cells, each listed in every cell within `reach`.
struct SegmentIndex {
    segments: Vec<([f64; 2], [f64; 2])>,
    cell: f64,
    cells: HashMap<(i64, i64), Vec<usize>>,
}

impl SegmentIndex {
    fn new<'a>(lines: impl Iterator<Item = &'a [[f64; 2]]>, reach: f64) -> Self {
        let cell = 1.0_f64.max(reach);
        let mut index = Self { segments: Vec::new(), cell, cells: HashMap::new() };
        for line in lines {
            for w in line.windows(2) {
                let Some(t) = unit(sub(w[1], w[0])) else { continue };
                let len = dist(w[0], w[1]);
                let parts = len.ceil().max(1.0) as usize;
                for k in 0..parts {
                    let a = add_scaled(w[0], t, len * k as f64 / parts as f64);
                    let b = add_scaled(w[0], t, len * (k + 1) as f64 / parts as f64);
                    index.insert(a, b, reach);
                }
            }
        }
        index
    }

    fn key(&self, p: [f64; 2]) -> (i64, i64) {
        ((p[0] / self.cell).floor() as i64, (p[1] / self.cell).floor() as i64)
    }

    fn insert(&mut self, a: [f64; 2], b: [f64; 2], reach: f64) {
        let lo = self.key([a[0].min(b[0]) - reach, a[1].min(b[1]) - reach]);
        let hi = self.key([a[0].max(b[0]) + reach, a[1].max(b[1]) + reach]);
        let id = self.segments.len();
        self.segments.push((a, b));
        for x in lo.0..=hi.0 {
            for y in lo.1..=hi.1 {
                self.cells.entry((x, y)).or_default().push(id);
            }
        }
    }

    fn candidates(&self, p: [f64; 2]) -> impl Iterator<Item = &([f64; 2], [f64; 2])> + '_ {
        self.cells.get(&self.key(p)).into_iter().flatten().map(|&i| &self.segments[i])
    }

    /// Whether a segment within `reach` of `p` runs within 10° of direction `t`.
    fn matches(&self, p: [f64; 2], t: [f64; 2], reach: f64) -> bool {
        self.nearest_matching(p, t, reach).is_some()
    }

    /// Distance to the nearest segment within `reach` that runs within 10° of direction `t`.
    fn nearest_matching(&self, p: [f64; 2], t: [f64; 2], reach: f64) -> Option<f64> {
        self.candidates(p)
            .filter_map(|&(a, b)| {
                let (d, dir) = segment_distance(p, a, b);
                (d <= reach && dir.is_some_and(|u| line_angle(u, t) <= ANGLE_DEG.to_radians())).then_some(d)
            })
            .min_by(f64::total_cmp)
    }

    /// Distance to the nearest segment, when within `reach`.
    fn nearest(&self, p: [f64; 2], reach: f64) -> Option<f64> {
        self.candidates(p).map(|&(a, b)| segment_distance(p, a, b).0).filter(|&d| d <= reach).min_by(f64::total_cmp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn piece(x: f64, y0: f64, y1: f64) -> Piece {
        let vertices: Vec<[f64; 2]> = (0..=6).map(|k| [x, y0 + (y1 - y0) * f64::from(k) / 6.0]).collect();
        Piece {
            sigma_m: vec![0.01; vertices.len()],
            vertices,
            width_m: 0.12,
            observations: 3,
            panoramas: 3,
            closed: [true; 2],
        }
    }

    fn truth(kind: LineKind, x: f64, y0: f64, y1: f64) -> TruthElement {
        TruthElement { id: format!("x{x}y{y0}"), kind, points: vec![[x, y0], [x, y1]], width_m: 0.12 }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn only_paint_within_reach_of_the_drive_is_kept() {
        // A 30 m line along y; the drive came within 5 m of y = 0..10 and of y = 20..22 only.
        let line = [truth(LineKind::Solid, 0.0, 0.0, 30.0)];
        let centres = [[3.0, 2.0], [3.0, 6.0], [4.0, 21.0]];
        let kept = within_reach(&line, &centres, 5.0);
        let spans: Vec<(f64, f64)> = kept.iter().map(|t| (t.points[0][1], t.points[t.points.len() - 1][1])).collect();
        assert_eq!(spans.len(), 2, "{spans:?}");
        // From centre (3, 2) the line is reached for |y − 2| ≤ 4; from (3, 6) up to y = 10; from (4, 21) ±3.
        assert!((spans[0].0 - 0.0).abs() < 1e-9 && (spans[0].1 - 10.0).abs() < 0.1, "{spans:?}");
        assert!((spans[1].0 - 18.0).abs() < 0.1 && (spans[1].1 - 24.0).abs() < 0.1, "{spans:?}");
        assert!(kept.iter().all(|t| t.kind == LineKind::Solid && close(t.width_m, 0.12)));
        assert!(within_reach(&line, &[], 5.0).is_empty(), "no drive, nothing in reach");
    }

    #[test]
    fn offsets_of_one_ten_and_hundred_centimetres_are_within_correct_and_wrong() {
        let truths = [truth(LineKind::Dashed, 0.0, 0.0, 3.0), truth(LineKind::Dashed, 0.0, 9.0, 12.0)];
        let pieces = [piece(0.01, 0.0, 3.0), piece(0.10, 9.0, 12.0), piece(1.0, 0.0, 3.0)];
        let s = evaluate(&pieces, &truths, &EvaluateConfig::default());
        assert!(close(s.truth_length_m, 6.0) && close(s.recovered_length_m, 6.0), "{s:?}");
        assert!(close(s.extracted_length_m, 9.0) && close(s.correct_length_m, 6.0), "{s:?}");
        assert!(close(s.correct_share(), 2.0 / 3.0) && close(s.recovered_share(), 1.0));
        // 7 vertices at 1 cm and 7 at 10 cm are matched; the 1 m piece's are not.
        assert_eq!((s.vertices, s.vertices_within), (14, 7));
        assert!(close(s.within_share(), 0.5) && (s.vertex_error_q95_m - 0.10).abs() < 1e-9, "{s:?}");
    }

    #[test]
    fn a_missing_dash_costs_exactly_its_share_and_arrows_count_only_as_correct() {
        let truths = [
            truth(LineKind::Dashed, 0.0, 0.0, 3.0),
            truth(LineKind::Dashed, 0.0, 9.0, 12.0),
            truth(LineKind::Dashed, 0.0, 18.0, 21.0),
            truth(LineKind::Other, 2.0, 0.0, 5.0),
        ];
        let pieces = [piece(0.0, 0.0, 3.0), piece(0.0, 18.0, 21.0), piece(2.0, 1.0, 4.0)];
        let s = evaluate(&pieces, &truths, &EvaluateConfig::default());
        assert!(close(s.truth_length_m, 9.0) && close(s.recovered_share(), 2.0 / 3.0), "{s:?}");
        assert!(close(s.correct_share(), 1.0) && s.vertices == 21 && s.vertices_within == 21, "{s:?}");
        // A piece across a truth line is not correct, though its middle vertex lies on it.
        let across = Piece { vertices: vec![[-1.0, 1.5], [0.0, 1.5], [1.0, 1.5]], ..piece(0.0, 0.0, 1.0) };
        let s = evaluate(&[across], &truths[..1], &EvaluateConfig::default());
        assert!(close(s.correct_length_m, 0.0) && close(s.recovered_length_m, 0.0) && s.vertices == 1, "{s:?}");
        assert_eq!(evaluate(&[], &[], &EvaluateConfig::default()), LineScore::default());
    }

    #[test]
    fn each_marking_is_scored_with_its_parts_together_and_its_deviation() {
        // Marking a in two parts (y 0–3 and 6–9) found 2 cm off along 0–3 only; b found along half its
        // length 10 cm off; c not found; the arrow left out.
        let mut truths = vec![
            truth(LineKind::Solid, 0.0, 0.0, 3.0),
            truth(LineKind::Solid, 0.0, 6.0, 9.0),
            truth(LineKind::Dashed, 5.0, 0.0, 4.0),
            truth(LineKind::StopLine, 9.0, 0.0, 2.0),
            truth(LineKind::Other, 12.0, 0.0, 2.0),
        ];
        truths[1].id = truths[0].id.clone();
        let pieces = [piece(0.02, 0.0, 3.0), piece(5.1, 0.0, 2.0)];
        let scores = per_element(&pieces, &truths, &EvaluateConfig::default());
        let ids: Vec<&str> = scores.iter().map(|s| s.id.as_str()).collect();
        assert_eq!(ids, ["x0y0", "x5y0", "x9y0"]);
        let (a, b, c) = (&scores[0], &scores[1], &scores[2]);
        assert!(close(a.length_m, 6.0) && close(a.recovered_share(), 0.5), "{a:?}");
        assert!(
            (a.deviation_median_m.unwrap() - 0.02).abs() < 1e-9 && (a.deviation_max_m.unwrap() - 0.02).abs() < 1e-9
        );
        // b: y 0–2 and the 0.2 m past the piece's end still within 0.25 m of it.
        assert!(
            (b.recovered_length_m - 2.2).abs() < 1e-9 && (b.deviation_median_m.unwrap() - 0.1).abs() < 1e-9,
            "{b:?}"
        );
        assert!(b.deviation_max_m.is_some_and(|d| d > 0.1 && d <= 0.25), "{b:?}");
        assert!(close(c.recovered_length_m, 0.0) && c.deviation_median_m.is_none() && c.kind == "stop_line", "{c:?}");
    }
}
