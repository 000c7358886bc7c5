//! A uniform planar grid over the world: which streets and objects may be near a cell.

use super::polyline::P2;

/// A uniform grid of cells each holding a list of items.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid<T> {
    /// South-west corner of the grid, map easting/northing.
    pub min: P2,
    /// Cell size, metres.
    pub cell: f64,
    /// Cells along easting.
    pub nx: usize,
    /// Cells along northing.
    pub ny: usize,
    cells: Vec<Vec<T>>,
}

impl<T: Clone> Grid<T> {
    /// An empty grid covering `[min, max]`.
    pub fn new(min: P2, max: P2, cell: f64) -> Self {
        let nx = (((max[0] - min[0]) / cell).ceil() as usize).max(1);
        let ny = (((max[1] - min[1]) / cell).ceil() as usize).max(1);
        Self { min, cell, nx, ny, cells: vec![Vec::new(); nx * ny] }
    }

    /// The cell holding a point, if inside the grid.
    pub fn cell_of(&self, p: P2) -> Option<(usize, usize)> {
        let (fx, fy) = ((p[0] - self.min[0]) / self.cell, (p[1] - self.min[1]) / self.cell);
        let inside = fx >= 0.0 && fy >= 0.0 && fx < self.nx as f64 && fy < self.ny as f64;
        inside.then_some((fx as usize, fy as usize))
    }

    /// Items of a cell.
    pub fn items(&self, ix: usize, iy: usize) -> &[T] {
        &self.cells[iy * self.nx + ix]
    }

    /// Items of the cell holding `p` (empty outside the grid).
    pub fn at(&self, p: P2) -> &[T] {
        self.cell_of(p).map_or(&[], |(ix, iy)| self.items(ix, iy))
    }

    /// Insert an item into every cell overlapping the box `[lo, hi]`.
    pub fn insert_box(&mut self, lo: P2, hi: P2, item: T) {
        let clamp = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1);
        let (x0, x1) =
            (clamp((lo[0] - self.min[0]) / self.cell, self.nx), clamp((hi[0] - self.min[0]) / self.cell, self.nx));
        let (y0, y1) =
            (clamp((lo[1] - self.min[1]) / self.cell, self.ny), clamp((hi[1] - self.min[1]) / self.cell, self.ny));
        for iy in y0..=y1 {
            for ix in x0..=x1 {
                self.cells[iy * self.nx + ix].push(item.clone());
            }
        }
    }

    /// Insert an item into every cell overlapping an oriented rectangle (separating-axis test per cell).
    pub fn insert_rect(&mut self, center: P2, axis: P2, half: [f64; 2], item: T) {
        let n = [-axis[1], axis[0]];
        let r = half[0].hypot(half[1]);
        let clamp = |v: f64, k: usize| (v.max(0.0) as usize).min(k - 1);
        let (x0, x1) = (
            clamp((center[0] - r - self.min[0]) / self.cell, self.nx),
            clamp((center[0] + r - self.min[0]) / self.cell, self.nx),
        );
        let (y0, y1) = (
            clamp((center[1] - r - self.min[1]) / self.cell, self.ny),
            clamp((center[1] + r - self.min[1]) / self.cell, self.ny),
        );
        // A cell square's half extent projected on a unit axis u is (|u_x| + |u_y|) · cell / 2.
        let reach = |u: P2| (u[0].abs() + u[1].abs()) * self.cell / 2.0;
        for iy in y0..=y1 {
            for ix in x0..=x1 {
                let c = [self.min[0] + (ix as f64 + 0.5) * self.cell, self.min[1] + (iy as f64 + 0.5) * self.cell];
                let (dx, dy) = (c[0] - center[0], c[1] - center[1]);
                let apart = (dx * axis[0] + dy * axis[1]).abs() > half[0] + reach(axis)
                    || (dx * n[0] + dy * n[1]).abs() > half[1] + reach(n);
                if !apart {
                    self.cells[iy * self.nx + ix].push(item.clone());
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangles_are_listed_in_every_cell_they_touch() {
        let mut grid: Grid<u32> = Grid::new([0.0, 0.0], [100.0, 100.0], 8.0);
        let rects: Vec<(P2, P2, [f64; 2])> = (0..40)
            .map(|i| {
                let f = f64::from(i);
                let a = f * 0.7;
                (
                    [10.0 + (f * 7.3) % 80.0, 10.0 + (f * 13.1) % 80.0],
                    [a.cos(), a.sin()],
                    [1.0 + f % 9.0, 0.8 + f % 5.0],
                )
            })
            .collect();
        for (i, (c, a, h)) in rects.iter().enumerate() {
            grid.insert_rect(*c, *a, *h, i as u32);
        }
        for (i, (c, a, h)) in rects.iter().enumerate() {
            let n = [-a[1], a[0]];
            for u in -10..=10 {
                for v in -10..=10 {
                    let (su, sv) = (h[0] * f64::from(u) / 10.0, h[1] * f64::from(v) / 10.0);
                    let p = [c[0] + su * a[0] + sv * n[0], c[1] + su * a[1] + sv * n[1]];
                    assert!(grid.at(p).contains(&(i as u32)), "rect {i} missing at {p:?}");
                }
            }
        }
        // And not wildly conservative: a rectangle far smaller than a cell sits in at most 4 cells.
        let listed = (0..grid.ny)
            .flat_map(|y| (0..grid.nx).map(move |x| (x, y)))
            .filter(|&(x, y)| grid.items(x, y).contains(&0))
            .count();
        assert!(listed <= 4, "{listed}");
    }
}
