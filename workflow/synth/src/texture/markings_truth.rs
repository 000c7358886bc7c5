//! The true geometry of the road paint at the mobile epoch (what the panoramas see), as polylines in map
//! coordinates: one element per dash, continuous solid line, stop line, zebra stripe and arrow shaft, each its
//! painted centre line with the paint's width.
//!
//! The elements are laid out from the same definitions the texture paints from (`texture::markings`), mapped
//! from street coordinates (station s, offset t) to the map the way the place lookup the texture paints by
//! (`world::place`) inverts it: a point belongs to the nearest segment of its street's polyline, so a line at
//! constant t is the polyline offset by t — trimmed where two offset segments cross on the inside of a bend,
//! joined by an arc around the vertex on the outside. Elements are then clipped to where the texture actually
//! paints them as part of their own street (not inside a junction area, not where another street's carriageway
//! takes over at an acute junction). Paint is never missing at the mobile epoch (at worst half worn), so every
//! element exists.

use std::fmt::Write as _;

use super::markings::{
    ARROW_HEAD, ARROW_SHAFT, ARROW_TAIL, ARROW_TIP, CLEAR, DASH_LEN, DASH_PERIOD, LINE, STOP_END, ZEBRA_END, ZEBRA_LEN,
    ZEBRA_PERIOD, ZEBRA_START, each_line, has_zebra,
};
use crate::world::polyline::{self, P2};
use crate::world::{Street, StreetClass, World};

/// Shortest element kept, metres: a dash cut to less by the clear zone is not worth a line.
const MIN_LEN: f64 = 1e-3;
/// Narrowest zebra stripe kept where the carriageway's edge cuts one, metres: a sliver of paint below any
/// sensor's resolution is no stripe.
const MIN_WIDTH: f64 = 0.02;
/// Spacing of the samples that find where an element leaves its street's paint, metres.
const CLIP_STEP: f64 = 0.05;
/// Largest distance of an arc's chord from the arc around an outer bend, metres.
const ARC_TOLERANCE: f64 = 5e-4;

/// What a painted element is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MarkingKind {
    /// A continuous section of a solid line (arterial centre lines, parking edge lines).
    Solid,
    /// One dash of a dashed line (centre lines of two-lane streets, lane lines).
    Dashed,
    /// A stop line across the approaching half of the carriageway; its centre line runs across the street.
    StopLine,
    /// One stripe of a zebra crossing; its centre line runs along the street, over the stripe's 3 m.
    ZebraStripe,
    /// A straight-ahead arrow: the centre line of its shaft, from the tail toward the head.
    Arrow,
}

impl MarkingKind {
    /// The kind's snake_case name (`solid`, `dashed`, `stop_line`, `zebra_stripe`, `arrow`).
    pub fn as_str(self) -> &'static str {
        match self {
            MarkingKind::Solid => "solid",
            MarkingKind::Dashed => "dashed",
            MarkingKind::StopLine => "stop_line",
            MarkingKind::ZebraStripe => "zebra_stripe",
            MarkingKind::Arrow => "arrow",
        }
    }
}

/// One painted element: its centre line in map coordinates (the world's CRS) and the paint's width across it.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkingTruth {
    /// Stable identity: `s{street key}.l{line}` (solid), `….l{line}.d{dash}` (dashed), `s{key}.{from|to}.stop`,
    /// `….zebra{k}`, `….arrow{lane}`; `.p{n}` appended when the element is cut into pieces.
    pub id: String,
    /// What it is.
    pub kind: MarkingKind,
    /// Its centre line, easting/northing, metres.
    pub points: Vec<P2>,
    /// Width of the paint across the centre line, metres.
    pub width_m: f64,
}

impl MarkingTruth {
    /// Length of the centre line, metres.
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| polyline::dist(w[0], w[1])).sum()
    }
}

/// Every painted element of the world's streets at the mobile epoch, street by street (none on streets
/// without markings).
pub fn road_markings(world: &World) -> Vec<MarkingTruth> {
    road_markings_where(world, |_| true)
}

