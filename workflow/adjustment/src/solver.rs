//! Sparse Cholesky of the normal matrix with faer: AMD ordering (on the block graph) and symbolic analysis
//! once, numeric factorisation per iteration, and the selected inverse (Takahashi recurrences on the
//! factor's pattern) for posterior covariances and redundancy numbers.

use std::time::{Duration, Instant};

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::linalg::{SupernodalThreshold, amd};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use crate::pattern::Pattern;

/// Failures of the linear algebra.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolverError {
    /// faer could not analyse or allocate.
    #[error("sparse Cholesky {stage} failed: {message}")]
    Faer { stage: &'static str, message: String },
    /// The normal matrix is not positive definite (an unobservable parameter).
    #[error("normal matrix is not positive definite ({message})")]
    NotPositiveDefinite { message: String },
}

/// Wall-clock time spent in each linear-algebra stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolverTimings {
    /// Ordering + symbolic factorisation (once).
    pub symbolic: Duration,
    /// All numeric factorisations.
    pub numeric: Duration,
    /// All triangular solves.
    pub solve: Duration,
    /// The selected inversions.
    pub selected_inverse: Duration,
    /// Number of numeric factorisations.
    pub factorizations: usize,
}

/// A reusable factorisation of matrices with one fixed pattern.
pub(crate) struct Factorizer {
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
    par: Par,
    pub timings: SolverTimings,
}

fn faer_err(stage: &'static str) -> impl Fn(faer::sparse::FaerError) -> SolverError {
    move |e| SolverError::Faer { stage, message: format!("{e:?}") }
}

impl Factorizer {
    /// AMD ordering and simplicial symbolic factorisation of the pattern (upper triangle).
    pub fn new(pattern: &Pattern, par: Par) -> Result<Self, SolverError> {
        let start = Instant::now();
        let n = pattern.dim();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        // Simplicial: its factor's pattern is what the selected inversion walks.
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        };
        let (fwd, inv) = block_amd(pattern)?;
        let ordering = SymmetricOrdering::Custom(PermRef::new_checked(&fwd, &inv, n));
        let symbolic =
            factorize_symbolic_cholesky(sym, Side::Upper, ordering, params).map_err(faer_err("symbolic analysis"))?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, par),
        ]);
        let mem = MemBuffer::try_new(req)
            .map_err(|_| SolverError::Faer { stage: "scratch allocation", message: "out of memory".into() })?;
        let l_values = vec![0.0; symbolic.len_val()];
        let timings = SolverTimings { symbolic: start.elapsed(), ..SolverTimings::default() };
        Ok(Self { symbolic, l_values, mem, par, timings })
    }

    /// Numeric factorisation of the matrix with the pattern's structure and these values.
    pub fn factor(&mut self, pattern: &Pattern, values: &[f64]) -> Result<(), SolverError> {
        let start = Instant::now();
        let n = pattern.dim();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        let a = SparseColMatRef::new(sym, values);
        let stack = MemStack::new(&mut self.mem);
        let result = self.symbolic.factorize_numeric_llt(
            &mut self.l_values,
            a,
            Side::Upper,
            LltRegularization::default(),
            self.par,
            stack,
            Default::default(),
        );
        self.timings.numeric += start.elapsed();
        self.timings.factorizations += 1;
        result.map(|_| ()).map_err(|e| SolverError::NotPositiveDefinite { message: format!("{e:?}") })
    }

    /// Solve N x = rhs in place with the last factorisation.
    pub fn solve(&mut self, rhs: &mut [f64]) {
        let start = Instant::now();
        let n = rhs.len();
        let llt = LltRef::new(&self.symbolic, &self.l_values);
        let stack = MemStack::new(&mut self.mem);
        llt.solve_in_place_with_conj(Conj::No, MatMut::from_column_major_slice_mut(rhs, n, 1), self.par, stack);
        self.timings.solve += start.elapsed();
    }

    /// Entries of N⁻¹ on the pattern of the factor (which holds every entry of N), by the Takahashi
    /// recurrences on the simplicial factor P N Pᵀ = L Lᵀ, columns right to left:
    /// Z_ij = −(1/L_jj) Σ_k L_kj Z_ik (i > j), Z_jj = 1/L_jj² − (1/L_jj) Σ_k L_kj Z_kj.
    pub fn selected_inverse(&mut self) -> Result<SelectedInverse, SolverError> {
        let start = Instant::now();
        let SymbolicCholeskyRaw::Simplicial(simp) = self.symbolic.raw() else {
            return Err(SolverError::Faer { stage: "selected inversion", message: "factor is not simplicial".into() });
        };
        let (col_ptr, row_idx) = (simp.col_ptr().to_vec(), simp.row_idx().to_vec());
        let perm_inv = match self.symbolic.perm() {
            Some(p) => p.arrays().1.to_vec(),
            None => (0..simp.nrows()).collect(),
        };
        let mut out = SelectedInverse { col_ptr, row_idx, z: vec![0.0; self.l_values.len()], perm_inv };
        out.fill(&self.l_values);
        self.timings.selected_inverse += start.elapsed();
        Ok(out)
    }
}

