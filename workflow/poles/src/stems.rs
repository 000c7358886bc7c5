//! Vertical stems — poles and tree trunks — in a static point cloud: the product an agency asks of a
//! mobile-laser-scanning delivery (a pole or tree inventory), with no trajectory, GPS time or scanner
//! position needed. The detector of [`mod@crate::detect`] works in one scan's polar view; this one works on a
//! merged cloud in map coordinates.
//!
//! Three passes over the points, each fed in batches so that a file is streamed, never held:
//! 1. [`StemDetector::ground`]: the ground as the third-lowest height of every 1 m cell (a few stray low
//!    points do not pull it down), or a lower cell's within 3 m where the cell saw none (a parked car hid it);
//! 2. [`StemDetector::collect`]: the points of the breast-height band (1.2–1.4 m above that ground, the
//!    forester's 1.3 m) are kept; at the pass's end they are linked into clusters (points within `link_m`
//!    of each other) and a circle is fitted to each (algebraic fit, then Gauss–Newton on the geometric
//!    distances, refitted without the points beyond 3 robust σ — twigs, branch stubs), keeping those of a
//!    plausible diameter, a small residual and an arc of at least `min_arc_deg` (a facade or a car's side
//!    is a long line: no circle fits it): the candidates;
//!    Clusters too thin for a circle — a sign post of 6–8 cm crossed by one or two profiles of a moving
//!    scanner shows its near face only — become *front* candidates when they span at most `THIN_SPAN_M`:
//!    their centre is the mean of the face's points, their diameter a guess (see [`StemFit::Front`]);
//! 3. [`StemDetector::surroundings`]: the points within 3.5 m of a candidate, 0.2 m to `max_height_m` above
//!    ground, are kept — what the stems are followed in.
//!
//! Held whole ([`StemDetector::collect`], [`StemDetector::surroundings`]), memory grows with the band and the
//! stems' surroundings. A caller that must bound it takes the band and the surroundings itself
//! ([`StemDetector::band_of`], [`StemDetector::surroundings_of`]), bucketed by [`Tiling`] tile, and fits and
//! follows one tile at a time ([`StemDetector::candidates_in`], [`StemDetector::stems_in`],
//! [`merge_stems`]): only the ground (a few numbers per square metre) is held for the whole cloud.
//!
//! [`StemDetector::finish`] then
//! - follows the stem slice by slice (`slice_m`) up and down from the band while the slice's points lie on
//!   the circle and little lies just outside it — a stem must reach from `max_base_m` to `min_top_m` above
//!   ground;
//! - fits the centres of the stem's slices against height: the lean (metres per metre) and its azimuth;
//! - guesses the class from what stands above the stem's top: a crown (many points within 3 m around, up to
//!   5 m above) makes a trunk, nothing but a thin stem a pole.
//!
//! The centre's covariance and the diameter's σ come from the geometric fit: σ̂²·(JᵀJ)⁻¹ with σ̂² the fit's
//! residual variance.

use std::collections::HashMap;

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Cells around a ground cell searched for a lower level, each way (3 m with 1 m cells: the ground a
/// parked car hides from a roof scanner reaches a few metres behind it).
const GROUND_REACH_CELLS: i64 = 3;
/// A cell more than this above the lowest cell within reach saw no ground, m (kerbs are 0.15 m, an 8 %
/// slope rises 0.24 m over 3 m).
const GROUND_STEP_M: f64 = 0.5;

/// Parameters of the stem detector.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct StemConfig {
    /// Ground grid cell, m.
    pub ground_cell_m: f64,
    /// Height of the diameter's band above ground, m (1.3: diameter at breast height).
    pub breast_height_m: f64,
    /// Half the band's thickness, m.
    pub band_half_m: f64,
    /// Points closer than this are linked into one cluster, m.
    pub link_m: f64,
    /// Fewest band points for a stem.
    pub min_points: usize,
    /// Smallest diameter, m.
    pub min_diameter_m: f64,
    /// Largest diameter, m.
    pub max_diameter_m: f64,
    /// Largest RMS of the circle fit, as a share of the radius (with a floor of 1.5 cm).
    pub max_rms_share: f64,
    /// Smallest arc of the circle the band's points must cover, degrees (one side of a stem seen by a passing
    /// scanner covers about 150°).
    pub min_arc_deg: f64,
    /// Height step of the stem's slices, m.
    pub slice_m: f64,
    /// The stem must reach down to this height above ground, m.
    pub max_base_m: f64,
    /// The stem must reach up to this height above ground, m.
    pub min_top_m: f64,
    /// Points higher above ground are not kept, m.
    pub max_height_m: f64,
    /// Report thin stems seen from one side only ([`StemFit::Front`]). Off by default: in a static cloud a
    /// wall grazed by single scan lines looks the same; the moving-scanner path turns it on and keeps only
    /// those that stand in front of what the neighbouring scan lines hit (`cloud::in_front`).
    pub thin_stems: bool,
}

impl Default for StemConfig {
    fn default() -> Self {
        Self {
            ground_cell_m: 1.0,
            breast_height_m: 1.3,
            band_half_m: 0.1,
            link_m: 0.1,
            min_points: 10,
            min_diameter_m: 0.04,
            max_diameter_m: 1.5,
            max_rms_share: 0.15,
            min_arc_deg: 60.0,
            slice_m: 0.25,
            max_base_m: 0.7,
            min_top_m: 2.0,
            max_height_m: 20.0,
            thin_stems: false,
        }
    }
}

