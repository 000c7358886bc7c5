//! The block sparsity pattern of the normal matrix and its upper-triangular compressed-column layout.
//!
//! Parameter blocks are the node corrections (6 columns each), then the other unknowns in the widths given:
//! tie points (3 each), cadastre objects' nuisance offsets (2 each), aerial frame sets' height biases (1
//! each). The pattern is fixed once (chain links + the block pairs every observation touches), so the symbolic
//! factorisation is reused for every Gauss–Newton iteration; values are accumulated straight into the
//! compressed-column value array.

use nalgebra::Matrix3x6;

/// Width and first parameter of each block, and the compressed-column structure of the upper triangle.
#[derive(Clone, Debug)]
pub(crate) struct Pattern {
    /// First parameter index of each block (plus the total at the end).
    pub offsets: Vec<usize>,
    blk_ptr: Vec<usize>,
    blk_rows: Vec<usize>,
    blk_row_off: Vec<usize>,
    /// Compressed-column pointers (length n + 1).
    pub col_ptr: Vec<usize>,
    /// Row indices (sorted within each column; the diagonal is each column's last entry).
    pub row_idx: Vec<usize>,
}

impl Pattern {
    /// The pattern for `n_nodes` node blocks followed by blocks of the given `widths`, and the given coupled
    /// block pairs (each pair in any order; the diagonal and the chain links are always present).
    pub fn new(n_nodes: usize, widths: &[usize], mut pairs: Vec<(usize, usize)>) -> Self {
        let n_blocks = n_nodes + widths.len();
        let mut offsets = Vec::with_capacity(n_blocks + 1);
        let mut acc = 0;
        for width in std::iter::repeat_n(6, n_nodes).chain(widths.iter().copied()) {
            offsets.push(acc);
            acc += width;
        }
        offsets.push(acc);
        pairs.extend((0..n_blocks).map(|b| (b, b)));
        pairs.extend((1..n_nodes).map(|b| (b - 1, b)));
        // Upper triangle, grouped by column block: (column, row) with row ≤ column.
        let mut upper: Vec<(usize, usize)> = pairs.into_iter().map(|(a, b)| (a.max(b), a.min(b))).collect();
        upper.sort_unstable();
        upper.dedup();
        let mut blk_ptr = vec![0; n_blocks + 1];
        for &(col, _) in &upper {
            blk_ptr[col + 1] += 1;
        }
        for b in 0..n_blocks {
            blk_ptr[b + 1] += blk_ptr[b];
        }
        let blk_rows: Vec<usize> = upper.iter().map(|&(_, row)| row).collect();
        let mut blk_row_off = vec![0; blk_rows.len()];
        let mut col_ptr = Vec::with_capacity(acc + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for bj in 0..n_blocks {
            let mut off = 0;
            for k in blk_ptr[bj]..blk_ptr[bj + 1] {
                blk_row_off[k] = off;
                off += offsets[blk_rows[k] + 1] - offsets[blk_rows[k]];
            }
            for c in 0..offsets[bj + 1] - offsets[bj] {
                for &bi in &blk_rows[blk_ptr[bj]..blk_ptr[bj + 1]] {
                    let last = if bi == bj { offsets[bi] + c + 1 } else { offsets[bi + 1] };
                    row_idx.extend(offsets[bi]..last);
                }
                col_ptr.push(row_idx.len());
            }
        }
        Self { offsets, blk_ptr, blk_rows, blk_row_off, col_ptr, row_idx }
    }

    /// The block-level upper-triangular pattern: (column pointers, row blocks) over blocks.
    pub fn blocks(&self) -> (&[usize], &[usize]) {
        (&self.blk_ptr, &self.blk_rows)
    }

    /// Number of parameters.
    pub fn dim(&self) -> usize {
        self.col_ptr.len() - 1
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    fn width(&self, b: usize) -> usize {
        self.offsets[b + 1] - self.offsets[b]
    }

    /// Index into the value array of entry (row `r` of block `bi`, column `c` of block `bj`), bi ≤ bj.
    fn position(&self, bi: usize, bj: usize, r: usize, c: usize) -> usize {
        let range = self.blk_ptr[bj]..self.blk_ptr[bj + 1];
        let k = range.start + self.blk_rows[range].partition_point(|&x| x < bi);
        self.col_ptr[self.offsets[bj] + c] + self.blk_row_off[k] + r
    }

    /// Index of the diagonal entry of parameter `i`.
    pub fn diagonal(&self, i: usize) -> usize {
        self.col_ptr[i + 1] - 1
    }

    /// Add Jaᵀ Jb into the (block a, block b) part of the upper triangle (using only the block widths'
    /// leading columns of each Jacobian).
    pub fn add_product(&self, values: &mut [f64], a: usize, ja: &Matrix3x6<f64>, b: usize, jb: &Matrix3x6<f64>) {
        let (a, ja, b, jb) = if a <= b { (a, ja, b, jb) } else { (b, jb, a, ja) };
        let (wa, wb) = (self.width(a), self.width(b));
        for c in 0..wb {
            let base = self.position(a, b, 0, c);
            let rows = if a == b { c + 1 } else { wa };
            for r in 0..rows {
                values[base + r] += ja.column(r).dot(&jb.column(c));
            }
        }
    }

    /// Add `v` to the (i, j) entries of the diagonal of the block pair (a, b), a ≤ b, both node blocks:
    /// the chain terms' diagonal couplings.
    pub fn add_diagonal(&self, values: &mut [f64], a: usize, b: usize, v: &nalgebra::Vector6<f64>) {
        for c in 0..6 {
            values[self.position(a, b, c, c)] += v[c];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_holds_every_upper_entry_once_with_the_diagonal_last() {
        let p = Pattern::new(3, &[3], vec![(3, 0), (2, 3)]);
        assert_eq!(p.dim(), 21);
        for col in 0..p.dim() {
            let rows = &p.row_idx[p.col_ptr[col]..p.col_ptr[col + 1]];
            assert!(rows.windows(2).all(|w| w[0] < w[1]));
            assert_eq!(*rows.last().unwrap(), col);
        }
        // Column 18 (point, first) holds node 0 rows, node 2 rows and its own first row.
        let rows = &p.row_idx[p.col_ptr[18]..p.col_ptr[19]];
        assert_eq!(rows.len(), 6 + 6 + 1);
        let mut v = vec![0.0; p.nnz()];
        let j = Matrix3x6::from_fn(|r, c| (r * 6 + c) as f64);
        p.add_product(&mut v, 3, &j, 0, &j);
        // Entry (node 0 row 4, point column 1) = Σ_k J[k,4] J[k,1].
        let idx = p.col_ptr[19] + 4;
        assert_eq!(v[idx], j.column(4).dot(&j.column(1)));
    }
}
