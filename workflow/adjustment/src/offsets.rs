//! One nuisance offset per cadastre object seen more than once (Meyer et al. 2023 eq. (1) split into its shared and
//! its per-update part).

use std::collections::HashMap;

use crate::observations::ObservationRef;
use crate::problem::{Item, Kind, Obs};

/// Updates of one cadastre object share its cadastre error (err_pole in Meyer et al. 2023 eq. (1)): where an object is
/// observed more than once, it gets one 2-D nuisance offset with prior σ = err_pole and each update keeps
/// only err_cam, so the updates together cannot pull harder than that one position allows. An object is its
/// id together with its listed position. Returns the offsets' prior σ.
pub(crate) fn share_pole_offsets(raw: &mut [Obs]) -> Vec<f64> {
    let key = |o: &Obs| match (&o.item, &o.kind) {
        (Item::Observation(ObservationRef::Pole { cadastre_id, .. }), Kind::Pole { cadastre, .. }) => {
            Some((cadastre_id.clone(), cadastre.x.to_bits(), cadastre.y.to_bits()))
        }
        _ => None,
    };
    let mut counts: HashMap<(String, u64, u64), usize> = HashMap::new();
    for k in raw.iter().filter_map(key) {
        *counts.entry(k).or_default() += 1;
    }
    let mut index: HashMap<(String, u64, u64), usize> = HashMap::new();
    let mut sigmas = Vec::new();
    for o in raw.iter_mut() {
        let Some(k) = key(o) else { continue };
        let Some((camera, pole)) = o.pole_sigmas else { continue };
        let Kind::Pole { sigma, offset, .. } = &mut o.kind else { continue };
        if counts[&k] < 2 || camera <= 0.0 || pole <= 0.0 {
            continue;
        }
        let g = *index.entry(k).or_insert_with(|| {
            sigmas.push(pole);
            sigmas.len() - 1
        });
        *sigma = camera;
        *offset = Some(g);
    }
    sigmas
}
