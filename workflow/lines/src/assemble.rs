//! Tracking strokes across panoramas: every observation is resampled, its samples are hashed, and strokes
//! whose samples lie close across and along with similar directions are united into pieces (one dash, one
//! zebra stripe, one stop line or a continuous line). A piece's centre line is traced along its samples with
//! σ-weighted across offsets, so curved lines keep their shape; its ends come from the observations that saw
//! them closed. The pieces are then classified into road lines (see `lines.rs`); the piece and the settings
//! both steps read are in `piece.rs`.

use std::collections::HashMap;

use crate::geometry::{add_scaled, cross, dist, dot, line_angle, median_or_zero, normal, resample, sub, unit};
use crate::lines::{self, RoadLine};
use crate::piece::{AssembleConfig, Piece};

/// A stroke placed in the corrected frame, as the assembly reads it.
#[derive(Clone, Debug, PartialEq)]
pub struct Observed {
    /// Centre-line vertices, easting/northing, metres; at least two, in order along the element.
    pub points: Vec<[f64; 2]>,
    /// Painted width, metres.
    pub width_m: f64,
    /// Total 1σ of a vertex across the line: extraction ⊕ trajectory, metres.
    pub sigma_m: f64,
    /// The part of `sigma_m` the observations of neighbouring panoramas share (the trajectory's error, which
    /// changes slowly along the drive), metres: averaging observations does not reduce it.
    pub common_sigma_m: f64,
    /// Whether the start / end is open (the element's true end unseen).
    pub open: [bool; 2],
    /// Index of the panorama.
    pub panorama: usize,
    /// Driving direction at the panorama, radians clockwise from grid north.
    pub heading: f64,
}

/// The pieces and the road lines built from them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Assembly {
    /// Every piece.
    pub pieces: Vec<Piece>,
    /// Every piece belongs to exactly one line.
    pub lines: Vec<RoadLine>,
}

/// Unite the observations into pieces and classify the pieces into lines. Observations with fewer than two
/// points or non-finite values are ignored.
pub fn assemble(observed: &[Observed], config: &AssembleConfig) -> Assembly {
    let usable: Vec<&Observed> = observed.iter().filter(|o| usable(o)).collect();
    let samples = Samples::new(&usable, config);
    let groups = samples.groups(&usable, config);
    let mut pieces = Vec::new();
    let mut info = Vec::new();
    for group in groups {
        if let Some(piece) = samples.piece(&usable, &group, config) {
            let mut panoramas: Vec<usize> = group.iter().map(|&k| usable[k].panorama).collect();
            panoramas.sort_unstable();
            panoramas.dedup();
            let heading = axial_mean(group.iter().map(|&k| usable[k].heading));
            pieces.push(piece);
            info.push(lines::PieceInfo { heading, panoramas });
        }
    }
    let lines = lines::classify(&pieces, &info, config);
    Assembly { pieces, lines }
}

fn usable(o: &Observed) -> bool {
    let finite = o.points.iter().all(|p| p[0].is_finite() && p[1].is_finite());
    finite
        && o.points.len() >= 2
        && o.width_m.is_finite()
        && o.sigma_m.is_finite()
        && o.common_sigma_m.is_finite()
        && o.heading.is_finite()
}

/// Mean of undirected angles (modulo π), radians.
fn axial_mean(angles: impl Iterator<Item = f64>) -> f64 {
    let (s, c) = angles.fold((0.0, 0.0), |(s, c), a| (s + (2.0 * a).sin(), c + (2.0 * a).cos()));
    0.5 * s.atan2(c)
}

/// Weight 1/σ² of an observation, σ floored at 1 mm.
fn weight(o: &Observed) -> f64 {
    1.0 / o.sigma_m.max(0.001).powi(2)
}

/// Union–find over observations.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// What one window of samples says about the centre line: across offset, direction and σ.
#[derive(Clone, Copy, Debug)]
struct Fit {
    offset: f64,
    tangent: [f64; 2],
    sigma: f64,
}

/// Every observation's samples in a spatial hash.
struct Samples {
    points: Vec<[f64; 2]>,
    tangents: Vec<[f64; 2]>,
    owner: Vec<usize>,
    /// The samples of each observation.
    ranges: Vec<std::ops::Range<usize>>,
    cell: f64,
    hash: HashMap<(i64, i64), Vec<usize>>,
}

