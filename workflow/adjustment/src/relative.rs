//! The image-derived motion between consecutive panoramas ([`crate::RelativeMotion`], Cazzaniga et al. 2007 §4 and
//! Jende et al. 2017 §3.3) as internal observations of the adjustment: each constrains the corrected east, north
//! displacement and heading change between its two epochs, with the DG's own counterpart read off the
//! trajectory (model::motion), and enters the normal equations through the difference of the corrections
//! interpolated at its ends.

use nalgebra::Vector3;
use plumbline_geo::Trajectory;
use plumbline_geo::trajectory::PositionInterpolation;

use crate::nodes::Nodes;
use crate::observations::{MotionError, RelativeMotion};
use crate::problem::{Item, Kind, Obs, dg_pose};

/// The usable motions as observations (their node parts left empty until the nodes are known) and the
/// broken ones or those outside the trajectory, each named by index and field.
pub(crate) fn observations(t: &Trajectory, motions: &[RelativeMotion]) -> (Vec<Obs>, Vec<MotionError>) {
    let (mut obs, mut skipped) = (Vec::new(), Vec::new());
    for (index, m) in motions.iter().enumerate() {
        let problems = m.problems(index);
        if !problems.is_empty() {
            skipped.extend(problems);
            continue;
        }
        let at = |time: f64| t.interpolate(time, PositionInterpolation::Linear).ok();
        let (Some(a), Some(b), Some(dg)) = (at(m.start), at(m.end), dg_pose(t, m.start)) else {
            let problem = "lies outside the trajectory's time span".into();
            skipped.push(MotionError { index, field: "start/end", problem });
            continue;
        };
        let d = b.position.p - a.position.p;
        let turn = crate::model::wrap(b.attitude.heading - a.attitude.heading);
        let [e, n] = m.displacement;
        let kind = Kind::Motion {
            dg: Vector3::new(d.x, d.y, turn),
            measured: Vector3::new(e, n, m.heading_change),
            sigma: Vector3::from(m.std),
        };
        let (item, parts) = (Item::Motion(index), Vec::new());
        obs.push(Obs { item, time: m.start, until: m.end, dg, parts, kind, pole_sigmas: None });
    }
    (obs, skipped)
}

/// The interpolation weights of δ(end) − δ(start), one entry per node.
pub(crate) fn difference_parts(nodes: &Nodes, start: f64, end: f64) -> Vec<(usize, f64)> {
    let mut parts: Vec<(usize, f64)> = nodes.bracket(start).into_iter().map(|(k, w)| (k, -w)).collect();
    for (k, w) in nodes.bracket(end) {
        match parts.iter_mut().find(|(j, _)| *j == k) {
            Some(part) => part.1 += w,
            None => parts.push((k, w)),
        }
    }
    parts.retain(|(_, w)| *w != 0.0);
    parts
}