impl StemConfig {
    /// Check every parameter; the error names the first bad one.
    pub fn check(&self) -> Result<(), String> {
        let positive = [
            ("ground_cell_m", self.ground_cell_m),
            ("breast_height_m", self.breast_height_m),
            ("band_half_m", self.band_half_m),
            ("link_m", self.link_m),
            ("min_diameter_m", self.min_diameter_m),
            ("max_diameter_m", self.max_diameter_m),
            ("max_rms_share", self.max_rms_share),
            ("slice_m", self.slice_m),
            ("min_top_m", self.min_top_m),
            ("max_height_m", self.max_height_m),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!("stems.{field} = {value}: expected a finite number > 0"));
            }
        }
        if self.min_diameter_m >= self.max_diameter_m {
            return Err(format!(
                "stems.min_diameter_m = {} is not under max_diameter_m = {}",
                self.min_diameter_m, self.max_diameter_m
            ));
        }
        if !(self.min_arc_deg.is_finite() && (0.0..=360.0).contains(&self.min_arc_deg)) {
            return Err(format!("stems.min_arc_deg = {}: expected 0–360", self.min_arc_deg));
        }
        if self.min_points < 5 {
            return Err(format!("stems.min_points = {}: expected at least 5", self.min_points));
        }
        Ok(())
    }
}

/// What a stem looks like it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StemClass {
    /// A thin stem with nothing above it: a street light, sign post, mast.
    Pole,
    /// A stem under a crown: a tree.
    Trunk,
    /// Neither clearly.
    Unknown,
}

impl StemClass {
    /// Its name in outputs.
    pub fn name(self) -> &'static str {
        match self {
            StemClass::Pole => "pole",
            StemClass::Trunk => "trunk",
            StemClass::Unknown => "unknown",
        }
    }
}

/// How a stem's centre and diameter were found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StemFit {
    /// A circle fitted to the band's points: centre, diameter and their σ measured.
    Circle,
    /// Too few sides seen for a circle (a thin stem crossed by one or two scan lines): the centre is the mean
    /// of the near face's points, which lies about 2/π of a radius toward the scanner (a caller that knows
    /// where the scanner stood moves it back, see `cloud::thin_centre`); the diameter is `THIN_DIAMETER_M`
    /// with a σ covering the 4–12 cm of sign posts and masts, and the centre's covariance the face offset.
    Front,
}

impl StemFit {
    /// Its name in outputs.
    pub fn name(self) -> &'static str {
        match self {
            StemFit::Circle => "circle",
            StemFit::Front => "front",
        }
    }
}

/// A band cluster spanning at most this can be a thin stem's near face, m.
pub const THIN_SPAN_M: f64 = 0.12;
/// The diameter reported for a thin stem, m, and its σ.
pub const THIN_DIAMETER_M: f64 = 0.08;
/// σ of a thin stem's reported diameter, m.
pub const THIN_DIAMETER_SIGMA_M: f64 = 0.03;
/// σ (each axis) of a thin stem's centre taken from its near face alone, m: the face's mean lies 2/π of an
/// unknown 2–6 cm radius from the axis, toward an unknown scanner.
pub const THIN_CENTRE_SIGMA_M: f64 = 0.03;
/// Fewest band points for a thin stem (one profile across a post at 15 m leaves about five).
const THIN_MIN_POINTS: usize = 5;

/// One detected stem.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Stem {
    /// Centre of the band's circle (easting, northing), m.
    pub centre: [f64; 2],
    /// Covariance of the centre, m² (row-major, symmetric).
    pub covariance: [[f64; 2]; 2],
    /// Diameter at the band, m.
    pub diameter_m: f64,
    /// σ of the diameter, m.
    pub diameter_sigma_m: f64,
    /// Ground height under it, m.
    pub ground_m: f64,
    /// Lowest and highest height above ground the stem was followed to, m.
    pub extent_m: [f64; 2],
    /// Lean, metres per metre of height.
    pub lean: f64,
    /// Direction it leans toward, degrees clockwise from grid north.
    pub lean_azimuth_deg: f64,
    /// The class guessed from what stands above it.
    pub class: StemClass,
    /// Points in the band.
    pub points: usize,
    /// Arc of the circle the band's points cover, degrees.
    pub arc_deg: f64,
    /// RMS of the band's circle fit (of the points about their mean for a front fit), m.
    pub rms_m: f64,
    /// How the centre and diameter were found.
    pub fit: StemFit,
}

/// The detector, fed in two passes (see the module).
#[derive(Clone, Debug)]
pub struct StemDetector {
    config: StemConfig,
    /// The three lowest heights per ground cell.
    cells: HashMap<(i64, i64), [f64; 3]>,
    /// The ground per cell once the first pass is over (see [`StemDetector::settle_ground`]).
    levels: Option<HashMap<(i64, i64), f64>>,
    /// The band's points (second pass).
    band: Vec<[f64; 2]>,
    /// The circles fitted in the band (after the second pass).
    candidates: Option<Vec<Candidate>>,
    /// 1 m cells within reach of a candidate.
    near: std::collections::HashSet<(i64, i64)>,
    /// Points kept in the third pass: x, y, height above ground.
    kept: Vec<[f64; 3]>,
}

impl StemDetector {
    /// A detector with `config` (checked by the caller with [`StemConfig::check`]).
    pub fn new(config: StemConfig) -> Self {
        Self {
            config,
            cells: HashMap::new(),
            levels: None,
            band: Vec::new(),
            candidates: None,
            near: std::collections::HashSet::new(),
            kept: Vec::new(),
        }
    }

    /// Its parameters.
    pub fn config(&self) -> StemConfig {
        self.config
    }

    fn cell(&self, x: f64, y: f64) -> (i64, i64) {
        let c = self.config.ground_cell_m;
        ((x / c).floor() as i64, (y / c).floor() as i64)
    }

    /// First pass: a batch of points (x, y, z) for the ground.
    pub fn ground(&mut self, batch: &[[f64; 3]]) {
        for p in batch {
            let key = self.cell(p[0], p[1]);
            let low = self.cells.entry(key).or_insert([f64::INFINITY; 3]);
            if p[2] < low[2] {
                low[2] = p[2];
                low.sort_by(f64::total_cmp);
            }
        }
    }

