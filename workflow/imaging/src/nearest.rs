//! Brute-force nearest-neighbour descriptor matching shared by AKAZE (Hamming) and KAZE (Euclidean):
//! Lowe's ratio test on the best and second-best distance, optionally mutual (A's nearest in B is also B's
//! nearest in A).
//!
//! One pass over the |A| × |B| distances serves both directions: each distance is computed once, and the
//! search keeps, per row of A, the best and second-best distance and, per column of B, the best row. B is
//! packed once per call into blocks of [`LANES`] descriptors; a tile of [`ROWS`] descriptors of A against
//! one block is computed by a kernel written on fixed-size arrays, so that LLVM vectorises it. A's rows are
//! split into chunks, in parallel; each chunk walks B in tiles that stay in cache.
//!
//! The results are those of the plain search, bit for bit: the distances are the same sums in the same
//! order (the L2 kernel vectorises across B's descriptors, not along a descriptor, so each sum keeps its
//! order), ties go to the lowest index of B (and, from B's side, of A), and the Hamming and squared L2
//! distances are symmetric, so B's nearest in A comes from the same distances.

use rayon::prelude::*;

/// Descriptors of B in a block, computed together.
pub(crate) const LANES: usize = 8;

/// Descriptors of A in a tile, computed together against one block of B.
pub(crate) const ROWS: usize = 4;

/// Rows of A in a chunk, the unit of parallel work.
const CHUNK: usize = 64;

/// Bytes of B's blocks that a chunk's rows go through before moving on (a tile of B; fits L1 beside A's chunk).
const TILE_BYTES: usize = 32 * 1024;

/// Words of an AKAZE descriptor.
const WORDS: usize = 8;

/// Floats of a SURF-like descriptor.
const DIMS: usize = 64;

/// A block of B's binary descriptors: [`LANES`] descriptors, zero past B's end.
pub(crate) type HammingBlock = [[u64; WORDS]; LANES];

/// A block of B's float descriptors, dimension-major: `block[k][lane]` is dimension k of descriptor `lane`.
pub(crate) type L2Block = [[f32; LANES]; DIMS];

/// B's binary descriptors in blocks of [`LANES`], the last one padded with zeros.
pub(crate) fn pack_hamming(b: &[[u64; WORDS]]) -> Vec<HammingBlock> {
    b.chunks(LANES).map(|chunk| std::array::from_fn(|lane| chunk.get(lane).copied().unwrap_or([0; WORDS]))).collect()
}

/// B's float descriptors in dimension-major blocks of [`LANES`], the last one padded with zeros.
pub(crate) fn pack_l2(b: &[[f32; DIMS]]) -> Vec<L2Block> {
    b.chunks(LANES)
        .map(|chunk| std::array::from_fn(|k| std::array::from_fn(|lane| chunk.get(lane).map_or(0.0, |d| d[k]))))
        .collect()
}

/// Hamming distances of [`ROWS`] descriptors to a block: `out[r][lane]`, the popcount of the XOR, word by word.
pub(crate) fn hamming_tile(a: &[[u64; WORDS]; ROWS], block: &HammingBlock, out: &mut [[u32; LANES]; ROWS]) {
    for (row, d) in out.iter_mut().zip(a) {
        for (h, e) in row.iter_mut().zip(block) {
            *h = d.iter().zip(e).map(|(x, y)| (x ^ y).count_ones()).sum();
        }
    }
}

/// Squared L2 distances of [`ROWS`] descriptors to a block: `out[r][lane]` = Σ_k (a_k − b_k)², summed in k
/// order per lane (the plain sum's order, so the same bits), [`LANES`] lanes at a time.
pub(crate) fn l2_tile(a: &[[f32; DIMS]; ROWS], block: &L2Block, out: &mut [[f32; LANES]; ROWS]) {
    let mut acc = [[0.0f32; LANES]; ROWS];
    for (k, b) in block.iter().enumerate() {
        for (sum, d) in acc.iter_mut().zip(a) {
            let x = d[k];
            for lane in 0..LANES {
                let diff = x - b[lane];
                sum[lane] += diff * diff;
            }
        }
    }
    *out = acc;
}

/// A row's nearest in B so far: best and second-best distance, and the best's index (`usize::MAX`: none).
#[derive(Clone, Copy, Debug)]
struct Nearest<T> {
    best: T,
    second: T,
    j: usize,
}

