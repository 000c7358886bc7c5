//! Normal equations: linearise every term at the current estimate and accumulate Jᵀ W J (upper triangle,
//! compressed-column) and Jᵀ W e, with Huber IRLS weights on the observations; and the objective.

use nalgebra::{Matrix3x6, Vector3, Vector6};

use crate::model::{self, Linearized};
use crate::parallel;
use crate::problem::{Kind, Obs, Problem, node};

/// The Huber loss of a whitened residual norm `s` with threshold `k` (plain ½s² without one).
pub(crate) fn huber_loss(s: f64, k: Option<f64>) -> f64 {
    match k {
        Some(k) if s > k => k * s - 0.5 * k * k,
        _ => 0.5 * s * s,
    }
}

/// The IRLS weight ψ(s)/s of the Huber loss.
pub(crate) fn huber_weight(s: f64, k: Option<f64>) -> f64 {
    match k {
        Some(k) if s > k => k / s,
        _ => 1.0,
    }
}

/// Linearise one observation at `x`.
pub(crate) fn linearize(p: &Problem, o: &Obs, x: &[f64]) -> Linearized {
    let delta: Vector6<f64> = o.parts.iter().map(|(k, w)| node(x, *k) * *w).sum();
    let point = |i: usize| Vector3::from_column_slice(&x[p.point_offset(i)..p.point_offset(i) + 3]);
    match &o.kind {
        Kind::Pole { observed, cadastre, sigma, offset } => {
            let mut lin = model::pole(&o.dg, &delta, observed, &(cadastre + pole_offset(p, x, *offset)), *sigma);
            if offset.is_some() {
                // The true pole is the cadastre position plus the object's offset.
                lin.j_point = nalgebra::Matrix3::from_diagonal(&Vector3::new(-1.0, -1.0, 0.0)) / *sigma;
            }
            lin
        }
        Kind::Gnss { lever, measured, sigma } => model::gnss(&o.dg, &delta, lever, measured, sigma),
        Kind::Ray { point: i, direction, sigma } => model::ray(&o.dg, &delta, &p.mount, &point(*i), direction, *sigma),
        Kind::Aerial { point: i, measured, whitening, bias } => {
            // The measured height carries the frame set's bias: measured = true + b·e_z.
            let b = bias.map_or(0.0, |h| x[p.bias_param(h)]);
            model::aerial(&(point(*i) + Vector3::new(0.0, 0.0, b)), measured, whitening)
        }
        Kind::Standstill { offset, sigma, heading } => model::standstill(&delta, offset, *sigma, *heading),
        Kind::Motion { dg, measured, sigma } => model::motion(&delta, dg, measured, sigma),
    }
}

/// The current offset of cadastre object `g` (zero without one).
fn pole_offset(p: &Problem, x: &[f64], g: Option<usize>) -> nalgebra::Vector2<f64> {
    g.map_or_else(nalgebra::Vector2::zeros, |g| nalgebra::Vector2::from_column_slice(&x[p.offset_param(g)..][..2]))
}

/// The Jacobian blocks of an observation: (block, J) with node blocks scaled by their interpolation weight.
pub(crate) fn blocks(p: &Problem, o: &Obs, lin: &Linearized) -> Vec<(usize, Matrix3x6<f64>)> {
    let mut out: Vec<_> = o.parts.iter().map(|(k, w)| (*k, lin.j_pose * *w)).collect();
    let extra = match o.kind {
        Kind::Ray { point, .. } | Kind::Aerial { point, .. } => Some(p.nodes.len() + point),
        Kind::Pole { offset: Some(g), .. } => Some(p.offset_block(g)),
        _ => None,
    };
    if let Some(block) = extra {
        let mut j = Matrix3x6::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&lin.j_point);
        out.push((block, j));
    }
    if let Kind::Aerial { bias: Some(h), whitening, .. } = &o.kind {
        // ∂S(X + b e_z − z)/∂b = S e_z.
        let mut j = Matrix3x6::zeros();
        j.set_column(0, &whitening.column(2));
        out.push((p.bias_block(*h), j));
    }
    out
}

/// The assembled normal equations at one estimate.
pub(crate) struct Normal {
    pub values: Vec<f64>,
    pub gradient: Vec<f64>,
    pub cost: f64,
    /// Whitened residual rows (chain terms, nuisance priors and active observations).
    pub rows: usize,
}