    /// The ground per cell from the first pass: a cell's own level (its third-lowest height), unless a cell
    /// within [`GROUND_REACH_CELLS`] lies more than [`GROUND_STEP_M`] lower — then the cell saw no ground
    /// (a parked car, a wall or a stem's foot hid it from the scanner, so its lowest points are on the
    /// object) and takes that lowest neighbour's level. A terrain step higher than that within the reach (a
    /// retaining wall) would be taken for such a cell too.
    fn settle_ground(&mut self) {
        if self.levels.is_some() {
            return;
        }
        let level = |low: &[f64; 3]| low.iter().rev().copied().find(|v| v.is_finite());
        let own: HashMap<(i64, i64), f64> = self.cells.iter().filter_map(|(k, low)| Some((*k, level(low)?))).collect();
        let r = GROUND_REACH_CELLS;
        let levels = own
            .iter()
            .map(|(&(i, j), &g)| {
                let lowest = (-r..=r)
                    .flat_map(|di| (-r..=r).map(move |dj| (i + di, j + dj)))
                    .filter_map(|k| own.get(&k).copied())
                    .fold(g, f64::min);
                ((i, j), if g - lowest > GROUND_STEP_M { lowest } else { g })
            })
            .collect();
        self.levels = Some(levels);
    }

    /// The ground height at (x, y): its cell's, or the lowest of its neighbours' when it has none.
    fn ground_at(&self, x: f64, y: f64) -> Option<f64> {
        let (i, j) = self.cell(x, y);
        let levels = self.levels.as_ref()?;
        if let Some(&g) = levels.get(&(i, j)) {
            return Some(g);
        }
        (-1..=1)
            .flat_map(|di| (-1..=1).map(move |dj| (i + di, j + dj)))
            .filter_map(|k| levels.get(&k).copied())
            .min_by(f64::total_cmp)
    }

    /// Height above ground of a point, when a ground cell is within reach.
    fn height(&self, p: &[f64; 3]) -> Option<f64> {
        self.ground_at(p[0], p[1]).map(|g| p[2] - g)
    }

    /// Second pass: the same points again; those of the breast-height band are kept.
    pub fn collect(&mut self, batch: &[[f64; 3]]) {
        let mut band = std::mem::take(&mut self.band);
        self.band_of(batch, |p| band.push(p));
        self.band = band;
    }

    /// Second pass, for a caller that keeps the band itself (by tile, see [`Tiling`]): each point of `batch`
    /// in the breast-height band goes to `sink` as (x, y).
    pub fn band_of(&mut self, batch: &[[f64; 3]], mut sink: impl FnMut([f64; 2])) {
        self.settle_ground();
        let (centre, half) = (self.config.breast_height_m, self.config.band_half_m);
        for p in batch {
            if self.height(p).is_some_and(|h| (h - centre).abs() <= half) {
                sink([p[0], p[1]]);
            }
        }
    }

    /// The band's circles, fitted once after the second pass.
    fn fit_candidates(&mut self) {
        if self.candidates.is_none() {
            let found = self.candidates_in(&self.band);
            self.add_candidates(found);
        }
    }

    /// The candidates among the band points `band` (the whole band, or one tile's with its margin): each
    /// cluster's circle that can be a stem's.
    pub fn candidates_in(&self, band: &[[f64; 2]]) -> Vec<Candidate> {
        let c = self.config;
        clusters(band, c.link_m)
            .into_iter()
            .filter(|cluster| {
                cluster.len() >= if c.thin_stems { THIN_MIN_POINTS.min(c.min_points) } else { c.min_points }
            })
            .filter_map(|cluster| {
                let pts: Vec<[f64; 2]> = cluster.iter().map(|&i| band[i]).collect();
                let circle = if pts.len() >= c.min_points { candidate(&pts, &c) } else { None };
                circle.or_else(|| if c.thin_stems { thin_candidate(&pts) } else { None })
            })
            .collect()
    }

    /// Take `found` as candidates: the third pass keeps the points around them.
    pub fn add_candidates(&mut self, found: Vec<Candidate>) {
        self.near.extend(surroundings_cells(&found));
        self.candidates.get_or_insert_with(Vec::new).extend(found);
    }

    /// The candidates taken so far.
    pub fn candidates(&self) -> &[Candidate] {
        self.candidates.as_deref().unwrap_or_default()
    }

    /// Third pass: the same points again; those near a candidate, 0.2 m to `max_height_m` above ground,
    /// are kept.
    pub fn surroundings(&mut self, batch: &[[f64; 3]]) {
        self.fit_candidates();
        let mut kept = std::mem::take(&mut self.kept);
        self.surroundings_of(batch, |p| kept.push(p));
        self.kept = kept;
    }

    /// Third pass, for a caller that keeps the points itself (by tile): each point of `batch` near a
    /// candidate taken so far, 0.2 m to `max_height_m` above ground, goes to `sink` as (x, y, height above
    /// ground).
    pub fn surroundings_of(&self, batch: &[[f64; 3]], mut sink: impl FnMut([f64; 3])) {
        for p in batch {
            if !self.near.contains(&(p[0].floor() as i64, p[1].floor() as i64)) {
                continue;
            }
            if let Some(h) = self.height(p)
                && (0.2..=self.config.max_height_m).contains(&h)
            {
                sink([p[0], p[1], h]);
            }
        }
    }

    /// Points of the band (second pass).
    pub fn band_points(&self) -> usize {
        self.band.len()
    }

    /// Centres of the `size`-metre cells that hold ground (what the cloud covers), sorted.
    pub fn covered_cells(&self, size: f64) -> Vec<[f64; 2]> {
        let c = self.config.ground_cell_m;
        let mut keys: Vec<(i64, i64)> = self
            .cells
            .keys()
            .map(|&(i, j)| {
                let (x, y) = ((i as f64 + 0.5) * c, (j as f64 + 0.5) * c);
                ((x / size).floor() as i64, (y / size).floor() as i64)
            })
            .collect();
        keys.sort_unstable();
        keys.dedup();
        keys.into_iter().map(|(i, j)| [(i as f64 + 0.5) * size, (j as f64 + 0.5) * size]).collect()
    }

