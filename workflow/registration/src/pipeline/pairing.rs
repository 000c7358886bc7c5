//! Which panorama an owned one is paired with — the next in time within the pairing distance, else the
//! previous — from the DG poses alone: what choosing the panoramas to prepare (`prepared`) and processing a
//! pair (`pair`) share. Below both: it imports neither.

use plumbline_geo::MapFromBody;

use super::PipelineConfig;
use crate::mm::PanoramaRig;
use crate::output::DiscardReason;

/// Horizontal distance between the DG camera centres of two vehicle poses, metres.
fn distance(a: &MapFromBody, b: &MapFromBody, rig: &PanoramaRig) -> f64 {
    let (ca, cb) = (rig.mount.camera_pose(a).translation, rig.mount.camera_pose(b).translation);
    (ca.x() - cb.x()).hypot(ca.y() - cb.y())
}

/// The neighbour of panorama `i` of a tile whose DG poses in time order are `poses`: the next panorama in
/// time if it lies within the pairing distance, else the previous one; the reason when neither does.
pub fn neighbour(
    i: usize,
    poses: &[&MapFromBody],
    rig: &PanoramaRig,
    config: &PipelineConfig,
) -> Result<usize, DiscardReason> {
    let candidates = [i.checked_add(1).filter(|&j| j < poses.len()), i.checked_sub(1)];
    let mut nearest: Option<f64> = None;
    for j in candidates.into_iter().flatten() {
        let d = distance(poses[i], poses[j], rig);
        if d >= config.min_pair_distance && d <= config.max_pair_distance {
            return Ok(j);
        }
        nearest = Some(nearest.map_or(d, |n: f64| n.min(d)));
    }
    Err(DiscardReason::NoNeighbour { nearest_m: nearest })
}
