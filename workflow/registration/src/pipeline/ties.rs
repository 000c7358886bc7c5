//! Tie observations from one panorama pair (paper 000 §3.9 → `plumbline_adjustment` ObservationSet v1):
//! one ray per panorama in its camera frame, and the aerial-derived coordinates when the point was matched.

use plumbline_adjustment::{AerialPoint, TiePoint, TiePointId, TieRay};
use plumbline_geo::{Camera, Vec3};

use crate::aerial::AerialPointResult;
use crate::mm::{MmPoint, Panorama};

/// The ties of the pair (A, B): every MM point with an aerial result, plus (if `keep_mm_only`) the others.
/// Ties that fail the adjustment's own checks are left out and counted in the second value.
pub(crate) fn assemble(
    a: &Panorama,
    b: &Panorama,
    points: &[MmPoint],
    aerial: &[AerialPointResult],
    keep_mm_only: bool,
) -> (Vec<TiePoint>, usize) {
    let (mut ties, mut broken) = (Vec::new(), 0);
    for (k, p) in points.iter().enumerate() {
        let matched = aerial.iter().find(|r| r.index == k);
        if matched.is_none() && !keep_mm_only {
            continue;
        }
        let tie = TiePoint {
            id: TiePointId(format!("{}:{k:04}", a.id)),
            rays: vec![ray(a.time, &p.direction_a, p.sigma), ray(b.time, &p.direction_b, p.sigma)],
            aerial: matched.map(|r| AerialPoint { position: r.position, covariance: r.covariance }),
        };
        if tie.problems(ties.len()).is_empty() {
            ties.push(tie);
        } else {
            broken += 1;
        }
    }
    (ties, broken)
}

fn ray(time: f64, d: &Vec3<Camera>, sigma: f64) -> TieRay {
    TieRay { time, direction: [d.x(), d.y(), d.z()], sigma }
}
