//! Tie observations from one panorama pair (Jende et al. 2017 §3.9 → `plumbline_adjustment` ObservationSet v1):
//! one ray per panorama in its camera frame, and the aerial-derived coordinates when the point was matched,
//! with the aerial frames those coordinates were triangulated from.

use plumbline_adjustment::{AerialPoint, TiePoint, TiePointId, TieRay};
use plumbline_geo::{Camera, Vec3};

use crate::aerial::AerialPointResult;
use crate::mm::{MmPoint, Panorama};
use crate::output::TieFrames;

/// The ties of one pair and what came with them.
#[derive(Debug, Default)]
pub(crate) struct Assembled {
    /// Tie points that pass the adjustment's checks.
    pub ties: Vec<TiePoint>,
    /// Per kept tie with aerial coordinates: the frames they came from.
    pub frames: Vec<TieFrames>,
    /// Ties left out because they failed the adjustment's own checks.
    pub dropped: usize,
}

/// The ties of the pair (A, B): every MM point with an aerial result, plus (if `keep_mm_only`) the others.
pub(crate) fn assemble(
    a: &Panorama,
    b: &Panorama,
    points: &[MmPoint],
    aerial: &[AerialPointResult],
    keep_mm_only: bool,
) -> Assembled {
    let mut out = Assembled::default();
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
        if !tie.problems(out.ties.len()).is_empty() {
            out.dropped += 1;
            continue;
        }
        // A single aerial ray belongs to no frame set: a set's height bias would slide it along the vertical
        // plane of the ray, taking away half of what it measures.
        if let Some(r) = matched.filter(|r| r.observations.len() > 1) {
            out.frames.push(TieFrames { tie: tie.id.0.clone(), frames: frames_of(r) });
        }
        out.ties.push(tie);
    }
    out
}

/// The distinct frames of an aerial point's observations, sorted.
fn frames_of(r: &AerialPointResult) -> Vec<String> {
    let mut frames: Vec<String> = r.observations.iter().map(|o| o.frame.clone()).collect();
    frames.sort();
    frames.dedup();
    frames
}

fn ray(time: f64, d: &Vec3<Camera>, sigma: f64) -> TieRay {
    TieRay::new(time, [d.x(), d.y(), d.z()], sigma)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aerial::AerialObservation;

    #[test]
    fn frames_are_the_distinct_observed_frames_sorted() {
        let obs = |frame: &str| AerialObservation { frame: frame.into(), pixel: [1.0, 2.0] };
        let r = AerialPointResult {
            index: 0,
            position: [0.0; 3],
            covariance: [[0.0; 3]; 3],
            observations: vec![obs("f7"), obs("f3"), obs("f7"), obs("f5")],
        };
        assert_eq!(frames_of(&r), vec!["f3".to_owned(), "f5".into(), "f7".into()]);
    }
}