/// Assemble N = Σ Jᵀ W J and g = Σ Jᵀ W e over the chain terms and the active observations.
pub(crate) fn assemble(p: &Problem, x: &[f64], active: &[bool], huber: Option<f64>) -> Normal {
    let chain_rows = 6 * (p.relative_sigma.len() + p.prior_sigma.len()) + p.nuisance_priors().count();
    let (values, gradient) = (vec![0.0; p.pattern.nnz()], vec![0.0; p.pattern.dim()]);
    let mut n = Normal { values, gradient, cost: 0.0, rows: chain_rows };
    assemble_chain(p, x, &mut n);
    // A tie point whose observations were all rejected keeps an identity block: decoupled, it stays put.
    let mut observed = vec![false; p.points.len()];
    for (o, _) in p.obs.iter().zip(active).filter(|(_, a)| **a) {
        if let Kind::Ray { point, .. } | Kind::Aerial { point, .. } = o.kind {
            observed[point] = true;
        }
    }
    for (i, _) in observed.iter().enumerate().filter(|(_, o)| !**o) {
        for c in 0..3 {
            n.values[p.pattern.diagonal(p.point_offset(i) + c)] += 1.0;
        }
    }
    let lins = parallel::map(p.par, p.obs.len(), |i| active[i].then(|| linearize(p, &p.obs[i], x)));
    for (o, lin) in p.obs.iter().zip(lins) {
        let Some(lin) = lin else { continue };
        n.rows += lin.dim;
        let s = lin.e.norm();
        n.cost += huber_loss(s, huber);
        let w = huber_weight(s, huber);
        let parts = blocks(p, o, &lin);
        for (i, (a, ja)) in parts.iter().enumerate() {
            let off = p.pattern.offsets[*a];
            let width = p.pattern.offsets[a + 1] - off;
            let g = ja.transpose() * lin.e * w;
            for (c, gc) in g.iter().take(width).enumerate() {
                n.gradient[off + c] += gc;
            }
            for (b, jb) in &parts[i..] {
                p.pattern.add_product(&mut n.values, *a, &(ja * w), *b, jb);
            }
        }
    }
    n
}

/// Relative random-walk constraints x_{k+1} − x_k ~ N([mean; 0], diag σ²) and the weak prior x_k ~ N(0, diag σ_p²).
fn assemble_chain(p: &Problem, x: &[f64], n: &mut Normal) {
    for (k, sigma) in p.relative_sigma.iter().enumerate() {
        let wgt = sigma.map(|s| 1.0 / (s * s));
        let d = p.link_residual(x, k);
        n.cost += 0.5 * d.component_mul(&d).dot(&wgt);
        let g = d.component_mul(&wgt);
        for c in 0..6 {
            n.gradient[6 * k + c] -= g[c];
            n.gradient[6 * (k + 1) + c] += g[c];
        }
        p.pattern.add_diagonal(&mut n.values, k, k, &wgt);
        p.pattern.add_diagonal(&mut n.values, k + 1, k + 1, &wgt);
        p.pattern.add_diagonal(&mut n.values, k, k + 1, &(-wgt));
    }
    for (k, sigma) in p.prior_sigma.iter().enumerate() {
        let wgt = sigma.map(|s| 1.0 / (s * s));
        let d = node(x, k);
        n.cost += 0.5 * d.component_mul(&d).dot(&wgt);
        let g = d.component_mul(&wgt);
        for c in 0..6 {
            n.gradient[6 * k + c] += g[c];
        }
        p.pattern.add_diagonal(&mut n.values, k, k, &wgt);
    }
    for (i, sigma) in p.nuisance_priors() {
        let wgt = 1.0 / (sigma * sigma);
        n.cost += 0.5 * x[i] * x[i] * wgt;
        n.gradient[i] += x[i] * wgt;
        n.values[p.pattern.diagonal(i)] += wgt;
    }
}

/// ½ Σ (v / σ_v)² over the nuisance parameters (cadastre offsets, height biases): their priors.
pub(crate) fn nuisance_prior(p: &Problem, x: &[f64]) -> f64 {
    0.5 * p.nuisance_priors().map(|(i, s)| (x[i] / s).powi(2)).sum::<f64>()
}

/// The objective at `x` (chain terms + Huber loss of the active observations).
pub(crate) fn cost(p: &Problem, x: &[f64], active: &[bool], huber: Option<f64>) -> f64 {
    let relative = parallel::sum(p.par, p.relative_sigma.len(), |k| {
        0.5 * p.link_residual(x, k).component_div(&p.relative_sigma[k]).norm_squared()
    });
    let prior =
        parallel::sum(p.par, p.prior_sigma.len(), |k| 0.5 * node(x, k).component_div(&p.prior_sigma[k]).norm_squared());
    let obs = parallel::sum(p.par, p.obs.len(), |i| {
        if active[i] { huber_loss(linearize(p, &p.obs[i], x).e.norm(), huber) } else { 0.0 }
    });
    relative + prior + obs + nuisance_prior(p, x)
}