/// For each descriptor of `a`, its nearest among the `nb` descriptors packed in `blocks` when
/// `passes(best, second)` holds (and, if `mutual`, `a[i]` is also the nearest of `b[j]` in `a`):
/// `(i, j, best distance)`, by increasing i. `tile` fills the distances of [`ROWS`] descriptors of A to a
/// block; `worst` is above every distance (a distance not below it, or unordered, is never a nearest).
pub(crate) fn match_blocked<D, B, T>(
    a: &[D],
    blocks: &[B],
    nb: usize,
    tile: impl Fn(&[D; ROWS], &B, &mut [[T; LANES]; ROWS]) + Sync,
    passes: impl Fn(T, T) -> bool + Sync,
    mutual: bool,
    worst: T,
) -> Vec<(usize, usize, T)>
where
    D: Copy + Sync,
    B: Sync,
    T: PartialOrd + Copy + Default + Send + Sync,
{
    if a.is_empty() || nb == 0 {
        return Vec::new();
    }
    let tile_blocks = (TILE_BYTES / size_of::<B>().max(1)).max(1);
    let mut rows = vec![Nearest { best: worst, second: worst, j: usize::MAX }; a.len()];
    // Per column of B (padded to whole blocks), its best distance and row so far; rows reach a column in
    // increasing order within a fold, so the first of equal distances stays; folds merge by (distance, row).
    let padded = blocks.len() * LANES;
    let columns = rows
        .par_chunks_mut(CHUNK)
        .enumerate()
        .fold(
            || if mutual { Columns::new(padded, worst) } else { Columns::new(0, worst) },
            |mut columns, (c, out)| {
                let first = c * CHUNK;
                let chunk = &a[first..first + out.len()];
                let search = Search { blocks, nb, tile_blocks, tile: &tile };
                if mutual {
                    search.chunk::<true, _, _>(chunk, first, out, &mut columns);
                } else {
                    search.chunk::<false, _, _>(chunk, first, out, &mut columns);
                }
                columns
            },
        )
        .reduce(|| Columns::new(0, worst), Columns::merge);
    rows.into_iter()
        .enumerate()
        .filter_map(|(i, n)| {
            let ok = n.j != usize::MAX && passes(n.best, n.second) && (!mutual || columns.row.get(n.j) == Some(&i));
            ok.then_some((i, n.j, n.best))
        })
        .collect()
}

/// Per column of B, the best distance from A's rows so far and its row (`usize::MAX`: none); empty when the
/// search is not mutual.
#[derive(Debug)]
struct Columns<T> {
    best: Vec<T>,
    row: Vec<usize>,
}

impl<T: PartialOrd + Copy> Columns<T> {
    fn new(n: usize, worst: T) -> Self {
        Self { best: vec![worst; n], row: vec![usize::MAX; n] }
    }

    /// The lower distance per column, of equal ones the lower row (an empty side: the other).
    fn merge(mut self, other: Self) -> Self {
        if self.row.is_empty() {
            return other;
        }
        for ((b, r), (&ob, &or)) in self.best.iter_mut().zip(&mut self.row).zip(other.best.iter().zip(&other.row)) {
            if or != usize::MAX && (*r == usize::MAX || ob < *b || (ob == *b && or < *r)) {
                (*b, *r) = (ob, or);
            }
        }
        self
    }
}

/// B packed in blocks, its length, the blocks of a tile of B, and the tile kernel.
struct Search<'a, B, K> {
    blocks: &'a [B],
    nb: usize,
    tile_blocks: usize,
    tile: &'a K,
}

impl<B, K> Search<'_, B, K> {
    /// One chunk of A (rows `first..first + chunk.len()`) against all of B, tile by tile of B: updates the
    /// rows' nearest in `out` and, if `MUTUAL`, the columns' best rows.
    fn chunk<const MUTUAL: bool, D, T>(
        &self,
        chunk: &[D],
        first: usize,
        out: &mut [Nearest<T>],
        columns: &mut Columns<T>,
    ) where
        D: Copy,
        T: PartialOrd + Copy + Default,
        K: Fn(&[D; ROWS], &B, &mut [[T; LANES]; ROWS]),
    {
        let Some(&last) = chunk.last() else { return };
        // A's rows by groups of ROWS, the last group padded with the last row (its distances are not read).
        let groups: Vec<[D; ROWS]> =
            chunk.chunks(ROWS).map(|g| std::array::from_fn(|r| g.get(r).copied().unwrap_or(last))).collect();
        let mut dist = [[T::default(); LANES]; ROWS];
        for (t, tile_of_b) in self.blocks.chunks(self.tile_blocks).enumerate() {
            for (g, rows_of_a) in groups.iter().enumerate() {
                let (r0, valid_rows) = (g * ROWS, (out.len() - g * ROWS).min(ROWS));
                for (k, block) in tile_of_b.iter().enumerate() {
                    let j0 = (t * self.tile_blocks + k) * LANES;
                    let valid_lanes = self.nb.saturating_sub(j0).min(LANES);
                    (self.tile)(rows_of_a, block, &mut dist);
                    for (r, (row, ds)) in out[r0..r0 + valid_rows].iter_mut().zip(&dist).enumerate() {
                        // Most tiles change nothing: test all lanes at once, without branches, first.
                        if ds.iter().fold(false, |hit, &h| hit | (h < row.second)) {
                            for (l, &h) in ds[..valid_lanes].iter().enumerate() {
                                if h < row.best {
                                    *row = Nearest { best: h, second: row.best, j: j0 + l };
                                } else if h < row.second {
                                    row.second = h;
                                }
                            }
                        }
                        if MUTUAL {
                            // Padded columns (past B's end) may be updated too; they are never read.
                            let bests = &mut columns.best[j0..j0 + LANES];
                            if ds.iter().zip(bests.iter()).fold(false, |hit, (&h, &c)| hit | (h < c)) {
                                for (l, (&h, c)) in ds.iter().zip(bests).enumerate() {
                                    if h < *c {
                                        *c = h;
                                        columns.row[j0 + l] = first + r0 + r;
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
