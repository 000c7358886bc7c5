//! One tie point per ground feature: the pairs A–B and B–C of a tile each triangulate the corners they match,
//! so a feature seen from A, B and C arrives as two tie points sharing B's image point, each with its own
//! aerial coordinates from the same aerial frames and nearly the same aerial pixels. Kept apart, the
//! feature's aerial position counts twice as if its errors were independent (they are almost the same), and
//! each point has two rays only, so an error along the epipolar plane moves the point unseen instead of
//! failing the w-test. Joined, the point has three rays (over-determined, Jende et al. 2017 §3.5) and one aerial
//! observation.

use std::collections::{BTreeMap, HashMap, HashSet};

use nalgebra::Vector3;
use plumbline_adjustment::{TiePoint, TiePointId};

use crate::merge::Merged;

/// Two rays of one panorama see the same image point when their angle is within this many σ of its
/// difference (√(σ₁² + σ₂²)): the w-test's critical value at α = 0.1 %.
pub const SAME_POINT_SIGMAS: f64 = 3.29;

/// Join the merged tie points that share an image point (a ray of the same panorama within
/// [`SAME_POINT_SIGMAS`]) into the first of them: its rays plus the others' rays from panoramas it does not
/// see yet, and one aerial observation (its own, else the first joined one's). A tie point joined into
/// another is not skipped input (its rays are kept) and is not listed; it leaves the aerial frame sets (where
/// the kept aerial observation's tie is renamed). Returns how many were joined.
pub fn join_shared_points(merged: &mut Merged) -> usize {
    let ties = std::mem::take(&mut merged.observations.ties);
    let mut into: Vec<Option<usize>> = vec![None; ties.len()];
    let mut replaced: HashMap<usize, TiePoint> = HashMap::new();
    let mut renamed: HashMap<TiePointId, TiePointId> = HashMap::new();
    for members in groups(&ties) {
        let first = members[0];
        for &m in &members[1..] {
            into[m] = Some(first);
        }
        let (tie, source) = joined(&ties, &members);
        if let Some(source) = source.filter(|s| *s != first) {
            renamed.insert(ties[source].id.clone(), ties[first].id.clone());
        }
        replaced.insert(first, tie);
    }
    let absorbed: HashSet<TiePointId> =
        (0..ties.len()).filter(|i| into[*i].is_some()).map(|i| ties[i].id.clone()).collect();
    let mut kept = Vec::with_capacity(ties.len() - absorbed.len());
    for (i, tie) in ties.iter().enumerate().filter(|(i, _)| into[*i].is_none()) {
        kept.push(replaced.remove(&i).unwrap_or_else(|| tie.clone()));
    }
    merged.observations.ties = kept;
    for set in &mut merged.observations.aerial_frame_sets {
        let mut seen = HashSet::new();
        let ids = set.ties.iter().filter_map(|id| renamed.get(id).or((!absorbed.contains(id)).then_some(id)));
        set.ties = ids.filter(|id| seen.insert((*id).clone())).cloned().collect();
    }
    merged.observations.aerial_frame_sets.retain(|s| !s.ties.is_empty());
    absorbed.len()
}

/// A ray of a tie point in one panorama: azimuth (rad), unit direction, σ, the tie point's index.
type ImageRay = (f64, Vector3<f64>, f64, usize);

/// The groups of tie points (indices, ascending; two or more) linked by shared image points.
fn groups(ties: &[TiePoint]) -> Vec<Vec<usize>> {
    let mut by_image: BTreeMap<u64, Vec<ImageRay>> = BTreeMap::new();
    for (i, tie) in ties.iter().enumerate() {
        for r in &tie.rays {
            let Some(d) = Vector3::from(r.direction).try_normalize(1e-12) else { continue };
            by_image.entry(r.time.to_bits()).or_default().push((d.x.atan2(d.z), d, r.sigma, i));
        }
    }
    let mut parent: Vec<usize> = (0..ties.len()).collect();
    for rays in by_image.values_mut() {
        rays.sort_by(|a, b| a.0.total_cmp(&b.0));
        let widest = rays.iter().map(|r| r.2).fold(0.0, f64::max) * SAME_POINT_SIGMAS * std::f64::consts::SQRT_2;
        for (k, a) in rays.iter().enumerate() {
            // Rays further apart in azimuth than the widest limit cannot be the same point.
            for b in rays[k + 1..].iter().take_while(|b| b.0 - a.0 <= widest) {
                if a.3 != b.3 && a.1.angle(&b.1) <= SAME_POINT_SIGMAS * a.2.hypot(b.2) {
                    union(&mut parent, a.3, b.3);
                }
            }
        }
    }
    let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for i in 0..ties.len() {
        let root = find(&mut parent, i);
        groups.entry(root).or_default().push(i);
    }
    let mut out: Vec<Vec<usize>> = groups.into_values().filter(|g| g.len() > 1).collect();
    out.sort_by_key(|g| g[0]);
    out
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    // The smaller index stays the root, so a group's first tie point is its root.
    parent[ra.max(rb)] = ra.min(rb);
}

