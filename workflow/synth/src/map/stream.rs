//! The campaign map drawn piece by piece as a drive of any length is made (the `city` preset): what the map
//! shows is marked in a grid of square cells that grows with the drawn extent; whenever its longer side
//! would pass the cell budget, the cells double in size (2 × 2 merge), so memory stays below budget² × 4 bytes
//! however long the drive. The PNG is rendered at the end, its longer side `size_px`, north up, in the layers and
//! colours of [`campaign_map_png`](super::campaign_map_png): buildings, streets, aerial footprints, poles,
//! the drive coloured by the horizontal DG error (green 0 → red 1 m), standstills in black.

use image::{Rgb, RgbImage};

use super::{RED_AT, class_colour};
use crate::motion::Drive;
use crate::motion::dg::DgSolution;
use crate::render::{RenderError, encode_png_rgb};
use crate::world::{PoleClass, World};

const BUILDING: u32 = 1;
const STREET: u32 = 1 << 1;
const FOOTPRINT: u32 = 1 << 2;
const POLE: u32 = 1 << 3;
const TRACK: u32 = 1 << 4;
const STOP: u32 = 1 << 5;
/// Bits 8–9: the pole's class; bits 16–23: the largest DG error on the track in the cell, 255 = `RED_AT`.
const CLASS_SHIFT: u32 = 8;
const ERROR_SHIFT: u32 = 16;
/// Finest cell, metres.
const FINEST_CELL_M: f64 = 0.25;
/// Track samples along the drive, metres.
const TRACK_STEP_M: f64 = 0.5;

/// A campaign map of bounded memory, drawn leg by leg.
#[derive(Clone, Debug)]
pub struct StreamedMap {
    budget: usize,
    cell: f64,
    /// Grid index of the first column and row (south-west corner), in cells of the current size.
    origin: [i64; 2],
    /// Columns, rows.
    size: [usize; 2],
    grid: Vec<u32>,
}

impl StreamedMap {
    /// An empty map whose grid never has more than `budget` cells on a side (at least 64).
    pub fn new(budget: usize) -> Self {
        Self { budget: budget.max(64), cell: FINEST_CELL_M, origin: [0, 0], size: [0, 0], grid: Vec::new() }
    }

    /// Size of a cell now, metres.
    pub fn cell_size(&self) -> f64 {
        self.cell
    }

    /// Columns and rows of the grid now.
    pub fn grid_size(&self) -> [usize; 2] {
        self.size
    }

