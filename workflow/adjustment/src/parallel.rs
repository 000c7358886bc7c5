//! Data-parallel maps over observations and nodes, sequential or on rayon's pool as the caller's `Par` says.

use faer::Par;
use rayon::prelude::*;

/// `(0..n).map(f).collect()`, on rayon when `par` allows more than one thread.
pub(crate) fn map<T: Send>(par: Par, n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    if par.degree() > 1 { (0..n).into_par_iter().map(f).collect() } else { (0..n).map(f).collect() }
}

/// `(0..n).map(f).sum()`, on rayon when `par` allows more than one thread.
pub(crate) fn sum(par: Par, n: usize, f: impl Fn(usize) -> f64 + Sync + Send) -> f64 {
    if par.degree() > 1 { (0..n).into_par_iter().map(f).sum() } else { (0..n).map(f).sum() }
}