/// The first member with the others' rays from panoramas it does not see and one aerial observation; with
/// the index of the member that observation came from.
fn joined(ties: &[TiePoint], members: &[usize]) -> (TiePoint, Option<usize>) {
    let mut tie = ties[members[0]].clone();
    let mut times: HashSet<u64> = tie.rays.iter().map(|r| r.time.to_bits()).collect();
    for &m in &members[1..] {
        for r in &ties[m].rays {
            if times.insert(r.time.to_bits()) {
                tie.rays.push(*r);
            }
        }
    }
    let source = members.iter().copied().find(|&m| ties[m].aerial.is_some());
    tie.aerial = source.and_then(|s| ties[s].aerial);
    (tie, source)
}

#[cfg(test)]
mod tests {
    use plumbline_adjustment::{AerialFrameSet, AerialPoint, TieRay};

    use super::*;

    const SIGMA: f64 = 0.002;

    /// A ray of the panorama at `time` at `azimuth` (rad) and 30° below the horizon.
    fn ray(time: f64, azimuth: f64) -> TieRay {
        let (e, a) = (30f64.to_radians(), azimuth);
        TieRay::new(time, [e.cos() * a.sin(), e.sin(), e.cos() * a.cos()], SIGMA)
    }

    fn tie(id: &str, rays: Vec<TieRay>, aerial_x: Option<f64>) -> TiePoint {
        let aerial = aerial_x.map(|x| AerialPoint {
            position: [x, 0.0, 0.0],
            covariance: [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 1.0]],
        });
        TiePoint { id: TiePointId(id.into()), rays, aerial }
    }

    fn merged(ties: Vec<TiePoint>, sets: &[(&str, &[&str])]) -> Merged {
        let mut m = Merged::default();
        m.observations.ties = ties;
        m.observations.aerial_frame_sets = sets
            .iter()
            .map(|(f, ids)| AerialFrameSet {
                frames: vec![(*f).to_owned()],
                ties: ids.iter().map(|i| TiePointId((*i).to_owned())).collect(),
            })
            .collect();
        m
    }

    fn ids(m: &Merged) -> Vec<&str> {
        m.observations.ties.iter().map(|t| t.id.0.as_str()).collect()
    }

    /// A feature seen from A, B and C arrives as the A–B and B–C points sharing B's image point (2σ apart):
    /// one point with the three panoramas' rays and the first one's aerial coordinates; the second is
    /// listed as joined and leaves its frame set. A point 8σ off in B and one of another panorama stay.
    #[test]
    fn points_sharing_an_image_point_become_one_with_every_panorama() {
        let (a, b, c) = (1.0, 2.0, 3.0);
        let off = 2.0 * SIGMA / 30f64.to_radians().cos();
        let ties = vec![
            tie("A:1", vec![ray(a, 0.3), ray(b, 0.5)], Some(10.0)),
            tie("B:1", vec![ray(b, 0.5 + off), ray(c, 0.8)], Some(10.02)),
            tie("B:2", vec![ray(b, 0.5 + 5.0 * off), ray(c, 0.9)], Some(20.0)),
            tie("C:1", vec![ray(c, 0.3), ray(4.0, 0.2)], None),
        ];
        let mut m = merged(ties, &[("f1", &["A:1", "B:1"]), ("f2", &["B:2"])]);
        assert_eq!(join_shared_points(&mut m), 1);
        assert_eq!(ids(&m), ["A:1", "B:2", "C:1"]);
        let joined = &m.observations.ties[0];
        assert_eq!(joined.rays.iter().map(|r| r.time).collect::<Vec<_>>(), [a, b, c]);
        assert_eq!(joined.rays[1], ray(b, 0.5), "the first point's own ray of the shared panorama is kept");
        assert_eq!(joined.aerial.map(|p| p.position[0]), Some(10.0));
        let sets: Vec<Vec<&str>> =
            m.observations.aerial_frame_sets.iter().map(|s| s.ties.iter().map(|t| t.0.as_str()).collect()).collect();
        assert_eq!(sets, [vec!["A:1"], vec!["B:2"]]);
        assert!(m.skipped.is_empty(), "joined ties lose nothing: {:?}", m.skipped);
    }

    /// A chain A–B, B–C, C–D is one point; when only a later member has aerial coordinates, the joined
    /// point takes them and its frame set names the kept point instead.
    #[test]
    fn a_chain_joins_into_its_first_point_which_takes_the_aerial_coordinates() {
        let ties = vec![
            tie("A:1", vec![ray(1.0, 0.1), ray(2.0, 0.2)], None),
            tie("B:1", vec![ray(2.0, 0.2), ray(3.0, 0.3)], Some(5.0)),
            tie("C:1", vec![ray(3.0, 0.3), ray(4.0, 0.4)], Some(6.0)),
        ];
        let mut m = merged(ties, &[("f1", &["B:1"]), ("f2", &["C:1"])]);
        assert_eq!(join_shared_points(&mut m), 2);
        assert_eq!(ids(&m), ["A:1"]);
        let joined = &m.observations.ties[0];
        assert_eq!(joined.rays.len(), 4);
        assert_eq!(joined.aerial.map(|p| p.position[0]), Some(5.0));
        assert_eq!(m.observations.aerial_frame_sets.len(), 1, "the dropped aerial point's set is gone");
        assert_eq!(m.observations.aerial_frame_sets[0].ties, [TiePointId("A:1".into())]);
    }
}