    /// Draw a world (or a window of the city): buildings, street centre lines and poles.
    pub fn world(&mut self, world: &World) {
        for b in &world.buildings {
            let c = b.shape.corners();
            let lo = [
                c.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
                c.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min),
            ];
            let hi = [
                c.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
                c.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max),
            ];
            self.rect(lo, hi, BUILDING);
        }
        for s in &world.streets {
            for w in s.points.windows(2) {
                self.line([w[0][0], w[0][1]], [w[1][0], w[1][1]], STREET);
            }
        }
        for p in &world.poles {
            self.mark([p.base[0], p.base[1]], POLE | (class_index(p.class) << CLASS_SHIFT));
        }
    }

    /// Draw an aerial frame's ground footprint (four corners, easting/northing).
    pub fn footprint(&mut self, corners: &[[f64; 2]; 4]) {
        for k in 0..4 {
            self.line(corners[k], corners[(k + 1) % 4], FOOTPRINT);
        }
    }

    /// Draw a drive (every 0.5 m, with its horizontal DG error) and its standstills.
    pub fn drive(&mut self, drive: &Drive, dg: &DgSolution) {
        let records = drive.trajectory.records();
        let mut next = f64::NEG_INFINITY;
        for ((rec, k), e) in records.iter().zip(&drive.kinematics).zip(&dg.errors) {
            if k.distance >= next {
                next = k.distance + TRACK_STEP_M;
                let red = (e.position.x().hypot(e.position.y()) / RED_AT).clamp(0.0, 1.0);
                self.mark(
                    [rec.position.x(), rec.position.y()],
                    TRACK | (((red * 255.0).round() as u32) << ERROR_SHIFT),
                );
            }
        }
        for stop in &drive.stops {
            let i = drive.kinematics.partition_point(|k| k.distance < stop.s).min(records.len().saturating_sub(1));
            if let Some(r) = records.get(i) {
                self.mark([r.position.x(), r.position.y()], STOP);
            }
        }
    }

    /// PNG bytes of the map: the drawn extent with a 5 % margin, its longer side `size_px` pixels (at least
    /// 16); white if nothing was drawn.
    pub fn png(&self, size_px: u32) -> Result<Vec<u8>, RenderError> {
        let (lo, hi) = self.drawn();
        let margin = ((hi[0] - lo[0]).max(hi[1] - lo[1]) / 20).max(1);
        let (lo, hi) = ([lo[0] - margin, lo[1] - margin], [hi[0] + margin, hi[1] + margin]);
        let (cols, rows) = ((hi[0] - lo[0] + 1) as f64, (hi[1] - lo[1] + 1) as f64);
        let per_cell = f64::from(size_px.max(16)) / cols.max(rows);
        let (width, height) = (((cols * per_cell).ceil() as u32).max(16), ((rows * per_cell).ceil() as u32).max(16));
        let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
        // Pixel rectangle of the cell at grid index c (north up).
        let span = |c: [i64; 2]| {
            let (x, y) = ((c[0] - lo[0]) as f64, (hi[1] - c[1]) as f64);
            let (u0, v0) = ((x * per_cell) as i64, (y * per_cell) as i64);
            let (u1, v1) = (((x + 1.0) * per_cell) as i64, ((y + 1.0) * per_cell) as i64);
            (u0, v0, u1.max(u0 + 1), v1.max(v0 + 1))
        };
        for layer in [BUILDING, STREET, FOOTPRINT, POLE, TRACK, STOP] {
            for (i, &v) in self.grid.iter().enumerate() {
                if v & layer == 0 {
                    continue;
                }
                let (u0, v0, u1, v1) = span(self.cell_at(i));
                let (cu, cv) = ((u0 + u1) / 2, (v0 + v1) / 2);
                match layer {
                    BUILDING => fill(&mut img, (u0, v0), (u1, v1), Rgb([215, 215, 215])),
                    STREET => fill(&mut img, (u0, v0), (u1, v1), Rgb([90, 90, 90])),
                    FOOTPRINT => fill(&mut img, (u0, v0), (u1, v1), Rgb([60, 90, 230])),
                    POLE => fill(&mut img, (cu - 1, cv - 1), (cu + 2, cv + 2), class_colour(class_of(v))),
                    TRACK => fill(&mut img, (cu - 1, cv - 1), (cu + 1, cv + 1), track_colour(v)),
                    _ => fill(&mut img, (cu - 3, cv - 3), (cu + 4, cv + 4), Rgb([0, 0, 0])),
                }
            }
        }
        encode_png_rgb(&img)
    }

    /// Grid indices of the first and last drawn cells on each axis (the origin if none).
    fn drawn(&self) -> ([i64; 2], [i64; 2]) {
        let mut bounds = ([i64::MAX; 2], [i64::MIN; 2]);
        for (i, _) in self.grid.iter().enumerate().filter(|(_, v)| **v != 0) {
            let c = self.cell_at(i);
            bounds = ([bounds.0[0].min(c[0]), bounds.0[1].min(c[1])], [bounds.1[0].max(c[0]), bounds.1[1].max(c[1])]);
        }
        if bounds.0[0] > bounds.1[0] { (self.origin, self.origin) } else { bounds }
    }

    /// Grid index of the cell stored at `i`.
    fn cell_at(&self, i: usize) -> [i64; 2] {
        [self.origin[0] + (i % self.size[0]) as i64, self.origin[1] + (i / self.size[0]) as i64]
    }

    /// Mark the cell under `p` with `bits`.
    fn mark(&mut self, p: [f64; 2], bits: u32) {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return;
        }
        self.cover(p, p);
        let i = self.index(p);
        self.grid[i] = merge(self.grid[i], bits);
    }

    /// Mark the cells along a segment (sampled every half cell).
    fn line(&mut self, a: [f64; 2], b: [f64; 2], bits: u32) {
        if !(a.iter().chain(&b).all(|x| x.is_finite())) {
            return;
        }
        self.cover([a[0].min(b[0]), a[1].min(b[1])], [a[0].max(b[0]), a[1].max(b[1])]);
        let n = ((b[0] - a[0]).hypot(b[1] - a[1]) * 2.0 / self.cell).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let i = self.index([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            self.grid[i] = merge(self.grid[i], bits);
        }
    }

    /// Mark every cell of an axis-aligned rectangle.
    fn rect(&mut self, lo: [f64; 2], hi: [f64; 2], bits: u32) {
        if !(lo.iter().chain(&hi).all(|x| x.is_finite())) {
            return;
        }
        self.cover(lo, hi);
        let (a, b) = (self.cell_of(lo), self.cell_of(hi));
        for r in a[1]..=b[1] {
            for c in a[0]..=b[0] {
                let i = self.offset([c, r]);
                self.grid[i] = merge(self.grid[i], bits);
            }
        }
    }

    /// Grid index (in cells of the current size) of a point.
    fn cell_of(&self, p: [f64; 2]) -> [i64; 2] {
        [(p[0] / self.cell).floor() as i64, (p[1] / self.cell).floor() as i64]
    }

    fn offset(&self, c: [i64; 2]) -> usize {
        (c[1] - self.origin[1]) as usize * self.size[0] + (c[0] - self.origin[0]) as usize
    }

    fn index(&self, p: [f64; 2]) -> usize {
        self.offset(self.cell_of(p))
    }

    /// Grow the grid (coarsening it as the budget needs) until it covers the box `lo`–`hi`.
    fn cover(&mut self, lo: [f64; 2], hi: [f64; 2]) {
        loop {
            let (a, b) = (self.cell_of(lo), self.cell_of(hi));
            let (new_lo, new_hi) = if self.grid.is_empty() {
                (a, b)
            } else {
                let end = [self.origin[0] + self.size[0] as i64 - 1, self.origin[1] + self.size[1] as i64 - 1];
                if a[0] >= self.origin[0] && a[1] >= self.origin[1] && b[0] <= end[0] && b[1] <= end[1] {
                    return;
                }
                // Grow by a quarter beyond what is needed, so a drive moving on does not regrow every cell.
                let slack = |n: usize| (n / 4).max(8) as i64;
                let (sx, sy) = (slack(self.size[0]), slack(self.size[1]));
                (
                    [
                        a[0].min(self.origin[0]) - if a[0] < self.origin[0] { sx } else { 0 },
                        a[1].min(self.origin[1]) - if a[1] < self.origin[1] { sy } else { 0 },
                    ],
                    [
                        b[0].max(end[0]) + if b[0] > end[0] { sx } else { 0 },
                        b[1].max(end[1]) + if b[1] > end[1] { sy } else { 0 },
                    ],
                )
            };
            let size = [(new_hi[0] - new_lo[0] + 1) as usize, (new_hi[1] - new_lo[1] + 1) as usize];
            if size[0].max(size[1]) > self.budget {
                self.coarsen();
                continue;
            }
            self.regrid(new_lo, size);
            return;
        }
    }

    /// Copy the cells into a grid starting at `origin` of `size` (which holds the old one).
    fn regrid(&mut self, origin: [i64; 2], size: [usize; 2]) {
        let mut grid = vec![0u32; size[0] * size[1]];
        for (i, &v) in self.grid.iter().enumerate() {
            if v != 0 {
                let c = self.cell_at(i);
                grid[(c[1] - origin[1]) as usize * size[0] + (c[0] - origin[0]) as usize] = v;
            }
        }
        (self.origin, self.size, self.grid) = (origin, size, grid);
    }

    /// Double the cell size, merging each 2 × 2 block of cells.
    fn coarsen(&mut self) {
        let half = |x: i64| x.div_euclid(2);
        let origin = [half(self.origin[0]), half(self.origin[1])];
        let end = [half(self.origin[0] + self.size[0] as i64 - 1), half(self.origin[1] + self.size[1] as i64 - 1)];
        let size = [(end[0] - origin[0] + 1) as usize, (end[1] - origin[1] + 1) as usize];
        let mut grid = vec![0u32; size[0] * size[1]];
        if !self.grid.is_empty() {
            for (i, &v) in self.grid.iter().enumerate() {
                let c = self.cell_at(i);
                let j = (half(c[1]) - origin[1]) as usize * size[0] + (half(c[0]) - origin[0]) as usize;
                grid[j] = merge(grid[j], v);
            }
        }
        self.cell *= 2.0;
        (self.origin, self.size, self.grid) = (origin, size, grid);
    }
}