/// [`road_markings`] of the streets `keep` accepts.
pub fn road_markings_where(world: &World, keep: impl Fn(&Street) -> bool) -> Vec<MarkingTruth> {
    let mut out = Vec::new();
    for st in world.streets.iter().filter(|s| s.markings && keep(s)) {
        let own = |p: P2| world.place(p).is_some_and(|pl| pl.street.id == st.id && !pl.in_junction);
        for e in street_elements(world, st) {
            let pieces = clip(&e.points, own);
            let n = pieces.len();
            for (k, points) in pieces.into_iter().enumerate() {
                let id = if n == 1 { e.id.clone() } else { format!("{}.p{k}", e.id) };
                out.push(MarkingTruth { id, kind: e.kind, points, width_m: e.width_m });
            }
        }
    }
    out
}

/// The elements as CSV `id,kind,width_m,wkt`: the WKT `LINESTRING (e n, e n, …)` in the world's CRS with
/// millimetre coordinates, quoted (it holds commas); ids never hold commas or quotes.
pub fn markings_csv(markings: &[MarkingTruth]) -> Vec<u8> {
    let mut s = String::from("id,kind,width_m,wkt\n");
    for m in markings {
        let _ = write!(s, "{},{},{:.3},\"LINESTRING (", m.id, m.kind.as_str(), m.width_m);
        for (k, p) in m.points.iter().enumerate() {
            let sep = if k == 0 { "" } else { ", " };
            let _ = write!(s, "{sep}{:.3} {:.3}", p[0], p[1]);
        }
        s.push_str(")\"\n");
    }
    s.into_bytes()
}

/// The street's elements before clipping to where its paint shows.
fn street_elements(world: &World, st: &Street) -> Vec<MarkingTruth> {
    let r0 = world.junctions[st.from as usize].radius;
    let r1 = world.junctions[st.to as usize].radius;
    let len = st.length();
    let key = st.key;
    let mut out = Vec::new();
    let mut push = |id: String, kind: MarkingKind, points: Vec<P2>, width_m: f64| {
        if points.len() >= 2 {
            out.push(MarkingTruth { id, kind, points, width_m });
        }
    };
    // Lines where both ends are at least CLEAR away.
    let (lo, hi) = (r0 + CLEAR, len - r1 - CLEAR);
    if hi - lo > MIN_LEN {
        let mut line = 0;
        each_line(st, |t, dashed| {
            if dashed {
                let first = (lo / DASH_PERIOD).floor() as i64;
                let last = (hi / DASH_PERIOD).floor() as i64;
                for k in first..=last {
                    let start = k as f64 * DASH_PERIOD;
                    let (a, b) = (start.max(lo), (start + DASH_LEN).min(hi));
                    if b - a > MIN_LEN {
                        let id = format!("s{key}.l{line}.d{k}");
                        push(id, MarkingKind::Dashed, offset_path(st, t, a, b), 2.0 * LINE);
                    }
                }
            } else {
                push(format!("s{key}.l{line}"), MarkingKind::Solid, offset_path(st, t, lo, hi), 2.0 * LINE);
            }
            line += 1;
        });
    }
    // Near each end: the paint of the end nearer than the other, within (end < CLEAR) or beyond the clear zone.
    let mid = (len + r0 - r1) / 2.0;
    let half = st.carriageway() / 2.0;
    for near_from in [true, false] {
        let name = if near_from { "from" } else { "to" };
        // Station of a distance `end` from this end's junction area, and the stations of an `end` range kept to
        // this end's half of the street.
        let station = |end: f64| if near_from { r0 + end } else { len - r1 - end };
        let range = |a: f64, b: f64| {
            let (sa, sb) = (station(a), station(b));
            let (sa, sb) = (sa.min(sb), sa.max(sb));
            if near_from { (sa, sb.min(mid)) } else { (sa.max(mid), sb) }
        };
        // The direction away from the junction (end increasing) is increasing s at the `from` end.
        let outward = |mut points: Vec<P2>| {
            if !near_from {
                points.reverse();
            }
            points
        };
        if has_zebra(st, near_from) {
            let (a, b) = range(ZEBRA_END.0, ZEBRA_END.1.min(CLEAR));
            let count = (2.0 * half / ZEBRA_PERIOD).ceil() as i64;
            for k in 0..=count {
                let t0 = -half + k as f64 * ZEBRA_PERIOD + ZEBRA_START;
                let (t0, t1) = (t0.max(-half), (t0 + ZEBRA_LEN).min(half));
                if t1 - t0 >= MIN_WIDTH && b - a > MIN_LEN {
                    let points = outward(offset_path(st, (t0 + t1) / 2.0, a, b));
                    push(format!("s{key}.{name}.zebra{k}"), MarkingKind::ZebraStripe, points, t1 - t0);
                }
            }
        }
        let (a, b) = range(STOP_END.0, STOP_END.1.min(CLEAR));
        if b - a > MIN_LEN {
            // Across the approaching half, from the centre line to the kerb.
            let side = if near_from { half } else { -half };
            push(format!("s{key}.{name}.stop"), MarkingKind::StopLine, across(st, (a + b) / 2.0, 0.0, side), b - a);
        }
        if st.class == StreetClass::Arterial {
            let (a, b) = range((ARROW_TIP + ARROW_HEAD).max(CLEAR), ARROW_TIP + ARROW_TAIL);
            for lane in 0..st.lanes {
                let t = (f64::from(lane) + 0.5) * st.lane_width;
                let t = if near_from { t } else { -t };
                if b - a > MIN_LEN {
                    // From the tail toward the head, i.e. toward the junction.
                    let mut points = outward(offset_path(st, t, a, b));
                    points.reverse();
                    push(format!("s{key}.{name}.arrow{lane}"), MarkingKind::Arrow, points, 2.0 * ARROW_SHAFT);
                }
            }
        }
    }
    out
}

