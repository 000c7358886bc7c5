//! One height bias per aerial frame set: the aerial heights triangulated from the same frames share those
//! frames' orientation error (Jende et al. 2017 §3.9; [`crate::AerialFrameSet`]).
//!
//! Nadir frames see a street point with a base-to-height ratio of a few per cent, so the triangulated height
//! carries the frames' relative orientation error magnified by the height-to-base ratio (an angle error of
//! 3″ at 1500 m over a 50 m base is about 0.6 m of height), the same for every point of the set, while the
//! horizontal position moves by millimetres. Each set gets a bias b (metres, up) with the measured height
//! = true height + b; its prior σ is the set's median triangulated height σ times `prior_scale`: the
//! triangulation's own height σ is that same height-to-base propagation of the frames' accuracy, so the
//! prior says "as large as one point's height error" and the set's heights together weigh like one height
//! (plus what their differences say) rather than like n independent ones.

use std::collections::HashMap;

use nalgebra::Matrix3;

use crate::config::HeightBiasConfig;
use crate::observations::{AerialFrameSet, TiePointId};
use crate::problem::{BiasBlock, Kind, Obs};

/// The estimated height bias of one aerial frame set.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub struct HeightBias {
    /// The set's frames.
    pub frames: Vec<String>,
    /// Aerial heights in the set that the adjustment used.
    pub points: usize,
    /// The bias (measured aerial height − adjusted height), metres.
    pub bias: f64,
    /// Its prior σ, metres.
    pub prior_sigma: f64,
    /// Its posterior σ (a-priori variance factor 1), metres.
    pub sigma: f64,
}

/// Give every aerial observation of a tie listed in `sets` its set's bias block (`Kind::Aerial::bias`);
/// `points` are the problem's tie ids by point index. Sets with no usable aerial observation get no block.
pub(crate) fn share_height_biases(
    raw: &mut [Obs],
    sets: &[AerialFrameSet],
    points: &[TiePointId],
    c: &HeightBiasConfig,
) -> Vec<BiasBlock> {
    let set_of: HashMap<&TiePointId, usize> =
        sets.iter().enumerate().flat_map(|(s, set)| set.ties.iter().map(move |t| (t, s))).collect();
    let mut sigmas: Vec<Vec<f64>> = vec![Vec::new(); sets.len()];
    let mut members: Vec<(usize, usize)> = Vec::new();
    for (i, o) in raw.iter().enumerate() {
        let Kind::Aerial { point, whitening, .. } = &o.kind else { continue };
        let Some(&s) = points.get(*point).and_then(|id| set_of.get(id)) else { continue };
        let Some(sigma_z) = height_sigma(whitening) else { continue };
        sigmas[s].push(sigma_z);
        members.push((i, s));
    }
    let mut block_of = vec![None; sets.len()];
    let mut blocks = Vec::new();
    for (s, list) in sigmas.iter_mut().enumerate().filter(|(_, l)| !l.is_empty()) {
        let Some(typical) = plumbline_geo::metrics::median(list) else { continue };
        let prior_sigma = c.prior_scale * typical;
        block_of[s] = Some(blocks.len());
        blocks.push(BiasBlock { frames: sets[s].frames.clone(), prior_sigma, points: list.len() });
    }
    for (i, s) in members {
        if let Kind::Aerial { bias, .. } = &mut raw[i].kind {
            *bias = block_of[s];
        }
    }
    blocks
}

/// σ of the height from the whitening S (Sᵀ S = C⁻¹, so C = S⁻¹ S⁻ᵀ).
fn height_sigma(whitening: &Matrix3<f64>) -> Option<f64> {
    let inv = whitening.try_inverse()?;
    let c = inv * inv.transpose();
    let v = c[(2, 2)];
    (v.is_finite() && v > 0.0).then(|| v.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_height_sigma_comes_back_from_the_whitening() {
        let c = [[0.04, 0.01, 0.02], [0.01, 0.09, -0.03], [0.02, -0.03, 2.25]];
        let s = crate::observations::aerial_whitening(&c).unwrap();
        assert!((height_sigma(&s).unwrap() - 1.5).abs() < 1e-12);
    }
}