/// Two cells' marks as one: every layer of either, the first pole class, the larger DG error.
fn merge(a: u32, b: u32) -> u32 {
    let layers = (a | b) & 0xFF;
    let class = if a & POLE != 0 { a } else { b } & (3 << CLASS_SHIFT);
    let error = ((a >> ERROR_SHIFT) & 0xFF).max((b >> ERROR_SHIFT) & 0xFF) << ERROR_SHIFT;
    layers | class | error
}

fn class_index(class: PoleClass) -> u32 {
    match class {
        PoleClass::StreetLight => 0,
        PoleClass::SignPost => 1,
        PoleClass::TrafficLight => 2,
        PoleClass::Tree => 3,
    }
}

fn class_of(v: u32) -> PoleClass {
    match (v >> CLASS_SHIFT) & 3 {
        0 => PoleClass::StreetLight,
        1 => PoleClass::SignPost,
        2 => PoleClass::TrafficLight,
        _ => PoleClass::Tree,
    }
}

/// The track colour of `campaign_map_png` for the cell's largest error.
fn track_colour(v: u32) -> Rgb<u8> {
    let red = f64::from((v >> ERROR_SHIFT) & 0xFF) / 255.0;
    Rgb([(255.0 * red) as u8, (200.0 * (1.0 - red)) as u8, 0])
}