    /// Points kept around the candidates (third pass).
    pub fn kept(&self) -> usize {
        self.kept.len()
    }

    /// The stems found.
    pub fn finish(&mut self) -> Vec<Stem> {
        self.fit_candidates();
        let candidates = self.candidates.as_deref().unwrap_or_default();
        let stems = self.stems_in(candidates, &self.kept);
        merge_stems(stems, &self.config)
    }

    /// The stems of `candidates` followed in `kept` (points the third pass gave, holding all within
    /// [`Tiling`]'s margin of them), before [`merge_stems`].
    pub fn stems_in(&self, candidates: &[Candidate], kept: &[[f64; 3]]) -> Vec<Stem> {
        let index = GridIndex::new(kept, 1.0);
        candidates.iter().filter_map(|k| self.stem_of(k, &index, kept)).collect()
    }

    fn stem_of(&self, candidate: &Candidate, index: &GridIndex, kept: &[[f64; 3]]) -> Option<Stem> {
        let c = &self.config;
        let Candidate { fit, arc, points, thin } = candidate;
        let (arc, points, thin) = (*arc, *points, *thin);
        let diameter = if thin { THIN_DIAMETER_M } else { 2.0 * fit.r };
        let ground = self.ground_at(fit.centre[0], fit.centre[1])?;
        // Follow the stem up and down from the band, each slice from the centre of the one before (a leaning
        // stem moves), while the slice's points lie on the circle and no more lie just outside it. A thin
        // stem's face is followed about a fixed centre: points within its span, none too many just beyond.
        let tolerance = (0.25 * fit.r).max(0.03);
        let on_stem = |h0: f64, centre: [f64; 2]| -> Option<[f64; 2]> {
            let mut ring = Vec::new();
            let mut outside = 0usize;
            for p in index.near(centre, fit.r + OUTSIDE_M, kept) {
                if p[2] < h0 || p[2] >= h0 + c.slice_m {
                    continue;
                }
                let d = (p[0] - centre[0]).hypot(p[1] - centre[1]);
                let on = if thin { d <= fit.r + tolerance } else { (d - fit.r).abs() <= tolerance };
                if on {
                    ring.push([p[0], p[1]]);
                } else if d > fit.r + tolerance && d <= fit.r + OUTSIDE_M {
                    outside += 1;
                }
            }
            let next = if thin { centre } else { centroid_on_circle(&ring, centre, fit.r) };
            (ring.len() >= 3 && outside <= 2 * ring.len()).then_some(next)
        };
        let band_low = c.breast_height_m - c.band_half_m;
        let mut centres: Vec<(f64, [f64; 2])> = vec![(c.breast_height_m, fit.centre)];
        let follow = |start: f64, step: f64, centres: &mut Vec<(f64, [f64; 2])>| -> f64 {
            let (mut h, mut reached, mut centre, mut misses) = (start, start, fit.centre, 0);
            while (0.2 - c.slice_m..c.max_height_m).contains(&h) && misses < 2 {
                match on_stem(h, centre) {
                    Some(next) => {
                        centres.push((h + 0.5 * c.slice_m, next));
                        centre = next;
                        reached = if step > 0.0 { h + c.slice_m } else { h.max(0.2) };
                        misses = 0;
                    }
                    None => misses += 1,
                }
                h += step;
            }
            reached
        };
        let top = follow(c.breast_height_m + c.band_half_m, c.slice_m, &mut centres);
        let base = follow(band_low - c.slice_m, -c.slice_m, &mut centres).min(band_low);
        if base > c.max_base_m || top < c.min_top_m {
            return None;
        }
        let (lean, lean_azimuth_deg) = lean_of(&centres);
        let class = class_of(fit.centre, fit.r, top, index, kept);
        let cov = fit.covariance;
        Some(Stem {
            centre: fit.centre,
            covariance: [[cov[(0, 0)], cov[(0, 1)]], [cov[(1, 0)], cov[(1, 1)]]],
            diameter_m: diameter,
            diameter_sigma_m: if thin { THIN_DIAMETER_SIGMA_M } else { 2.0 * cov[(2, 2)].max(0.0).sqrt() },
            ground_m: ground,
            extent_m: [base, top],
            lean,
            lean_azimuth_deg,
            class,
            points,
            arc_deg: arc,
            rms_m: fit.rms,
            fit: if thin { StemFit::Front } else { StemFit::Circle },
        })
    }
}

/// The 1 m cells (floor of x, floor of y) the third pass keeps the surroundings of `candidates` in: those
/// within a candidate's radius, the crown's reach and half a metre of its centre. A kept point (x, y,
/// height) lies in one of them when `cells.contains(&(x.floor() as i64, y.floor() as i64))`.
pub fn surroundings_cells(candidates: &[Candidate]) -> std::collections::HashSet<(i64, i64)> {
    let mut cells = std::collections::HashSet::new();
    for Candidate { fit, .. } in candidates {
        let reach = fit.r + CROWN_RADIUS_M + 0.5;
        let (lo_i, hi_i) = (((fit.centre[0] - reach).floor()) as i64, ((fit.centre[0] + reach).floor()) as i64);
        let (lo_j, hi_j) = (((fit.centre[1] - reach).floor()) as i64, ((fit.centre[1] + reach).floor()) as i64);
        for i in lo_i..=hi_i {
            for j in lo_j..=hi_j {
                cells.insert((i, j));
            }
        }
    }
    cells
}

