//! A uniform grid over the cadastre for radius queries.

use std::collections::HashMap;

use plumbline_campaign::CadastreFeature;

/// Cell size, metres.
const CELL_M: f64 = 10.0;

/// Cadastre features bucketed by cell.
#[derive(Debug)]
pub(super) struct Grid<'a> {
    features: &'a [CadastreFeature],
    cells: HashMap<(i64, i64), Vec<usize>>,
    /// The largest accuracy (σ) among the indexed features, metres.
    pub max_accuracy_m: f64,
}

fn cell(x: f64, y: f64) -> (i64, i64) {
    ((x / CELL_M).floor() as i64, (y / CELL_M).floor() as i64)
}

impl<'a> Grid<'a> {
    /// Index the finite features.
    pub fn new(features: &'a [CadastreFeature]) -> Self {
        let mut cells: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        let mut max_accuracy_m: f64 = 0.0;
        for (i, f) in features.iter().enumerate().filter(|(_, f)| f.easting.is_finite() && f.northing.is_finite()) {
            cells.entry(cell(f.easting, f.northing)).or_default().push(i);
            if f.accuracy_m.is_finite() {
                max_accuracy_m = max_accuracy_m.max(f.accuracy_m);
            }
        }
        Self { features, cells, max_accuracy_m }
    }

    /// Features within `radius` of `p`, with their distances, nearest first.
    pub fn within(&self, p: [f64; 2], radius: f64) -> Vec<(usize, f64)> {
        let (lo, hi) = (cell(p[0] - radius, p[1] - radius), cell(p[0] + radius, p[1] + radius));
        let mut out = Vec::new();
        for cx in lo.0..=hi.0 {
            for cy in lo.1..=hi.1 {
                for &i in self.cells.get(&(cx, cy)).map_or(&[][..], Vec::as_slice) {
                    let f = &self.features[i];
                    let d = (f.easting - p[0]).hypot(f.northing - p[1]);
                    if d <= radius {
                        out.push((i, d));
                    }
                }
            }
        }
        out.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        out
    }
}