/// AMD on the block graph (one vertex per node or point), expanded to the parameters: the same fill as
/// scalar AMD on this block-structured matrix for a fraction of the ordering time.
fn block_amd(pattern: &Pattern) -> Result<(Vec<usize>, Vec<usize>), SolverError> {
    let (blk_ptr, blk_rows) = pattern.blocks();
    let nb = blk_ptr.len() - 1;
    let graph = SymbolicSparseColMatRef::new_checked(nb, nb, blk_ptr, None, blk_rows);
    let (mut perm, mut perm_inv) = (vec![0usize; nb], vec![0usize; nb]);
    let mut mem = MemBuffer::try_new(amd::order_scratch::<usize>(nb, blk_rows.len()))
        .map_err(|_| SolverError::Faer { stage: "ordering scratch", message: "out of memory".into() })?;
    amd::order(&mut perm, &mut perm_inv, graph, amd::Control::default(), MemStack::new(&mut mem))
        .map_err(faer_err("AMD ordering"))?;
    let mut fwd = Vec::with_capacity(pattern.dim());
    for b in perm {
        fwd.extend(pattern.offsets[b]..pattern.offsets[b + 1]);
    }
    let mut inv = vec![0usize; fwd.len()];
    for (new, old) in fwd.iter().enumerate() {
        inv[*old] = new;
    }
    Ok((fwd, inv))
}

/// Entries of the inverse normal matrix (the cofactor matrix Q_xx) on the factor's pattern.
#[derive(Clone, Debug)]
pub(crate) struct SelectedInverse {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    z: Vec<f64>,
    perm_inv: Vec<usize>,
}

impl SelectedInverse {
    fn lookup(&self, i: usize, j: usize) -> f64 {
        let (r, c) = if i >= j { (i, j) } else { (j, i) };
        let range = self.col_ptr[c]..self.col_ptr[c + 1];
        match self.row_idx[range.clone()].binary_search(&r) {
            Ok(k) => self.z[range.start + k],
            Err(_) => f64::NAN,
        }
    }

    fn fill(&mut self, l: &[f64]) {
        let n = self.col_ptr.len() - 1;
        for j in (0..n).rev() {
            let (s, e) = (self.col_ptr[j], self.col_ptr[j + 1]);
            let inv_d = 1.0 / l[s];
            for p in s + 1..e {
                let i = self.row_idx[p];
                let sum: f64 = (s + 1..e).map(|q| l[q] * self.lookup(i, self.row_idx[q])).sum();
                self.z[p] = -inv_d * sum;
            }
            let sum: f64 = (s + 1..e).map(|q| l[q] * self.z[q]).sum();
            self.z[s] = inv_d * inv_d - inv_d * sum;
        }
    }

    /// (N⁻¹)_ij for original parameter indices; NaN if the entry is outside the factor's pattern.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.lookup(self.perm_inv[i], self.perm_inv[j])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, Matrix3x6};
    use rand::{RngExt, SeedableRng};

    #[test]
    fn solve_and_selected_inverse_match_dense_linear_algebra() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let pattern = Pattern::new(5, &[3, 2], vec![(5, 0), (5, 4), (6, 2), (1, 3)]);
        let n = pattern.dim();
        let mut values = vec![0.0; pattern.nnz()];
        let pairs = [(0, 0), (1, 1), (2, 2), (3, 3), (4, 4), (5, 5), (6, 6), (0, 1), (1, 2), (2, 3), (3, 4)];
        let more = [(5, 0), (5, 4), (6, 2), (1, 3), (0, 5), (4, 5)];
        for &(a, b) in pairs.iter().chain(more.iter()) {
            let ja = Matrix3x6::from_fn(|_, _| rng.random::<f64>() - 0.5);
            let jb = Matrix3x6::from_fn(|_, _| rng.random::<f64>() - 0.5);
            pattern.add_product(&mut values, a, &ja, a, &ja);
            pattern.add_product(&mut values, b, &jb, b, &jb);
            pattern.add_product(&mut values, a, &ja, b, &jb);
        }
        for i in 0..n {
            values[pattern.diagonal(i)] += 1.0;
        }
        let mut dense = DMatrix::zeros(n, n);
        for c in 0..n {
            for k in pattern.col_ptr[c]..pattern.col_ptr[c + 1] {
                dense[(pattern.row_idx[k], c)] = values[k];
                dense[(c, pattern.row_idx[k])] = values[k];
            }
        }
        let mut f = Factorizer::new(&pattern, Par::Seq).unwrap();
        f.factor(&pattern, &values).unwrap();
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut x = rhs.clone();
        f.solve(&mut x);
        let residual = &dense * nalgebra::DVector::from_vec(x) - nalgebra::DVector::from_vec(rhs);
        assert!(residual.norm() < 1e-10, "{residual}");
        let inv = dense.try_inverse().unwrap();
        let sel = f.selected_inverse().unwrap();
        for c in 0..n {
            for k in pattern.col_ptr[c]..pattern.col_ptr[c + 1] {
                let r = pattern.row_idx[k];
                assert!((sel.get(r, c) - inv[(r, c)]).abs() < 1e-9, "({r},{c})");
            }
        }
    }
}