/// Stems the tiles or clusters found twice (two clusters of one stem, a gap in the band): of overlapping
/// ones the one with more band points stays (then the westernmost, southernmost); sorted by centre.
pub fn merge_stems(mut stems: Vec<Stem>, config: &StemConfig) -> Vec<Stem> {
    stems.sort_by(|a, b| {
        b.points.cmp(&a.points).then(a.centre[0].total_cmp(&b.centre[0])).then(a.centre[1].total_cmp(&b.centre[1]))
    });
    let mut out: Vec<Stem> = Vec::new();
    for s in stems {
        let overlaps = out.iter().any(|o| {
            let d = (o.centre[0] - s.centre[0]).hypot(o.centre[1] - s.centre[1]);
            d < 0.5 * (o.diameter_m.max(s.diameter_m)) + config.link_m
        });
        if !overlaps {
            out.push(s);
        }
    }
    out.sort_by(|a, b| a.centre[0].total_cmp(&b.centre[0]).then(a.centre[1].total_cmp(&b.centre[1])));
    out
}

/// A crown above the top makes a trunk; a thin stem with (almost) nothing around its top a pole.
fn class_of(centre: [f64; 2], r: f64, top: f64, index: &GridIndex, kept: &[[f64; 3]]) -> StemClass {
    let crown = index
        .near(centre, CROWN_RADIUS_M, kept)
        .filter(|p| p[2] >= top && p[2] <= top + 5.0)
        .filter(|p| (p[0] - centre[0]).hypot(p[1] - centre[1]) <= CROWN_RADIUS_M)
        .count();
    if crown >= CROWN_POINTS && r >= 0.05 {
        StemClass::Trunk
    } else if crown < CROWN_POINTS && 2.0 * r <= 0.5 {
        StemClass::Pole
    } else {
        StemClass::Unknown
    }
}

/// A band cluster's circle that can be a stem's.
#[derive(Clone, Copy, Debug)]
pub struct Candidate {
    fit: Circle,
    /// Arc of the circle its points cover, degrees.
    arc: f64,
    /// Points the fit kept.
    points: usize,
    /// A thin stem's near face, not a circle (see [`StemFit::Front`]); `fit.r` is then the face's half span.
    thin: bool,
}

impl Candidate {
    /// Centre of its circle (x, y), m.
    pub fn centre(&self) -> [f64; 2] {
        self.fit.centre
    }
}

/// Square tiles of the plane, each grown by a margin, for a detection that holds one tile's band and
/// surroundings at a time instead of the whole cloud's: the band points go to every tile whose grown area
/// holds them, each tile's candidates are fitted from its own band, and a tile keeps those whose centre lies
/// in it; the surroundings likewise, and each tile follows its own candidates' stems. The margin
/// ([`Tiling::margin_for`]) holds everything a candidate's cluster and stem reach, so a tiled detection
/// finds exactly what a whole one does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tiling {
    /// Side of a tile, m.
    pub size_m: f64,
    /// How far beyond its tile a tile's points reach, m (less than `size_m`).
    pub margin_m: f64,
}

impl Tiling {
    /// Tiles of `size_m` with the margin `config` needs (at most `size_m`: its caller picks a size that
    /// holds it).
    pub fn new(size_m: f64, config: &StemConfig) -> Self {
        Self { size_m, margin_m: Self::margin_for(config).min(size_m) }
    }

    /// The margin a detection with `config` needs, m: a candidate's cluster spans at most
    /// 2 × `max_diameter_m` + 2 × `link_m` (wider ones are refused before a fit) around a centre within a
    /// radius of its points; the surroundings kept around a candidate reach its radius, the crown's 3 m and
    /// 0.5 m, rounded out to 1 m cells (√2 m at most).
    pub fn margin_for(config: &StemConfig) -> f64 {
        let r = 0.5 * config.max_diameter_m;
        let cluster = 2.0 * config.max_diameter_m + 2.0 * config.link_m + r;
        let surroundings = r + CROWN_RADIUS_M + 0.5 + std::f64::consts::SQRT_2;
        cluster.max(surroundings) + 0.5
    }

    /// The tile holding (x, y).
    pub fn tile_of(&self, p: [f64; 2]) -> (i64, i64) {
        ((p[0] / self.size_m).floor() as i64, (p[1] / self.size_m).floor() as i64)
    }

    /// The tiles whose area grown by the margin holds (x, y): its own and up to three neighbours.
    pub fn tiles_holding(&self, p: [f64; 2]) -> impl Iterator<Item = (i64, i64)> + use<> {
        let (s, m) = (self.size_m, self.margin_m);
        let axis = |v: f64| {
            let i = (v / s).floor() as i64;
            let f = v - i as f64 * s;
            [Some(i), (f < m).then_some(i - 1), (f >= s - m).then_some(i + 1)]
        };
        let (xs, ys) = (axis(p[0]), axis(p[1]));
        xs.into_iter().flatten().flat_map(move |i| ys.into_iter().flatten().map(move |j| (i, j)))
    }
}

/// A band cluster's circle, when it can be a stem's: not wider than any stem with its twigs, a circle
/// fitting it robustly (twigs and branch stubs are outliers), of a plausible diameter, residual and arc.
fn candidate(cluster: &[[f64; 2]], c: &StemConfig) -> Option<Candidate> {
    let (min, max) = bounds(cluster);
    if (max[0] - min[0]).hypot(max[1] - min[1]) > 2.0 * c.max_diameter_m + 2.0 * c.link_m {
        return None;
    }
    let (fit, pts) = fit_circle_robust(cluster, c.min_points)?;
    let diameter = 2.0 * fit.r;
    if !(c.min_diameter_m..=c.max_diameter_m).contains(&diameter) || fit.rms > (c.max_rms_share * fit.r).max(0.015) {
        return None;
    }
    let arc = arc_deg(&pts, fit.centre);
    (arc >= c.min_arc_deg).then_some(Candidate { fit, arc, points: pts.len(), thin: false })
}

