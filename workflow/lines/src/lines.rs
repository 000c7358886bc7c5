//! Classification of pieces into road lines: wide pieces across the driving direction are stop lines, wide
//! short pieces along it zebra stripes; narrow pieces with closed ends that follow each other at dash gaps
//! (laterally aligned, directions continuing) are chained into dashed lines with their dash pattern; long
//! narrow pieces outside a chain are solid lines; everything else is other paint.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::geometry::{cross, dot, length, line_angle, median_or_zero, norm, sub, unit};
use crate::piece::{AssembleConfig, Piece};

/// What a road line is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LineKind {
    /// A continuous lane, centre or edge line.
    Solid,
    /// A chain of dashes.
    Dashed,
    /// A wide line across the driving direction.
    StopLine,
    /// One stripe of a zebra crossing.
    ZebraStripe,
    /// Any other paint (arrows' parts, short lines, lone dashes).
    Other,
}

impl LineKind {
    /// Every kind, in the order tables list them.
    pub const ALL: [Self; 5] = [Self::Solid, Self::Dashed, Self::StopLine, Self::ZebraStripe, Self::Other];

    /// The snake_case name, as serialised.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::Solid => "solid",
            Self::Dashed => "dashed",
            Self::StopLine => "stop_line",
            Self::ZebraStripe => "zebra_stripe",
            Self::Other => "other",
        }
    }
}

/// The rhythm of a dashed line.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct DashPattern {
    /// Median dash length over the dashes seen with both ends closed (all dashes when none), metres.
    pub dash_m: f64,
    /// Median gap between consecutive dashes, metres.
    pub gap_m: f64,
    /// Number of dashes in the chain.
    pub dashes: usize,
}

/// A road line built from one or more pieces.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RoadLine {
    /// What it is.
    pub kind: LineKind,
    /// Its pieces' vertices in order along the line (for a dashed line: the chain of dashes), metres.
    pub vertices: Vec<[f64; 2]>,
    /// 1σ across the line of each vertex, metres.
    pub sigma_m: Vec<f64>,
    /// Median painted width of its pieces, metres.
    pub width_m: f64,
    /// The dash pattern of a dashed line.
    pub dash: Option<DashPattern>,
    /// Indices into `Assembly::pieces`, in order along the line.
    pub pieces: Vec<usize>,
    /// Number of distinct panoramas that saw any of its pieces.
    pub panoramas: usize,
}

/// What classification needs beyond a piece: its driving direction and the panoramas that saw it.
#[derive(Clone, Debug)]
pub(crate) struct PieceInfo {
    /// Driving direction (modulo π), radians clockwise from grid north.
    pub(crate) heading: f64,
    /// Distinct panorama indices, sorted.
    pub(crate) panoramas: Vec<usize>,
}

/// One end of a piece: its index, which end, the end point and the unit direction pointing out of the piece.
#[derive(Clone, Copy, Debug)]
struct End {
    piece: usize,
    end: usize,
    at: [f64; 2],
    out: [f64; 2],
}

fn end_of(piece: &Piece, index: usize, end: usize) -> Option<End> {
    let v = &piece.vertices;
    let (at, inner) = if end == 0 { (*v.first()?, *v.get(1)?) } else { (*v.last()?, v[v.len().checked_sub(2)?]) };
    Some(End { piece: index, end, at, out: unit(sub(at, inner))? })
}

/// Whether end `b` continues a dashed line leaving end `a`: the gap in range, both end directions within the
/// angle of the chord, and the lateral offset across the mean direction small (exact for circular arcs).
/// Returns the gap.
fn continues(a: &End, b: &End, config: &AssembleConfig) -> Option<f64> {
    let chord = sub(b.at, a.at);
    let gap = norm(chord);
    let c = unit(chord)?;
    let into = [-b.out[0], -b.out[1]];
    let cos_max = config.dash_angle_deg.to_radians().cos();
    let in_range = (config.gap_min_m..=config.gap_max_m).contains(&gap);
    let mean = unit([a.out[0] + into[0], a.out[1] + into[1]])?;
    (in_range
        && dot(a.out, c) >= cos_max
        && dot(into, c) >= cos_max
        && cross(mean, chord).abs() <= config.dash_offset_m)
        .then_some(gap)
}