/// Unit left normal of a unit tangent.
fn normal(tan: P2) -> P2 {
    [-tan[1], tan[0]]
}

/// The straight line across the street at station `s` from offset `t0` to `t1`.
fn across(st: &Street, s: f64, t0: f64, t1: f64) -> Vec<P2> {
    let (p, tan) = polyline::point_at(&st.points, &st.cum, s);
    let n = normal(tan);
    vec![[p[0] + t0 * n[0], p[1] + t0 * n[1]], [p[0] + t1 * n[0], p[1] + t1 * n[1]]]
}

/// The points at offset `t` of stations `a` ≤ s ≤ `b`, as the texture's nearest-segment lookup sees them: each
/// segment offset by `t`, trimmed where it meets its neighbour's offset on the inside of a bend; on the
/// outside, the arc around the vertex (all at the vertex's station).
fn offset_path(st: &Street, t: f64, a: f64, b: f64) -> Vec<P2> {
    let (pts, cum) = (&st.points, &st.cum);
    let segs = pts.len().saturating_sub(1);
    let tangent = |i: usize| {
        let len = (cum[i + 1] - cum[i]).max(1e-12);
        [(pts[i + 1][0] - pts[i][0]) / len, (pts[i + 1][1] - pts[i][1]) / len]
    };
    // Turn at interior vertex v (between segments v − 1 and v): signed angle, positive to the left.
    let turn = |v: usize| {
        let (u0, u1) = (tangent(v - 1), tangent(v));
        (u0[0] * u1[1] - u0[1] * u1[0]).atan2(u0[0] * u1[0] + u0[1] * u1[1])
    };
    // How far each segment's offset is cut back at an inner bend.
    let trim = |v: usize| {
        let th = turn(v);
        if th * t > 0.0 { t.abs() * (th.abs() / 2.0).tan() } else { 0.0 }
    };
    let mut out: Vec<P2> = Vec::new();
    let add = |p: P2, out: &mut Vec<P2>| {
        if out.last().is_none_or(|q| polyline::dist(*q, p) > 1e-9) {
            out.push(p);
        }
    };
    for i in 0..segs {
        let (u, n) = (tangent(i), normal(tangent(i)));
        if i > 0 && (a..=b).contains(&cum[i]) {
            // The arc around an outer bend.
            let th = turn(i);
            if th * t < 0.0 {
                let n0 = normal(tangent(i - 1));
                let start = n0[1].atan2(n0[0]);
                let step = 2.0 * (1.0 - ARC_TOLERANCE / t.abs()).max(0.0).acos();
                let m = ((th.abs() / step.max(1e-6)).ceil() as usize).max(1);
                for k in 0..=m {
                    let ang = start + th * k as f64 / m as f64;
                    add(
                        [pts[i][0] + t.abs() * ang.cos() * t.signum(), pts[i][1] + t.abs() * ang.sin() * t.signum()],
                        &mut out,
                    );
                }
            }
        }
        let lo = cum[i] + if i > 0 { trim(i) } else { 0.0 };
        let hi = cum[i + 1] - if i + 1 < segs { trim(i + 1) } else { 0.0 };
        let (lo, hi) = (lo.max(a), hi.min(b));
        if lo <= hi {
            for s in [lo, hi] {
                let f = s - cum[i];
                add([pts[i][0] + f * u[0] + t * n[0], pts[i][1] + f * u[1] + t * n[1]], &mut out);
            }
        }
    }
    out
}

