//! The assembled problem as plain data, for solving it with another least-squares library (the GTSAM
//! comparison of `benches/gtsam.rs`). Pole CUPTs and the DG chain only: tie rays, aerial coordinates and GNSS
//! positions are left out of the export.

use serde::{Deserialize, Serialize};

use crate::config::AdjustmentConfig;
use crate::problem::{AdjustmentInput, Kind};

/// One node: its epoch and the σ of its weak absolute prior (east, north, up, θ_e, θ_n, θ_u).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExportedNode {
    /// Epoch, seconds.
    pub time: f64,
    /// Prior σ, metres / radians.
    pub prior_sigma: [f64; 6],
}

/// One pole CUPT: residual (p + δp + Exp(δθ)(observed − p))_{xy} − cadastre over σ, δ = Σ w_k x_k.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExportedPole {
    /// (node, interpolation weight).
    pub parts: Vec<(usize, f64)>,
    /// DG body origin.
    pub dg_position: [f64; 3],
    /// The observed pole at the vehicle's height.
    pub observed: [f64; 3],
    /// Cadastre easting, northing.
    pub cadastre: [f64; 2],
    /// σ per coordinate (Meyer et al. 2023 eq. (1)).
    pub sigma: f64,
}

/// The exported problem.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExportedProblem {
    /// The nodes in time order.
    pub nodes: Vec<ExportedNode>,
    /// σ of the random walk x_{k+1} − x_k, one per consecutive pair.
    pub links: Vec<[f64; 6]>,
    /// Expected position part of x_{k+1} − x_k, one per consecutive pair: zero but where the DG's motion
    /// departs from the vehicle's (its links follow the vehicle's reference motion; `crate::localize`).
    #[serde(default)]
    pub link_means: Vec<[f64; 3]>,
    /// The pole CUPTs.
    pub poles: Vec<ExportedPole>,
}

/// Export the chain and the pole CUPTs of the problem [`crate::adjust`] would solve.
pub fn export(input: &AdjustmentInput<'_>, config: &AdjustmentConfig) -> ExportedProblem {
    // The export has no nuisance offsets: every CUPT carries the σ of Meyer et al. 2023 eq. (1).
    let p = crate::build::problem(input, &AdjustmentConfig { pole_offsets: false, ..*config }, faer::Par::Seq);
    let nodes = p
        .nodes
        .times
        .iter()
        .zip(&p.prior_sigma)
        .map(|(t, s)| ExportedNode { time: *t, prior_sigma: (*s).into() })
        .collect();
    let links = p.relative_sigma.iter().map(|s| (*s).into()).collect();
    let link_means = p.relative_mean.iter().map(|m| (*m).into()).collect();
    let poles = p
        .obs
        .iter()
        .filter_map(|o| match &o.kind {
            Kind::Pole { observed, cadastre, sigma, .. } => Some(ExportedPole {
                parts: o.parts.clone(),
                dg_position: o.dg.p.into(),
                observed: (*observed).into(),
                cadastre: (*cadastre).into(),
                sigma: *sigma,
            }),
            _ => None,
        })
        .collect();
    ExportedProblem { nodes, links, link_means, poles }
}