/// Fill the pixels from `a` (inclusive) to `b` (exclusive), clipped.
fn fill(img: &mut RgbImage, a: (i64, i64), b: (i64, i64), colour: Rgb<u8>) {
    let (w, h) = (i64::from(img.width()), i64::from(img.height()));
    for v in a.1.max(0)..b.1.min(h) {
        for u in a.0.max(0)..b.0.min(w) {
            img.put_pixel(u as u32, v as u32, colour);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pixels of exactly `colour`: count and mean (u, v).
    fn find(png: &[u8], colour: [u8; 3]) -> (usize, f64, f64) {
        let img = image::load_from_memory(png).unwrap().to_rgb8();
        let hits: Vec<(u32, u32)> =
            img.enumerate_pixels().filter(|(_, _, p)| p.0 == colour).map(|(u, v, _)| (u, v)).collect();
        let n = hits.len().max(1) as f64;
        (
            hits.len(),
            hits.iter().map(|h| f64::from(h.0)).sum::<f64>() / n,
            hits.iter().map(|h| f64::from(h.1)).sum::<f64>() / n,
        )
    }

    #[test]
    fn marks_land_north_up_at_scale_after_the_cells_have_doubled() {
        let mut map = StreamedMap::new(256);
        let (o, e) = ([564_000.0, 5_930_000.0], 5_000.0);
        map.mark(o, POLE | (class_index(PoleClass::TrafficLight) << CLASS_SHIFT));
        // A traffic light (black), and a track point with a 1 m DG error (red) 5 km east and 2.5 km north.
        map.mark([o[0] + e, o[1] + e / 2.0], TRACK | (255 << ERROR_SHIFT));
        // 5 km over at most 256 cells: at least 5000 / 256 = 19.5 m, from 0.25 m by doubling: 32 m.
        assert_eq!(map.cell_size(), 32.0);
        assert!(map.grid_size()[0] <= 256 && map.grid_size()[1] <= 256, "{:?}", map.grid_size());
        let png = map.png(800).unwrap();
        let (black, bu, bv) = find(&png, [0, 0, 0]);
        let (red, ru, rv) = find(&png, [255, 0, 0]);
        assert!(black > 0 && red > 0, "{black} black, {red} red pixels");
        // The longer side (east: 5 km = 157 cells, plus 5 % margins) spans the 800 pixels.
        let cols = (e / 32.0).floor() + 1.0 + 2.0 * ((e / 32.0).floor() / 20.0).floor();
        let px_per_m = 800.0 / (cols * map.cell_size());
        // East is right and north is up, at the map's scale to within a cell.
        let tolerance = 32.0 * px_per_m + 1.0;
        assert!(((ru - bu) - e * px_per_m).abs() < tolerance, "du {} px", ru - bu);
        assert!(((bv - rv) - e / 2.0 * px_per_m).abs() < tolerance, "dv {} px", bv - rv);
    }

    #[test]
    fn a_long_drive_keeps_the_grid_within_budget_and_the_first_marks() {
        let mut map = StreamedMap::new(128);
        // 100 km of zig-zag streets, drawn a segment at a time as legs would come.
        let mut p = [0.0, 0.0];
        for k in 0..200 {
            let q = if k % 2 == 0 { [p[0] + 500.0, p[1]] } else { [p[0], p[1] + 500.0] };
            map.line(p, q, STREET);
            p = q;
            assert!(map.grid_size()[0] <= 128 && map.grid_size()[1] <= 128, "{:?}", map.grid_size());
        }
        map.mark([10.0, 10.0], POLE | (class_index(PoleClass::Tree) << CLASS_SHIFT));
        // 50 km × 50 km over 128 cells: cells of 512 m; the grid holds ≤ 128² words.
        assert!(
            map.cell_size() >= 50_000.0 / 128.0 && map.cell_size() <= 2.0 * 50_000.0 / 128.0,
            "{}",
            map.cell_size()
        );
        assert!(map.grid.len() <= 128 * 128);
        // The tree shares a cell with a street; merging kept its class (and the street).
        let i = map.index([10.0, 10.0]);
        assert_eq!(class_of(map.grid[i]), PoleClass::Tree);
        assert!(map.grid[i] & STREET != 0 && map.grid[i] & POLE != 0);
        assert_eq!(merge(TRACK | (9 << ERROR_SHIFT), TRACK | (200 << ERROR_SHIFT)) >> ERROR_SHIFT, 200);
    }
}