/// The runs of a polyline where `inside` holds, their ends found to a fraction of a millimetre.
fn clip(points: &[P2], inside: impl Fn(P2) -> bool) -> Vec<Vec<P2>> {
    let lerp = |p: P2, q: P2, f: f64| [p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1])];
    let mut pieces = Vec::new();
    let Some(&first) = points.first() else { return pieces };
    let (mut prev, mut prev_in) = (first, inside(first));
    let mut cur: Vec<P2> = if prev_in { vec![first] } else { Vec::new() };
    for w in points.windows(2) {
        let n = ((polyline::dist(w[0], w[1]) / CLIP_STEP).ceil() as usize).max(1);
        for k in 1..=n {
            let q = lerp(w[0], w[1], k as f64 / n as f64);
            let q_in = inside(q);
            if q_in != prev_in {
                let (mut lo, mut hi) = (prev, q);
                for _ in 0..20 {
                    let m = lerp(lo, hi, 0.5);
                    if inside(m) == prev_in {
                        lo = m;
                    } else {
                        hi = m;
                    }
                }
                if prev_in {
                    cur.push(lo);
                    pieces.push(std::mem::take(&mut cur));
                } else {
                    cur.push(hi);
                }
            }
            if k == n && q_in {
                cur.push(q);
            }
            (prev, prev_in) = (q, q_in);
        }
    }
    if !cur.is_empty() {
        pieces.push(cur);
    }
    pieces.retain(|p| p.len() >= 2 && p.windows(2).map(|w| polyline::dist(w[0], w[1])).sum::<f64>() > MIN_LEN);
    pieces
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::super::Texture;
    use super::super::markings::paint;
    use super::*;
    use crate::world::{Epoch, Preset, WorldConfig};

    /// Footprint of the coverage samples, metres.
    const FP: f64 = 0.01;

    fn world(seed: u64) -> World {
        World::generate(&WorldConfig::new(Preset::Tiny, seed)).unwrap()
    }

    /// Tiny worlds of seeds 0–3 and the district of seed 0, with their names.
    fn worlds() -> impl Iterator<Item = (String, World)> {
        let district = World::generate(&WorldConfig::new(Preset::District, 0)).unwrap();
        (0..4).map(|s| (format!("tiny {s}"), world(s))).chain(std::iter::once(("district 0".to_owned(), district)))
    }

    /// Paint coverage at the mobile epoch (0 off the carriageways).
    fn coverage(tex: &Texture, p: P2) -> f32 {
        let Some(place) = tex.world.place(p) else { return 0.0 };
        if place.station.t.abs() > place.street.carriageway() / 2.0 {
            return 0.0;
        }
        paint(&place, Epoch::Mobile, tex.world.config.seed, FP).0
    }

    fn segment_dist(p: P2, a: P2, b: P2) -> f64 {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let l2 = (dx * dx + dy * dy).max(1e-24);
        let f = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0);
        polyline::dist(p, [a[0] + f * dx, a[1] + f * dy])
    }

    /// The elements with their bounding boxes, for distance queries.
    struct Elements<'a> {
        all: &'a [MarkingTruth],
        boxes: Vec<(P2, P2)>,
    }

    impl<'a> Elements<'a> {
        fn new(all: &'a [MarkingTruth]) -> Self {
            let boxes = all
                .iter()
                .map(|m| {
                    m.points.iter().fold(([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]), |(lo, hi), p| {
                        ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
                    })
                })
                .collect();
            Self { all, boxes }
        }

        /// (index, distance from the centre line) of the elements whose box is within `margin` of `p`.
        fn near(&self, p: P2, margin: f64) -> impl Iterator<Item = (usize, f64)> + '_ {
            self.boxes.iter().enumerate().filter_map(move |(i, (lo, hi))| {
                let inside =
                    p[0] > lo[0] - margin && p[0] < hi[0] + margin && p[1] > lo[1] - margin && p[1] < hi[1] + margin;
                inside.then(|| {
                    let pts = &self.all[i].points;
                    (i, pts.windows(2).map(|w| segment_dist(p, w[0], w[1])).fold(f64::INFINITY, f64::min))
                })
            })
        }
    }

    /// Points every ≤ 0.1 m along an element's centre line, at least 2 cm from its ends, with the unit
    /// normal there.
    fn samples(m: &MarkingTruth) -> Vec<(P2, P2)> {
        let len = m.length();
        let mut out = Vec::new();
        let n = ((len / 0.1).ceil() as usize).max(4);
        for k in 0..=n {
            let target = 0.02 + (len - 0.04) * k as f64 / n as f64;
            let mut acc = 0.0;
            for w in m.points.windows(2) {
                let l = polyline::dist(w[0], w[1]);
                if acc + l >= target && l > 0.0 {
                    let f = (target - acc) / l;
                    let u = [(w[1][0] - w[0][0]) / l, (w[1][1] - w[0][1]) / l];
                    out.push(([w[0][0] + f * (w[1][0] - w[0][0]), w[0][1] + f * (w[1][1] - w[0][1])], normal(u)));
                    break;
                }
                acc += l;
            }
        }
        out
    }

    fn street_of<'w>(w: &'w World, m: &MarkingTruth) -> &'w Street {
        let key: u32 = m.id[1..].split('.').next().unwrap().parse().unwrap();
        w.streets.iter().find(|s| s.key == key).unwrap()
    }

    #[test]
    fn every_kind_on_marked_streets_only() {
        for seed in 0..4 {
            let w = world(seed);
            let all = road_markings(&w);
            for st in &w.streets {
                let n = all.iter().filter(|m| std::ptr::eq(street_of(&w, m), st)).count();
                assert_eq!(n > 0, st.markings, "street {} ({:?}, markings {}): {n}", st.id, st.class, st.markings);
            }
            let ids: std::collections::HashSet<&str> = all.iter().map(|m| m.id.as_str()).collect();
            assert_eq!(ids.len(), all.len(), "ids are unique");
            for kind in [MarkingKind::Solid, MarkingKind::Dashed, MarkingKind::StopLine, MarkingKind::Arrow] {
                assert!(all.iter().any(|m| m.kind == kind), "seed {seed}: no {}", kind.as_str());
            }
            assert!(all.iter().all(|m| m.points.len() >= 2 && m.length() > MIN_LEN));
        }
        let zebras =
            (0..4).map(|s| road_markings(&world(s))).filter(|a| a.iter().any(|m| m.kind == MarkingKind::ZebraStripe));
        assert!(zebras.count() > 0);
    }

    /// Along every element's centre line the renderer paints (coverage ≥ 0.9); 0.25 m beside a lane line,
    /// away from any other element, it does not (≤ 0.1).
    #[test]
    fn centre_lines_are_painted_and_their_sides_are_not() {
        let mut curved = 0;
        for (name, w) in worlds() {
            let tex = Texture::new(&w, Epoch::Mobile);
            let all = road_markings(&w);
            let idx = Elements::new(&all);
            let (mut bad, mut total, mut sides) = (Vec::new(), 0, 0);
            for (i, m) in all.iter().enumerate() {
                let on_curve = street_of(&w, m).points.len() > 2;
                for (p, n) in samples(m) {
                    total += 1;
                    curved += usize::from(on_curve);
                    let c = coverage(&tex, p);
                    if c < 0.9 {
                        bad.push(format!("{} at {p:?}: {c}", m.id));
                    }
                    if matches!(m.kind, MarkingKind::Solid | MarkingKind::Dashed) {
                        for side in [-0.25, 0.25] {
                            let q = [p[0] + side * n[0], p[1] + side * n[1]];
                            let clear = idx.near(q, 1.0).all(|(j, d)| j == i || d > all[j].width_m / 2.0 + 0.1);
                            if clear {
                                sides += 1;
                                let c = coverage(&tex, q);
                                if c > 0.1 {
                                    bad.push(format!("beside {} at {q:?}: {c}", m.id));
                                }
                            }
                        }
                    }
                }
            }
            assert!(bad.is_empty(), "{name}: {} of {total} samples wrong: {:?}", bad.len(), &bad[..bad.len().min(20)]);
            assert!(sides > total / 2, "{name}: {sides} side samples of {total}");
        }
        assert!(curved > 1000, "curved streets sampled: {curved}");
    }

    /// Painted carriageway points lie on some element (within its half width and 2 cm); arrow heads, wider than
    /// the shafts the elements describe, are left out.
    #[test]
    fn painted_points_lie_on_an_element() {
        for (name, w) in worlds() {
            let tex = Texture::new(&w, Epoch::Mobile);
            let all = road_markings(&w);
            let idx = Elements::new(&all);
            let marked: Vec<&Street> = w.streets.iter().filter(|s| s.markings).collect();
            let mut rng = ChaCha8Rng::seed_from_u64(w.config.seed);
            let (mut painted, mut off) = (0usize, Vec::new());
            for _ in 0..60_000 {
                let st = marked[rng.random_range(0..marked.len())];
                let half = st.carriageway() / 2.0;
                let (s, t) = (rng.random_range(0.0..st.length()), rng.random_range(-half..half));
                let (p, tan) = polyline::point_at(&st.points, &st.cum, s);
                let p = [p[0] - tan[1] * t, p[1] + tan[0] * t];
                if coverage(&tex, p) <= 0.5 {
                    continue;
                }
                let near: Vec<(usize, f64)> = idx.near(p, 2.0).collect();
                if near.iter().any(|&(j, d)| all[j].kind == MarkingKind::Arrow && d < 2.0) {
                    continue;
                }
                painted += 1;
                if !near.iter().any(|&(j, d)| d <= all[j].width_m / 2.0 + 0.02) {
                    off.push(p);
                }
            }
            assert!(painted > 1000, "{name}: {painted} painted samples");
            let share = off.len() as f64 / painted as f64;
            assert!(
                share < 0.01,
                "{name}: {} of {painted} painted points off every element: {:?}",
                off.len(),
                &off[..off.len().min(10)]
            );
        }
    }

    /// Dashes are 3 m with 6 m gaps, starting at multiples of 9 m along the street; only the first and last
    /// dash of a line are cut short (by the clear zone before the junction).
    #[test]
    fn dashes_are_three_metres_with_six_metre_gaps() {
        let mut full = 0;
        for (_, w) in worlds() {
            let all = road_markings(&w);
            let mut lines: std::collections::BTreeMap<String, Vec<(i64, f64, f64, f64)>> = Default::default();
            for m in all.iter().filter(|m| m.kind == MarkingKind::Dashed) {
                let st = street_of(&w, m);
                let (line, dash) = m.id.rsplit_once(".d").unwrap();
                assert!(!dash.contains('.'), "{}: a dash cut into pieces", m.id);
                let ends =
                    [m.points[0], m.points[m.points.len() - 1]].map(|p| polyline::nearest(&st.points, &st.cum, p).s);
                let (a, b) = (ends[0].min(ends[1]), ends[0].max(ends[1]));
                lines.entry(line.to_owned()).or_default().push((dash.parse().unwrap(), a, b, m.length()));
            }
            for (line, mut dashes) in lines {
                dashes.sort_by_key(|d| d.0);
                let n = dashes.len();
                for (k, &(dash, a, b, len)) in dashes.iter().enumerate() {
                    assert!(b - a <= DASH_LEN + 1e-6, "{line}.d{dash}: {}", b - a);
                    if k > 0 && k + 1 < n {
                        full += 1;
                        assert!((b - a - DASH_LEN).abs() < 1e-6, "{line}.d{dash}: {} m", b - a);
                        assert!((len - DASH_LEN).abs() < 1e-3, "{line}.d{dash}: centre line {len} m");
                        assert!((a - dash as f64 * DASH_PERIOD).abs() < 1e-6, "{line}.d{dash} starts at {a}");
                    }
                    if k > 0 {
                        let (prev, _, prev_b, _) = dashes[k - 1];
                        assert_eq!(prev + 1, dash, "{line}: a dash missing");
                        if k + 1 < n {
                            let gap = a - prev_b;
                            assert!((gap - (DASH_PERIOD - DASH_LEN)).abs() < 1e-6, "{line}.d{dash}: gap {gap}");
                        }
                    }
                }
            }
        }
        assert!(full > 100, "{full} full dashes");
    }

    /// A line at constant offset around a 60° bend: trimmed where the offsets cross inside, an arc outside;
    /// every point lies at that offset from the polyline, at a station within the requested range.
    #[test]
    fn offset_lines_follow_the_nearest_segment() {
        let (c, si) = (60f64.to_radians().cos(), 60f64.to_radians().sin());
        let points = vec![[0.0, 0.0], [10.0, 0.0], [10.0 + 10.0 * c, 10.0 * si]];
        let cum = polyline::cumulative(&points);
        let st = Street { points, cum, ..world(0).streets[0].clone() };
        for t in [2.0, -2.0] {
            let path = offset_path(&st, t, 3.0, 17.0);
            for p in &path {
                let station = polyline::nearest(&st.points, &st.cum, *p);
                assert!((station.t - t).abs() < 1e-9 && (3.0 - 1e-9..=17.0 + 1e-9).contains(&station.s), "{t}: {p:?}");
            }
            let dense: Vec<P2> = path
                .windows(2)
                .flat_map(|w| {
                    (0..10).map(move |k| {
                        let f = f64::from(k) / 10.0;
                        [w[0][0] + f * (w[1][0] - w[0][0]), w[0][1] + f * (w[1][1] - w[0][1])]
                    })
                })
                .collect();
            let worst =
                dense.iter().map(|p| (polyline::nearest(&st.points, &st.cum, *p).t - t).abs()).fold(0.0, f64::max);
            assert!(worst <= ARC_TOLERANCE + 1e-9, "{t}: chord error {worst}");
            // Inside the bend, the two offset segments meet where they cross; outside, the arc adds vertices.
            if t > 0.0 {
                assert_eq!(path.len(), 3);
                assert!(polyline::dist(path[1], [10.0 - trim_of(t), t]) < 1e-9, "{:?}", path[1]);
            } else {
                assert!(path.len() > 4, "{}", path.len());
                let arc = path.iter().filter(|p| (polyline::dist(**p, [10.0, 0.0]) - 2.0).abs() < 1e-9).count();
                assert_eq!(arc, path.len() - 2);
            }
        }
        // A range inside the stations the inner side skips has no points.
        assert!(offset_path(&st, 2.0, 10.0 - trim_of(2.0) / 2.0, 10.0 + trim_of(2.0) / 2.0).len() < 2);
    }

    /// How far the offset segments are cut back inside the 60° bend.
    fn trim_of(t: f64) -> f64 {
        t * 30f64.to_radians().tan()
    }

    #[test]
    fn csv_round_trips() {
        let w = world(1);
        let all = road_markings(&w);
        let csv = String::from_utf8(markings_csv(&all)).unwrap();
        let mut rows = csv.lines();
        assert_eq!(rows.next(), Some("id,kind,width_m,wkt"));
        let rows: Vec<&str> = rows.collect();
        assert_eq!(rows.len(), all.len());
        for (row, m) in rows.iter().zip(&all) {
            let f: Vec<&str> = row.splitn(4, ',').collect();
            assert_eq!((f[0], f[1]), (m.id.as_str(), m.kind.as_str()));
            assert!((f[2].parse::<f64>().unwrap() - m.width_m).abs() <= 5e-4);
            let wkt = f[3].trim_matches('"');
            let body = wkt.strip_prefix("LINESTRING (").and_then(|b| b.strip_suffix(')')).unwrap();
            let points: Vec<P2> = body
                .split(", ")
                .map(|v| {
                    let (e, n) = v.split_once(' ').unwrap();
                    [e.parse().unwrap(), n.parse().unwrap()]
                })
                .collect();
            assert_eq!(points.len(), m.points.len(), "{}", m.id);
            for (p, q) in points.iter().zip(&m.points) {
                assert!((p[0] - q[0]).abs() <= 5.01e-4 && (p[1] - q[1]).abs() <= 5.01e-4, "{}: {p:?} {q:?}", m.id);
            }
        }
    }
}