/// A band cluster no circle fits that can be a thin stem's near face: it spans at most `THIN_SPAN_M`. Its
/// centre is the points' mean, with the covariance `THIN_CENTRE_SIGMA_M` gives; `r` is half its span, the
/// reach its face is followed in.
fn thin_candidate(cluster: &[[f64; 2]]) -> Option<Candidate> {
    let (min, max) = bounds(cluster);
    let span = (max[0] - min[0]).hypot(max[1] - min[1]);
    if cluster.len() < THIN_MIN_POINTS || span > THIN_SPAN_M {
        return None;
    }
    let n = cluster.len() as f64;
    let centre = cluster.iter().fold([0.0, 0.0], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
    let rms = (cluster.iter().map(|p| (p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2)).sum::<f64>() / n).sqrt();
    let var = THIN_CENTRE_SIGMA_M * THIN_CENTRE_SIGMA_M;
    let covariance = Matrix3::from_diagonal(&Vector3::new(var, var, 0.0));
    let fit = Circle { centre, r: 0.5 * span, rms, covariance };
    Some(Candidate { fit, arc: arc_deg(cluster, centre), points: cluster.len(), thin: true })
}

/// Radius around a stem searched for a crown, m.
const CROWN_RADIUS_M: f64 = 3.0;

/// Width of the ring just outside a stem's circle where other points (a wall, a car, foliage) end the stem:
/// more than twice the points on the circle in a slice, m. Twigs and branch stubs stay under that.
const OUTSIDE_M: f64 = 0.25;

/// Points above a stem's top that make a crown.
const CROWN_POINTS: usize = 50;

/// Connected clusters of `points` linked at `link` (grid-hashed union–find).
fn clusters(points: &[[f64; 2]], link: f64) -> Vec<Vec<usize>> {
    let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    let key = |p: &[f64; 2]| ((p[0] / link).floor() as i64, (p[1] / link).floor() as i64);
    for (i, p) in points.iter().enumerate() {
        grid.entry(key(p)).or_default().push(i);
    }
    let mut parent: Vec<usize> = (0..points.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let link2 = link * link;
    for (i, p) in points.iter().enumerate() {
        let (ci, cj) = key(p);
        for di in -1..=1 {
            for dj in -1..=1 {
                let Some(others) = grid.get(&(ci + di, cj + dj)) else { continue };
                for &j in others {
                    if j <= i {
                        continue;
                    }
                    let q = &points[j];
                    if (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) <= link2 {
                        let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                        if a != b {
                            parent[a] = b;
                        }
                    }
                }
            }
        }
    }
    let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
    for i in 0..points.len() {
        let r = root(&mut parent, i);
        groups.entry(r).or_default().push(i);
    }
    let mut out: Vec<Vec<usize>> = groups.into_values().collect();
    out.sort_by_key(|g| g[0]);
    out
}

/// Kept points hashed on a horizontal grid, for neighbourhood queries.
struct GridIndex {
    cell: f64,
    cells: HashMap<(i64, i64), Vec<usize>>,
}

impl GridIndex {
    fn new(points: &[[f64; 3]], cell: f64) -> Self {
        let mut cells: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (i, p) in points.iter().enumerate() {
            cells.entry(((p[0] / cell).floor() as i64, (p[1] / cell).floor() as i64)).or_default().push(i);
        }
        Self { cell, cells }
    }

    /// Points in the cells within `radius` of `centre` (a superset of the disc).
    fn near<'a>(&'a self, centre: [f64; 2], radius: f64, points: &'a [[f64; 3]]) -> impl Iterator<Item = &'a [f64; 3]> {
        let lo = [((centre[0] - radius) / self.cell).floor() as i64, ((centre[1] - radius) / self.cell).floor() as i64];
        let hi = [((centre[0] + radius) / self.cell).floor() as i64, ((centre[1] + radius) / self.cell).floor() as i64];
        (lo[0]..=hi[0])
            .flat_map(move |i| (lo[1]..=hi[1]).map(move |j| (i, j)))
            .filter_map(|k| self.cells.get(&k))
            .flatten()
            .map(|&i| &points[i])
    }
}

fn bounds(pts: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for p in pts {
        for k in 0..2 {
            min[k] = min[k].min(p[k]);
            max[k] = max[k].max(p[k]);
        }
    }
    (min, max)
}

/// A fitted circle.
#[derive(Clone, Copy, Debug)]
struct Circle {
    centre: [f64; 2],
    r: f64,
    rms: f64,
    /// Covariance of (cx, cy, r).
    covariance: Matrix3<f64>,
}

/// Algebraic (Kåsa) fit, refined by Gauss–Newton on the geometric distances. Coordinates are taken
/// relative to the points' mean, so that map coordinates of millions of metres lose nothing.
fn fit_circle(pts: &[[f64; 2]]) -> Option<Circle> {
    let n = pts.len();
    if n < 3 {
        return None;
    }
    let mean = pts.iter().fold([0.0, 0.0], |a, p| [a[0] + p[0], a[1] + p[1]]);
    let mean = [mean[0] / n as f64, mean[1] / n as f64];
    let local: Vec<[f64; 2]> = pts.iter().map(|p| [p[0] - mean[0], p[1] - mean[1]]).collect();
    // x² + y² + D x + E y + F = 0.
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for p in &local {
        let row = Vector3::new(p[0], p[1], 1.0);
        ata += row * row.transpose();
        atb += row * -(p[0] * p[0] + p[1] * p[1]);
    }
    let sol = ata.try_inverse()? * atb;
    let (mut cx, mut cy) = (-sol[0] / 2.0, -sol[1] / 2.0);
    let r2 = cx * cx + cy * cy - sol[2];
    if r2.is_nan() || r2 <= 0.0 {
        return None;
    }
    let mut r = r2.sqrt();
    let mut jtj = Matrix3::zeros();
    let mut ss = 0.0;
    for _ in 0..20 {
        jtj = Matrix3::zeros();
        let mut jtr = Vector3::zeros();
        ss = 0.0;
        for p in &local {
            let (dx, dy) = (p[0] - cx, p[1] - cy);
            let d = dx.hypot(dy).max(1e-12);
            let res = d - r;
            let j = Vector3::new(-dx / d, -dy / d, -1.0);
            jtj += j * j.transpose();
            jtr += j * res;
            ss += res * res;
        }
        let step = jtj.try_inverse()? * jtr;
        cx -= step[0];
        cy -= step[1];
        r -= step[2];
        if step.norm() < 1e-9 {
            break;
        }
    }
    if !(r.is_finite() && r > 0.0 && cx.is_finite() && cy.is_finite()) {
        return None;
    }
    let dof = (n as f64 - 3.0).max(1.0);
    let covariance = jtj.try_inverse()? * (ss / dof);
    Some(Circle { centre: [cx + mean[0], cy + mean[1]], r, rms: (ss / n as f64).sqrt(), covariance })
}

/// [`fit_circle`], then refitted without the points farther from the circle than 3 robust σ (1.4826 × the
/// median absolute residual, at least 5 mm) until none is dropped (at most four times); `None` when fewer
/// than `min_points` or under half the points are left. Returns the circle and the points it kept.
fn fit_circle_robust(pts: &[[f64; 2]], min_points: usize) -> Option<(Circle, Vec<[f64; 2]>)> {
    let mut kept = pts.to_vec();
    let mut fit = fit_circle(&kept)?;
    for _ in 0..4 {
        let residual = |p: &[f64; 2]| ((p[0] - fit.centre[0]).hypot(p[1] - fit.centre[1]) - fit.r).abs();
        let mut abs: Vec<f64> = kept.iter().map(residual).collect();
        let mid = abs.len() / 2;
        let median = *abs.select_nth_unstable_by(mid, f64::total_cmp).1;
        let limit = 3.0 * (1.4826 * median).max(0.005);
        let inliers: Vec<[f64; 2]> = kept.iter().copied().filter(|p| residual(p) <= limit).collect();
        if inliers.len() == kept.len() {
            break;
        }
        if inliers.len() < min_points.max(3) || 2 * inliers.len() < pts.len() {
            return None;
        }
        kept = inliers;
        fit = fit_circle(&kept)?;
    }
    Some((fit, kept))
}

/// The arc of directions from `centre` the points cover: 360° less the largest empty gap, degrees.
fn arc_deg(pts: &[[f64; 2]], centre: [f64; 2]) -> f64 {
    let mut angles: Vec<f64> = pts.iter().map(|p| (p[1] - centre[1]).atan2(p[0] - centre[0])).collect();
    angles.sort_by(f64::total_cmp);
    let mut gap: f64 = 0.0;
    for w in angles.windows(2) {
        gap = gap.max(w[1] - w[0]);
    }
    if let (Some(first), Some(last)) = (angles.first(), angles.last()) {
        gap = gap.max(first + std::f64::consts::TAU - last);
    }
    (std::f64::consts::TAU - gap).to_degrees()
}

/// The centre of a slice's points on a circle of known radius near `guess`: the guess moved by the mean
/// of each point's offset from the circle along its direction (one Gauss–Newton step in the centre only).
fn centroid_on_circle(ring: &[[f64; 2]], guess: [f64; 2], r: f64) -> [f64; 2] {
    let mut c = guess;
    for _ in 0..5 {
        let mut jtj = nalgebra::Matrix2::zeros();
        let mut jtr = nalgebra::Vector2::zeros();
        for p in ring {
            let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
            let d = dx.hypot(dy).max(1e-12);
            let j = nalgebra::Vector2::new(-dx / d, -dy / d);
            jtj += j * j.transpose();
            jtr += j * (d - r);
        }
        let Some(inv) = jtj.try_inverse() else { return c };
        let step = inv * jtr;
        c = [c[0] - step[0], c[1] - step[1]];
    }
    c
}

/// Lean from the slice centres against height: |slope| and its azimuth (clockwise from north), by least
/// squares; zero with fewer than three slices.
fn lean_of(centres: &[(f64, [f64; 2])]) -> (f64, f64) {
    if centres.len() < 3 {
        return (0.0, 0.0);
    }
    let n = centres.len() as f64;
    let mh = centres.iter().map(|c| c.0).sum::<f64>() / n;
    let mx = centres.iter().map(|c| c.1[0]).sum::<f64>() / n;
    let my = centres.iter().map(|c| c.1[1]).sum::<f64>() / n;
    let shh: f64 = centres.iter().map(|c| (c.0 - mh).powi(2)).sum();
    if shh <= 0.0 {
        return (0.0, 0.0);
    }
    let sx: f64 = centres.iter().map(|c| (c.0 - mh) * (c.1[0] - mx)).sum::<f64>() / shh;
    let sy: f64 = centres.iter().map(|c| (c.0 - mh) * (c.1[1] - my)).sum::<f64>() / shh;
    let azimuth = sx.atan2(sy).to_degrees().rem_euclid(360.0);
    (sx.hypot(sy), azimuth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_circle_is_fitted_from_an_arc_far_from_the_origin() {
        let (cx, cy, r) = (512_345.678, 5_401_234.5, 0.2);
        let pts: Vec<[f64; 2]> = (0..40)
            .map(|k| {
                let a = -1.2 + 2.4 * f64::from(k) / 39.0;
                [cx + r * a.cos(), cy + r * a.sin()]
            })
            .collect();
        let fit = fit_circle(&pts).unwrap();
        assert!((fit.centre[0] - cx).abs() < 1e-6 && (fit.centre[1] - cy).abs() < 1e-6, "{fit:?}");
        assert!((fit.r - r).abs() < 1e-7, "{fit:?}");
        assert!((arc_deg(&pts, fit.centre) - 2.4f64.to_degrees()).abs() < 1e-6);
    }

    #[test]
    fn clusters_link_points_closer_than_the_link() {
        let pts = [[0.0, 0.0], [0.05, 0.0], [0.1, 0.0], [0.5, 0.0], [0.55, 0.02]];
        let mut c = clusters(&pts, 0.06);
        c.sort();
        assert_eq!(c, vec![vec![0, 1, 2], vec![3, 4]]);
    }

    #[test]
    fn lean_points_the_way_the_stem_goes() {
        let centres: Vec<(f64, [f64; 2])> =
            (0..8).map(|k| (f64::from(k) * 0.25, [0.02 * f64::from(k) * 0.25, 0.0])).collect();
        let (lean, azimuth) = lean_of(&centres);
        assert!((lean - 0.02).abs() < 1e-12 && (azimuth - 90.0).abs() < 1e-9, "{lean} {azimuth}");
    }

    #[test]
    fn bad_parameters_are_named() {
        let bad = StemConfig { min_diameter_m: 2.0, ..StemConfig::default() };
        assert!(bad.check().unwrap_err().contains("min_diameter_m"));
        assert!(StemConfig::default().check().is_ok());
    }
}

#[cfg(test)]
mod scene_tests {
    use plumbline_synth::scan::{ScanScene, scan_scene};

    use super::*;

    /// A scanned street: two trees, two poles, a facade, a parked car and a bush, one side of each stem seen.
    #[test]
    fn stems_of_a_scanned_street_are_found_with_centre_diameter_lean_and_class() {
        let (points, truth) = scan_scene(&ScanScene::default(), 5);
        let stems = whole(&points);
        for s in &stems {
            println!(
                "{:?} centre ({:.3}, {:.3}) d {:.3}±{:.3} extent {:?} lean {:.3} → {:.0}° arc {:.0}° rms {:.4} pts {}",
                s.class,
                s.centre[0],
                s.centre[1],
                s.diameter_m,
                s.diameter_sigma_m,
                s.extent_m,
                s.lean,
                s.lean_azimuth_deg,
                s.arc_deg,
                s.rms_m,
                s.points
            );
        }
        assert_eq!(stems.len(), truth.len(), "{stems:#?}");
        for t in &truth {
            let c = t.centre_at(1.3);
            let s = stems
                .iter()
                .min_by(|a, b| {
                    let da = (a.centre[0] - c[0]).hypot(a.centre[1] - c[1]);
                    let db = (b.centre[0] - c[0]).hypot(b.centre[1] - c[1]);
                    da.total_cmp(&db)
                })
                .unwrap();
            let off = (s.centre[0] - c[0]).hypot(s.centre[1] - c[1]);
            assert!(off < 0.03, "centre {off} m off for {t:?}: {s:?}");
            assert!((s.diameter_m - t.diameter_m).abs() < 0.02, "diameter for {t:?}: {s:?}");
            assert_eq!(s.class, if t.crown { StemClass::Trunk } else { StemClass::Pole }, "{t:?}: {s:?}");
            let lean = t.lean[0].hypot(t.lean[1]);
            assert!((s.lean - lean).abs() < 0.01, "lean {} for {t:?}", s.lean);
            // The centre's σ covers the error it made (4σ).
            let sigma = s.covariance[0][0].max(s.covariance[1][1]).sqrt();
            assert!(off < 4.0 * sigma.max(0.002), "centre {off} m off with σ {sigma}: {s:?}");
        }
    }

    /// The stems of `points` held whole, each pass fed in batches.
    fn whole(points: &[[f64; 3]]) -> Vec<Stem> {
        let mut d = StemDetector::new(StemConfig::default());
        for batch in points.chunks(10_000) {
            d.ground(batch);
        }
        for batch in points.chunks(10_000) {
            d.collect(batch);
        }
        for batch in points.chunks(10_000) {
            d.surroundings(batch);
        }
        d.finish()
    }

    #[test]
    fn a_tiled_detection_finds_exactly_what_a_whole_one_does() {
        let (points, _) = scan_scene(&ScanScene::default(), 5);
        let whole = whole(&points);
        assert!(whole.len() >= 4, "{whole:#?}");
        let config = StemConfig::default();
        // Tiles of about 10 m whose borders run through each stem's centre in turn, and larger ones.
        let through: Vec<f64> = whole.iter().map(|s| s.centre[0] / (s.centre[0] / 10.0).round()).collect();
        for size in through.into_iter().chain([16.0, 40.0]) {
            let tiling = Tiling::new(size, &config);
            let mut d = StemDetector::new(config);
            let bucket = |p: [f64; 2]| tiling.tiles_holding(p).collect::<Vec<_>>();
            for batch in points.chunks(10_000) {
                d.ground(batch);
            }
            let mut band: std::collections::BTreeMap<(i64, i64), Vec<[f64; 2]>> = Default::default();
            for batch in points.chunks(10_000) {
                d.band_of(batch, |p| bucket(p).into_iter().for_each(|t| band.entry(t).or_default().push(p)));
            }
            let mut found = Vec::new();
            for (tile, pts) in &band {
                found.extend(d.candidates_in(pts).into_iter().filter(|c| tiling.tile_of(c.centre()) == *tile));
            }
            d.add_candidates(found);
            let mut kept: HashMap<(i64, i64), Vec<[f64; 3]>> = HashMap::new();
            for batch in points.chunks(10_000) {
                d.surroundings_of(batch, |p| {
                    bucket([p[0], p[1]]).into_iter().for_each(|t| kept.entry(t).or_default().push(p))
                });
            }
            let mut owners: HashMap<(i64, i64), Vec<Candidate>> = HashMap::new();
            for c in d.candidates() {
                owners.entry(tiling.tile_of(c.centre())).or_default().push(*c);
            }
            assert!(owners.len() >= 3 || size > 12.0, "{size} m tiles: the stems should fall in several tiles");
            let mut stems = Vec::new();
            for (tile, candidates) in &owners {
                // Only the points around the tile's own candidates, as `poles detect` reads them.
                let cells = surroundings_cells(candidates);
                let own: Vec<[f64; 3]> = kept
                    .get(tile)
                    .map_or(&[][..], Vec::as_slice)
                    .iter()
                    .copied()
                    .filter(|p| cells.contains(&(p[0].floor() as i64, p[1].floor() as i64)))
                    .collect();
                stems.extend(d.stems_in(candidates, &own));
            }
            let tiled = merge_stems(stems, &config);
            assert!(tiled == whole, "{size} m tiles: {} stems against {} whole", tiled.len(), whole.len());
        }
    }
}