/// Classify the pieces; every piece ends up in exactly one line.
pub(crate) fn classify(pieces: &[Piece], info: &[PieceInfo], config: &AssembleConfig) -> Vec<RoadLine> {
    let lengths: Vec<f64> = pieces.iter().map(|p| length(&p.vertices)).collect();
    let candidate = |i: usize| {
        let p = &pieces[i];
        p.width_m < config.wide_m && lengths[i] <= config.dash_max_m && (p.closed[0] || p.closed[1])
    };
    let ends: Vec<End> = (0..pieces.len())
        .filter(|&i| candidate(i))
        .flat_map(|i| (0..2).filter_map(move |e| pieces[i].closed[e].then(|| end_of(&pieces[i], i, e)).flatten()))
        .collect();
    // Each end's nearest continuation; links are kept when mutual.
    let best: Vec<Option<(usize, f64)>> = ends
        .iter()
        .map(|a| {
            ends.iter()
                .enumerate()
                .filter(|(_, b)| b.piece != a.piece)
                .filter_map(|(k, b)| continues(a, b, config).map(|g| (k, g)))
                .min_by(|x, y| x.1.total_cmp(&y.1))
        })
        .collect();
    // link[piece][end] = (other piece, its end, gap)
    let mut link: Vec<[Option<(usize, usize, f64)>; 2]> = vec![[None, None]; pieces.len()];
    for (k, b) in best.iter().enumerate() {
        if let Some((j, gap)) = *b
            && best[j].map(|(back, _)| back) == Some(k)
        {
            link[ends[k].piece][ends[k].end] = Some((ends[j].piece, ends[j].end, gap));
        }
    }
    let mut used = vec![false; pieces.len()];
    let mut lines = Vec::new();
    // Chains start at a dash with at most one link; cycles (none on real roads) are cut anywhere.
    let starts = (0..pieces.len()).filter(|&i| link[i][0].is_none() || link[i][1].is_none()).chain(0..pieces.len());
    for i in starts.collect::<Vec<_>>() {
        if used[i] || !(link[i][0].is_some() || link[i][1].is_some()) {
            continue;
        }
        // Enter through the unlinked end (or end 0), leave through the other.
        let mut entered = if link[i][0].is_none() { 0 } else { 1 };
        let (mut chain, mut gaps, mut cur) = (Vec::new(), Vec::new(), i);
        loop {
            used[cur] = true;
            chain.push((cur, entered == 1));
            match link[cur][1 - entered] {
                Some((next, next_end, gap)) if !used[next] => {
                    gaps.push(gap);
                    (cur, entered) = (next, next_end);
                }
                _ => break,
            }
        }
        lines.push(dashed(pieces, info, &lengths, &chain, &mut gaps));
    }
    for (i, p) in pieces.iter().enumerate() {
        if used[i] {
            continue;
        }
        let dir = unit(sub(p.vertices[p.vertices.len() - 1], p.vertices[0])).unwrap_or([0.0, 1.0]);
        let heading = [info[i].heading.sin(), info[i].heading.cos()];
        let across = line_angle(dir, heading) > config.across_deg.to_radians();
        let kind = match (p.width_m >= config.wide_m, across) {
            (true, true) => LineKind::StopLine,
            (true, false) if lengths[i] <= config.zebra_max_m => LineKind::ZebraStripe,
            (false, _) if lengths[i] > config.solid_min_m => LineKind::Solid,
            _ => LineKind::Other,
        };
        lines.push(RoadLine {
            kind,
            vertices: p.vertices.clone(),
            sigma_m: p.sigma_m.clone(),
            width_m: p.width_m,
            dash: None,
            pieces: vec![i],
            panoramas: info[i].panoramas.len(),
        });
    }
    lines
}

/// A dashed line from a chain of (piece, reversed) in order.
fn dashed(
    pieces: &[Piece],
    info: &[PieceInfo],
    lengths: &[f64],
    chain: &[(usize, bool)],
    gaps: &mut [f64],
) -> RoadLine {
    let (mut vertices, mut sigma_m, mut panoramas) = (Vec::new(), Vec::new(), Vec::<usize>::new());
    for &(i, reversed) in chain {
        let p = &pieces[i];
        if reversed {
            vertices.extend(p.vertices.iter().rev());
            sigma_m.extend(p.sigma_m.iter().rev());
        } else {
            vertices.extend(&p.vertices);
            sigma_m.extend(&p.sigma_m);
        }
        panoramas.extend(&info[i].panoramas);
    }
    panoramas.sort_unstable();
    panoramas.dedup();
    let mut whole: Vec<f64> =
        chain.iter().filter(|(i, _)| pieces[*i].closed == [true, true]).map(|(i, _)| lengths[*i]).collect();
    if whole.is_empty() {
        whole = chain.iter().map(|(i, _)| lengths[*i]).collect();
    }
    let mut widths: Vec<f64> = chain.iter().map(|(i, _)| pieces[*i].width_m).collect();
    let dash = DashPattern { dash_m: median_or_zero(&mut whole), gap_m: median_or_zero(gaps), dashes: chain.len() };
    RoadLine {
        kind: LineKind::Dashed,
        vertices,
        sigma_m,
        width_m: median_or_zero(&mut widths),
        dash: Some(dash),
        pieces: chain.iter().map(|(i, _)| *i).collect(),
        panoramas: panoramas.len(),
    }
}