impl Samples {
    fn new(observed: &[&Observed], config: &AssembleConfig) -> Self {
        let cell = config.link_along_m.max(config.link_across_max_m).max(0.5 * config.vertex_step_m).max(0.05);
        let mut s = Self {
            points: Vec::new(),
            tangents: Vec::new(),
            owner: Vec::new(),
            ranges: Vec::new(),
            cell,
            hash: HashMap::new(),
        };
        for (k, o) in observed.iter().enumerate() {
            let first = s.points.len();
            for sample in resample(&o.points, config.sample_m.max(0.01)) {
                s.hash.entry(s.key(sample.p)).or_default().push(s.points.len());
                s.points.push(sample.p);
                s.tangents.push(sample.t);
                s.owner.push(k);
            }
            s.ranges.push(first..s.points.len());
        }
        s
    }

    fn key(&self, p: [f64; 2]) -> (i64, i64) {
        ((p[0] / self.cell).floor() as i64, (p[1] / self.cell).floor() as i64)
    }

    /// Samples within `r` (a square) of `p`.
    fn near(&self, p: [f64; 2], r: f64) -> impl Iterator<Item = usize> + '_ {
        let (lo, hi) = (self.key([p[0] - r, p[1] - r]), self.key([p[0] + r, p[1] + r]));
        (lo.0..=hi.0)
            .flat_map(move |x| (lo.1..=hi.1).map(move |y| (x, y)))
            .filter_map(|k| self.hash.get(&k))
            .flatten()
            .copied()
    }

    /// Observations united by close samples, each group sorted.
    fn groups(&self, observed: &[&Observed], config: &AssembleConfig) -> Vec<Vec<usize>> {
        let mut parent: Vec<usize> = (0..observed.len()).collect();
        let max_angle = config.link_angle_deg.to_radians();
        for i in 0..self.points.len() {
            let oi = self.owner[i];
            for j in self.near(self.points[i], self.cell) {
                let oj = self.owner[j];
                if j <= i || oi == oj || find(&mut parent, oi) == find(&mut parent, oj) {
                    continue;
                }
                let (t, d) = (self.tangents[i], sub(self.points[j], self.points[i]));
                let limit = (config.link_sigmas * observed[oi].sigma_m.hypot(observed[oj].sigma_m))
                    .max(config.link_across_m)
                    .min(config.link_across_max_m);
                let close = cross(t, d).abs() <= limit && dot(t, d).abs() <= config.link_along_m;
                if close && line_angle(t, self.tangents[j]) <= max_angle {
                    let (a, b) = (find(&mut parent, oi), find(&mut parent, oj));
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
        let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
        for k in 0..observed.len() {
            let root = find(&mut parent, k);
            groups.entry(root).or_default().push(k);
        }
        let mut out: Vec<Vec<usize>> = groups.into_values().collect();
        out.sort_unstable();
        out
    }

    /// The samples of a group in the window of half length `step`/2 along `t` around `p`: their σ-weighted
    /// mean across offset, mean direction (oriented like `t`) and the vertex σ (one weight per observation,
    /// as an observation's samples share its errors).
    fn fit(
        &self,
        observed: &[&Observed],
        in_group: &impl Fn(usize) -> bool,
        p: [f64; 2],
        t: [f64; 2],
        step: f64,
        across_max: f64,
    ) -> Option<Fit> {
        let n = normal(t);
        let (mut sw, mut sx, mut st) = (0.0, 0.0, [0.0, 0.0]);
        let mut seen: Vec<usize> = Vec::new();
        for j in self.near(p, step).filter(|&j| in_group(j)) {
            let (d, tj) = (sub(self.points[j], p), self.tangents[j]);
            let inside = dot(d, t).abs() <= 0.5 * step && dot(d, n).abs() <= across_max;
            if !inside || line_angle(tj, t) > 30f64.to_radians() {
                continue;
            }
            let w = weight(observed[self.owner[j]]);
            let s = if dot(tj, t) < 0.0 { -w } else { w };
            (sw, sx, st) = (sw + w, sx + w * dot(d, n), [st[0] + s * tj[0], st[1] + s * tj[1]]);
            if !seen.contains(&self.owner[j]) {
                seen.push(self.owner[j]);
            }
        }
        // The weighted mean's variance: the independent parts average out, the shared part does not.
        let (mut total, mut independent, mut common) = (0.0, 0.0, 0.0);
        for o in seen.iter().map(|&k| observed[k]) {
            let (w, c2) = (weight(o), o.common_sigma_m.min(o.sigma_m).powi(2));
            total += w;
            independent += w * w * (o.sigma_m.max(0.001).powi(2) - c2);
            common += w * c2;
        }
        (sw > 0.0).then(|| Fit {
            offset: sx / sw,
            tangent: unit(st).unwrap_or(t),
            sigma: (independent / (total * total) + common / total).sqrt(),
        })
    }

    /// Trace a group's centre line from its extreme sample, then settle its ends.
    fn piece(&self, observed: &[&Observed], group: &[usize], config: &AssembleConfig) -> Option<Piece> {
        let in_group = |j: usize| group.binary_search(&self.owner[j]).is_ok();
        let members: Vec<usize> = group.iter().flat_map(|&k| self.ranges[k].clone()).collect();
        let count = members.len() as f64;
        let m = members
            .iter()
            .fold([0.0, 0.0], |a, &j| [a[0] + self.points[j][0] / count, a[1] + self.points[j][1] / count]);
        let (mut cxx, mut cyy, mut cxy) = (0.0, 0.0, 0.0);
        for &j in &members {
            let d = sub(self.points[j], m);
            (cxx, cyy, cxy) = (cxx + d[0] * d[0], cyy + d[1] * d[1], cxy + d[0] * d[1]);
        }
        let theta = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
        let a = [theta.cos(), theta.sin()];
        let start = *members
            .iter()
            .min_by(|&&i, &&j| dot(sub(self.points[i], m), a).total_cmp(&dot(sub(self.points[j], m), a)))?;
        let step = config.vertex_step_m.max(0.05);
        let across_max = 0.25_f64.max(config.link_across_max_m);
        let (mut p, mut t) = (self.points[start], a);
        let (mut vertices, mut sigmas) = (Vec::new(), Vec::new());
        let mut misses = 0;
        for _ in 0..members.len() + 10 {
            // Fit twice: the second window is aligned with the local direction the first one found.
            let fit = self.fit(observed, &in_group, p, t, step, across_max);
            let Some(fit) = fit.and_then(|f| self.fit(observed, &in_group, p, f.tangent, step, across_max)) else {
                misses += 1;
                if misses > 2 {
                    break;
                }
                p = add_scaled(p, t, step);
                continue;
            };
            misses = 0;
            let v = add_scaled(p, normal(fit.tangent), fit.offset);
            vertices.push(v);
            sigmas.push(fit.sigma);
            t = fit.tangent;
            p = add_scaled(v, t, step);
        }
        // The far end lies up to half a step beyond the last vertex.
        let (&last, &last_sigma) = (vertices.last()?, sigmas.last()?);
        let reach = self
            .near(last, step)
            .filter(|&j| in_group(j) && cross(t, sub(self.points[j], last)).abs() <= across_max)
            .map(|j| dot(sub(self.points[j], last), t))
            .filter(|&u| u <= step)
            .fold(0.0, f64::max);
        if reach > 0.01 {
            vertices.push(add_scaled(last, t, reach));
            sigmas.push(last_sigma);
        }
        if vertices.len() < 2 {
            return None;
        }
        let closed = [0, 1].map(|end| settle_end(&mut vertices, end, observed, group, config));
        let mut widths: Vec<f64> = group.iter().map(|&k| observed[k].width_m).collect();
        let mut panoramas: Vec<usize> = group.iter().map(|&k| observed[k].panorama).collect();
        panoramas.sort_unstable();
        panoramas.dedup();
        Some(Piece {
            vertices,
            sigma_m: sigmas,
            width_m: median_or_zero(&mut widths),
            observations: group.len(),
            panoramas: panoramas.len(),
            closed,
        })
    }
}

/// Whether an observation saw the piece's `end` (0 start, 1 end) closed; if so, move that end vertex along
/// the line to the σ-weighted mean of those observations' end points.
fn settle_end(
    vertices: &mut [[f64; 2]],
    end: usize,
    observed: &[&Observed],
    group: &[usize],
    config: &AssembleConfig,
) -> bool {
    let n = vertices.len();
    let (at, inner) = if end == 0 { (0, 1) } else { (n - 1, n - 2) };
    let (v, span) = (vertices[at], dist(vertices[at], vertices[inner]));
    let Some(out) = unit(sub(v, vertices[inner])) else { return false };
    let (mut sw, mut su) = (0.0, 0.0);
    for &k in group {
        let o = observed[k];
        for (e, open) in [(o.points[0], o.open[0]), (o.points[o.points.len() - 1], o.open[1])] {
            let d = sub(e, v);
            if !open && dot(d, out).abs() <= config.end_m && cross(out, d).abs() <= config.link_across_max_m {
                (sw, su) = (sw + weight(o), su + weight(o) * dot(d, out));
            }
        }
    }
    if sw > 0.0 {
        vertices[at] = add_scaled(v, out, (su / sw).max(-0.5 * span));
    }
    sw > 0.0
}

#[cfg(test)]
mod tests {
    use plumbline_imaging::ortho::GroundGrid;

    use super::*;
    use crate::extract::{ExtractConfig, extract};
    use crate::geometry::length;
    use crate::lines::LineKind;
    use crate::scene::{PAINT, Road, Shape, distractors, render};

    /// A truth element in road coordinates: x, y range, width (a stop line runs along x at `x.1`).
    struct Element {
        from: [f64; 2],
        to: [f64; 2],
    }

    impl Element {
        /// Across distance of a map point in road coordinates, or `None` beyond the ends (±0.2 m).
        fn across(&self, p: [f64; 2]) -> Option<f64> {
            let t = unit(sub(self.to, self.from))?;
            let d = sub(p, self.from);
            let u = dot(d, t);
            (u > -0.2 && u < dist(self.from, self.to) + 0.2).then(|| cross(t, d).abs())
        }
    }

    /// Road coordinates of a map point.
    fn local(road: &Road, p: [f64; 2]) -> [f64; 2] {
        let d = sub(p, road.origin);
        let (s, c) = road.heading.sin_cos();
        [d[0] * c - d[1] * s, d[0] * s + d[1] * c]
    }

    /// Nine patches 2 m apart along a road with a solid line, four dashes (3 m every 9 m), a stop line and
    /// three zebra stripes; each patch's strokes shifted by a known per-patch error, one patch badly (7 cm)
    /// but with a σ that says so.
    #[test]
    fn overlapping_patches_make_one_piece_per_element_and_the_right_lines() {
        let road = Road { origin: [1000.0, 2000.0], heading: 0.35 };
        let mut shapes = distractors(&road, 4.0, [-6.0, 30.0], [-30.0, 0.0]);
        shapes.push(Shape::Stripe { line: road.line(-2.0, -40.0, -2.0, 40.0), width: 0.12, value: PAINT });
        let mut elements = vec![Element { from: [-2.0, -40.0], to: [-2.0, 40.0] }];
        for k in 0..4 {
            let y = -14.5 + 9.0 * f64::from(k);
            shapes.push(Shape::Stripe { line: road.line(2.0, y, 2.0, y + 3.0), width: 0.12, value: PAINT });
            elements.push(Element { from: [2.0, y], to: [2.0, y + 3.0] });
        }
        shapes.push(Shape::Stripe { line: road.line(-1.8, 9.0, 1.8, 9.0), width: 0.5, value: PAINT });
        elements.push(Element { from: [-1.8, 9.0], to: [1.8, 9.0] });
        for x in [-1.25, -0.25, 0.75] {
            shapes.push(Shape::Stripe { line: road.line(x, -13.0, x, -10.0), width: 0.5, value: PAINT });
            elements.push(Element { from: [x, -13.0], to: [x, -10.0] });
        }
        let mut observed = Vec::new();
        for k in 0u32..9 {
            let y = 2.0 * (f64::from(k) - 4.0);
            let grid = GroundGrid::new(road.map(0.0, y), 0.03, 400, 400, 0.0).unwrap();
            let (image, valid) = render(&grid, &shapes, 0.02, 100 + u64::from(k), Some((road.map(-1.0, y), 1.2)));
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            let (shift, sigma) = if k == 2 { (0.07, 0.3) } else { (0.01 * sign, 0.01) };
            let offset = sub(road.map(shift, shift), road.origin);
            for s in extract(&image, &valid, &grid, &ExtractConfig::default()) {
                observed.push(Observed {
                    points: s.points.iter().map(|p| [p[0] + offset[0], p[1] + offset[1]]).collect(),
                    width_m: s.width_m,
                    sigma_m: s.sigma_m.hypot(sigma),
                    common_sigma_m: 0.0,
                    open: s.open,
                    panorama: k as usize,
                    heading: road.heading,
                });
            }
        }
        let assembly = assemble(&observed, &AssembleConfig::default());
        // Every piece lies on one element, to a centimetre and a bit despite the bad patch.
        let mut per = vec![Vec::new(); elements.len()];
        for (i, piece) in assembly.pieces.iter().enumerate() {
            let locals: Vec<[f64; 2]> = piece.vertices.iter().map(|&v| local(&road, v)).collect();
            let owner = elements.iter().position(|e| locals.iter().all(|&p| e.across(p).is_some_and(|x| x < 0.1)));
            let Some(owner) = owner else { panic!("piece on no element: {locals:?}") };
            let err = locals.iter().filter_map(|&p| elements[owner].across(p)).fold(0.0, f64::max);
            assert!(err < 0.012, "piece {i} on element {owner}: error {err}");
            assert!(piece.sigma_m.iter().all(|&s| s > 0.0 && s < 0.02));
            per[owner].push(i);
        }
        assert!(per.iter().all(|p| p.len() == 1), "pieces per element {per:?}");
        let pieces = &assembly.pieces;
        let length_of = |e: usize| length(&pieces[per[e][0]].vertices);
        assert!(length_of(0) > 25.0 && pieces[per[0][0]].panoramas == 9);
        // The dashes seen whole are closed and 3 m long; the first is closed only where it was seen to end.
        for e in [2, 3] {
            assert!((length_of(e) - 3.0).abs() < 0.05 && pieces[per[e][0]].closed == [true, true]);
        }
        let first = &pieces[per[1][0]];
        let ends = [first.vertices[0], first.vertices[first.vertices.len() - 1]].map(|v| local(&road, v)[1]);
        let near_end = usize::from(ends[1] > ends[0]);
        assert!((ends[near_end] + 11.5).abs() < 0.05 && first.closed[near_end] && !first.closed[1 - near_end]);
        // Lines: the dashes chained with their pattern, the solid line, the stop line, the zebra stripes.
        let kinds = |k: LineKind| assembly.lines.iter().filter(|l| l.kind == k).collect::<Vec<_>>();
        let dashed = kinds(LineKind::Dashed);
        assert_eq!(dashed.len(), 1, "{:?}", assembly.lines);
        let pattern = dashed[0].dash.unwrap();
        assert!((pattern.dash_m - 3.0).abs() < 0.1 && (pattern.gap_m - 6.0).abs() < 0.1, "{pattern:?}");
        assert_eq!((pattern.dashes, dashed[0].pieces.len(), dashed[0].vertices.len()), (4, 4, dashed[0].sigma_m.len()));
        let along: Vec<f64> = dashed[0].vertices.iter().map(|&v| local(&road, v)[1]).collect();
        assert!(along.windows(2).all(|w| w[1] > w[0]) || along.windows(2).all(|w| w[1] < w[0]), "{along:?}");
        assert_eq!(kinds(LineKind::Solid).len(), 1);
        assert_eq!(kinds(LineKind::StopLine).len(), 1);
        assert_eq!(kinds(LineKind::ZebraStripe).len(), 3);
        assert!(kinds(LineKind::Other).is_empty());
    }

    fn observed(points: Vec<[f64; 2]>, open: [bool; 2], panorama: usize, heading: f64) -> Observed {
        Observed { points, width_m: 0.12, sigma_m: 0.01, common_sigma_m: 0.0, open, panorama, heading }
    }

    /// Dashes along a 60 m radius with one dash missing, an arterial's two solid centre lines 0.3 m apart
    /// seen in overlapping chunks, and a lone short line.
    #[test]
    fn the_trajectorys_shared_sigma_does_not_average_out() {
        // Three panoramas see one dash, each with σ 2 cm of which 1.5 cm is the trajectory's (shared).
        let obs: Vec<Observed> = (0..3)
            .map(|k| Observed {
                sigma_m: 0.02,
                common_sigma_m: 0.015,
                ..observed(vec![[0.0, 0.0], [0.0, 3.0]], [false; 2], k, 0.0)
            })
            .collect();
        let assembly = assemble(&obs, &AssembleConfig::default());
        assert_eq!(assembly.pieces.len(), 1, "{:?}", assembly.pieces);
        // σ² = (0.02² − 0.015²) / 3 + 0.015²: only the independent part shrinks with the count.
        let want = ((0.0004 - 0.000225) / 3.0 + 0.000225_f64).sqrt();
        assert!(assembly.pieces[0].sigma_m.iter().all(|&s| (s - want).abs() < 1e-9), "{:?}", assembly.pieces[0]);
    }

    #[test]
    fn curved_dashes_chain_across_a_missing_dash_and_close_parallel_lines_stay_apart() {
        let (centre, radius) = ([0.0, 0.0], 60.0);
        let arc = |s: f64, offset: f64| {
            let phi = s / radius;
            [centre[0] + (radius + offset) * phi.cos(), centre[1] + (radius + offset) * phi.sin()]
        };
        let mut obs = Vec::new();
        for k in [0, 1, 2, 4, 5, 6] {
            let s0 = 9.0 * f64::from(k);
            for (p, offset) in [(0, 0.004), (1, -0.004), (2, 0.0)] {
                let points = (0..=6).map(|i| arc(s0 + 0.5 * f64::from(i), offset)).collect();
                obs.push(observed(points, [false; 2], 3 * k as usize + p, -(s0 / radius)));
            }
        }
        for x in [49.85, 50.15] {
            obs.push(observed(vec![[x, 0.0], [x, 10.0]], [true; 2], 100, 0.0));
            obs.push(observed(vec![[x, 8.0], [x, 20.0]], [true; 2], 101, 0.0));
        }
        obs.push(observed(vec![[80.0, 0.0], [80.0, 1.0]], [false; 2], 102, 0.0));
        let assembly = assemble(&obs, &AssembleConfig::default());
        assert_eq!(assembly.pieces.len(), 6 + 2 + 1, "{:?}", assembly.pieces);
        for piece in &assembly.pieces[..] {
            // Three observations of σ 1 cm make a vertex of σ 1/√3 cm.
            if piece.observations == 3 {
                assert!(piece.sigma_m.iter().all(|&s| (s - 0.01 / 3f64.sqrt()).abs() < 1e-9), "{piece:?}");
                let err = piece.vertices.iter().map(|&v| (dist(v, centre) - radius).abs()).fold(0.0, f64::max);
                assert!(err < 1e-3 && piece.closed == [true, true], "{piece:?}");
            }
        }
        let of = |kind: LineKind| assembly.lines.iter().filter(move |l| l.kind == kind);
        let dashed: Vec<_> = of(LineKind::Dashed).collect();
        assert_eq!(dashed.len(), 1, "{:?}", assembly.lines);
        let pattern = dashed[0].dash.unwrap();
        assert_eq!((pattern.dashes, dashed[0].panoramas), (6, 18));
        assert!((pattern.dash_m - 3.0).abs() < 0.01 && (pattern.gap_m - 6.0).abs() < 0.01, "{pattern:?}");
        let phis: Vec<f64> = dashed[0].vertices.iter().map(|v| v[1].atan2(v[0])).collect();
        assert!(phis.windows(2).all(|w| w[1] > w[0]) || phis.windows(2).all(|w| w[1] < w[0]));
        let solid: Vec<_> = of(LineKind::Solid).collect();
        assert_eq!(solid.len(), 2, "{:?}", assembly.lines);
        assert!(solid.iter().all(|l| (length(&l.vertices) - 20.0).abs() < 0.01 && l.panoramas == 2));
        assert_eq!(of(LineKind::Other).count(), 1);
        assert_eq!(assembly.lines.iter().map(|l| l.pieces.len()).sum::<usize>(), assembly.pieces.len());
        assert_eq!(LineKind::ZebraStripe.as_str(), "zebra_stripe");
        assert_eq!(assemble(&[], &AssembleConfig::default()), Assembly::default());
    }
}
