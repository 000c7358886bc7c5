//! Tracks: the same pole over consecutive frames. A detection continues the track of the mutually nearest
//! detection of the previous frame when they lie within the link distance (the DG pose changes little
//! between frames, so one pole keeps its mapping-frame position).

use crate::detect::Detection;

/// Track ids per frame and detection (`tracks[frame][detection]`), from the detections of each frame.
pub(super) fn link(frames: &[&[Detection]], link_sigmas: f64, link_slack_m: f64) -> Vec<Vec<usize>> {
    let mut next = 0usize;
    let mut out: Vec<Vec<usize>> = Vec::with_capacity(frames.len());
    for (k, dets) in frames.iter().enumerate() {
        let mut ids: Vec<Option<usize>> = vec![None; dets.len()];
        if k > 0 {
            let prev = frames[k - 1];
            for (i, d) in dets.iter().enumerate() {
                let Some(j) = nearest(d, prev) else { continue };
                let back = nearest(&prev[j], dets);
                let tol = link_sigmas * d.sigma().hypot(prev[j].sigma()) + link_slack_m;
                if back == Some(i) && distance(d, &prev[j]) <= tol {
                    ids[i] = Some(out[k - 1][j]);
                }
            }
        }
        out.push(
            ids.into_iter()
                .map(|id| {
                    id.unwrap_or_else(|| {
                        next += 1;
                        next - 1
                    })
                })
                .collect(),
        );
    }
    out
}

fn distance(a: &Detection, b: &Detection) -> f64 {
    (a.centre[0] - b.centre[0]).hypot(a.centre[1] - b.centre[1])
}

fn nearest(d: &Detection, among: &[Detection]) -> Option<usize> {
    among.iter().enumerate().min_by(|a, b| distance(d, a.1).total_cmp(&distance(d, b.1))).map(|(i, _)| i)
}
