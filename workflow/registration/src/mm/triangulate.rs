//! Step 4, Jende et al. 2017 §3.5: matched ortho pixels → ground-plane points → directions in each panorama's
//! camera frame (the inverse of the ortho-projection) → least-squares intersection of the two rays with
//! the DG poses.

use nalgebra::{Matrix3, Vector3};
use plumbline_geo::{Camera, Map, Point3, Vec3};

use super::corners::CornerMatch;
use super::ortho::OrthoPatch;
use super::{MmConfig, Panorama, PanoramaRig};

/// The least-squares intersection of two or more rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayIntersection {
    /// The point closest to all rays.
    pub point: Point3<Map>,
    /// Largest perpendicular distance of the point from a ray, metres.
    pub miss: f64,
    /// Largest angle between two rays, radians.
    pub angle: f64,
}

/// Why rays gave no point.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum RayError {
    /// Fewer than two rays, or a direction of zero length.
    #[error("needs at least two rays with non-zero directions")]
    TooFewRays,
    /// The rays are (nearly) parallel: the intersection is undetermined along them.
    #[error("rays intersect at {angle_deg:.3}°, below the minimum")]
    Parallel {
        /// Largest angle between the rays, degrees.
        angle_deg: f64,
    },
    /// The point lies behind a camera.
    #[error("the intersection lies behind ray {ray}")]
    Behind {
        /// Index of the ray.
        ray: usize,
    },
}

/// Minimise Σ |(I − d dᵀ)(X − c)|² over X (Jende et al. 2017 §3.5): (Σ I − d dᵀ) X = Σ (I − d dᵀ) c.
/// Rejects ray bundles whose largest pairwise angle is below `min_angle` and points behind a ray.
pub fn intersect_rays(rays: &[(Point3<Map>, Vec3<Map>)], min_angle: f64) -> Result<RayIntersection, RayError> {
    let dirs: Vec<Vector3<f64>> = rays.iter().filter_map(|(_, d)| d.v.try_normalize(1e-12)).collect();
    if rays.len() < 2 || dirs.len() != rays.len() {
        return Err(RayError::TooFewRays);
    }
    let mut angle = 0.0f64;
    for (i, a) in dirs.iter().enumerate() {
        for b in &dirs[i + 1..] {
            angle = angle.max(a.angle(b));
        }
    }
    if angle < min_angle {
        return Err(RayError::Parallel { angle_deg: angle.to_degrees() });
    }
    let (mut n, mut rhs) = (Matrix3::zeros(), Vector3::zeros());
    for ((c, _), d) in rays.iter().zip(&dirs) {
        let p = Matrix3::identity() - d * d.transpose();
        n += p;
        rhs += p * c.p;
    }
    let x = n.try_inverse().ok_or(RayError::Parallel { angle_deg: angle.to_degrees() })? * rhs;
    let mut miss = 0.0f64;
    for (i, ((c, _), d)) in rays.iter().zip(&dirs).enumerate() {
        let along = (x - c.p).dot(d);
        if along <= 0.0 {
            return Err(RayError::Behind { ray: i });
        }
        miss = miss.max(((x - c.p) - d * along).norm());
    }
    Ok(RayIntersection { point: Point3::from_vector(x), miss, angle })
}

/// A corner triangulated from two panoramas with their DG poses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MmPoint {
    /// The match it came from (pixels in both ortho-images).
    pub corner: CornerMatch,
    /// Unit direction to the point in A's camera frame.
    pub direction_a: Vec3<Camera>,
    /// Unit direction to the point in B's camera frame.
    pub direction_b: Vec3<Camera>,
    /// Angular standard deviation of each direction, radians.
    pub sigma: f64,
    /// The intersection in the mapping frame (carries the DG error).
    pub position: Point3<Map>,
    /// Largest distance of the point from a ray, metres.
    pub miss: f64,
}

/// How many matches each check removed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TriangulationStats {
    /// Rays nearly parallel, behind a camera, or undefined.
    pub geometry: usize,
    /// Rays passing each other further apart than `max_miss`.
    pub miss: usize,
    /// Points too far above or below the ground plane (not on the road).
    pub off_ground: usize,
}

/// The camera-frame unit direction of ortho pixel (u, v): the ground-plane point seen with the DG pose.
fn direction(patch: &OrthoPatch, pano: &Panorama, rig: &PanoramaRig, uv: [f64; 2]) -> Option<Vec3<Camera>> {
    rig.mount.to_camera(&pano.pose, &patch.ground_point(uv[0], uv[1])).normalize()
}

/// Triangulate every match of the pair (A, B) (Jende et al. 2017 §3.5) and keep the points that pass the checks.
pub fn triangulate(
    (a, pano_a): (&OrthoPatch, &Panorama),
    (b, pano_b): (&OrthoPatch, &Panorama),
    rig: &PanoramaRig,
    matches: &[CornerMatch],
    config: &MmConfig,
) -> (Vec<MmPoint>, TriangulationStats) {
    let (pose_a, pose_b) = (rig.mount.camera_pose(&pano_a.pose), rig.mount.camera_pose(&pano_b.pose));
    let pixel_angle = std::f64::consts::TAU / f64::from(rig.camera.width.max(1));
    let mut stats = TriangulationStats::default();
    let mut points = Vec::with_capacity(matches.len());
    for m in matches {
        let (Some(da), Some(db)) = (direction(a, pano_a, rig, m.a), direction(b, pano_b, rig, m.b)) else {
            stats.geometry += 1;
            continue;
        };
        let rays = [(pose_a.translation, pose_a.rotation.apply(&da)), (pose_b.translation, pose_b.rotation.apply(&db))];
        let Ok(hit) = intersect_rays(&rays, config.min_ray_angle) else {
            stats.geometry += 1;
            continue;
        };
        if hit.miss > config.max_miss {
            stats.miss += 1;
            continue;
        }
        if (hit.point.z() - a.height_at(hit.point.x(), hit.point.y())).abs() > config.max_height_offset {
            stats.off_ground += 1;
            continue;
        }
        // Matching precision on the ground over the longer range, plus a fifth of a panorama pixel.
        let range = (hit.point - pose_a.translation).norm().max((hit.point - pose_b.translation).norm());
        let std_px = m.std[0].hypot(m.std[1]).max(0.1);
        let sigma = (std_px * a.grid.gsd / range).hypot(0.2 * pixel_angle);
        points.push(MmPoint {
            corner: *m,
            direction_a: da,
            direction_b: db,
            sigma,
            position: hit.point,
            miss: hit.miss,
        });
    }
    (points, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mm::corners::match_corners;
    use crate::mm::ortho::ortho_patch;
    use crate::mm::testing::{Ground, rig, scene_panorama, true_pose};
    use crate::mm::transform::{features, pair_transform};
    use plumbline_geo::dg::intersect_height;

    fn ray(from: [f64; 3], to: [f64; 3]) -> (Point3<Map>, Vec3<Map>) {
        let c = Point3::new(from[0], from[1], from[2]);
        (c, Point3::new(to[0], to[1], to[2]) - c)
    }

    #[test]
    fn exact_rays_return_the_point() {
        let x = [565_010.3, 5_933_002.7, 8.02];
        for cams in [
            vec![[565_004.0, 5_933_000.0, 10.85], [565_014.0, 5_933_001.0, 10.86]],
            vec![[565_000.0, 5_933_000.0, 10.9], [565_012.0, 5_932_990.0, 10.8], [565_020.0, 5_933_010.0, 11.0]],
        ] {
            let rays: Vec<_> = cams.iter().map(|c| ray(*c, x)).collect();
            let hit = intersect_rays(&rays, 1f64.to_radians()).unwrap();
            let err = (hit.point - Point3::new(x[0], x[1], x[2])).norm();
            assert!(err < 1e-6 && hit.miss < 1e-6, "error {err}, miss {}", hit.miss);
        }
    }

    #[test]
    fn skew_rays_meet_at_the_midpoint_of_their_common_perpendicular() {
        // Ray 1 along +x at z = 0, ray 2 along +y at z = 0.2 through x = 5: closest points (5, 0, 0)
        // and (5, 0, 0.2); the least-squares point is their midpoint, 0.1 m from each ray.
        let rays = [ray([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]), ray([5.0, -5.0, 0.2], [5.0, 1.0, 0.2])];
        let hit = intersect_rays(&rays, 0.01).unwrap();
        assert!((hit.point - Point3::new(5.0, 0.0, 0.1)).norm() < 1e-9 && (hit.miss - 0.1).abs() < 1e-9);
    }

    #[test]
    fn parallel_noisy_and_backward_configurations_are_rejected() {
        let x = [10.0, 0.0, 0.0];
        // 1 cm baseline at 10 m: 0.06° apart.
        let near_parallel = [ray([0.0, 0.0, 0.0], x), ray([0.0, 0.01, 0.0], x)];
        assert!(matches!(intersect_rays(&near_parallel, 1f64.to_radians()), Err(RayError::Parallel { .. })));
        // A point behind the second camera.
        let behind = [ray([0.0, 0.0, 0.0], x), ray([12.0, 3.0, 0.0], [14.0, 6.0, 0.0])];
        assert!(matches!(intersect_rays(&behind, 0.01), Err(RayError::Behind { ray: 1 })));
        assert!(matches!(intersect_rays(&near_parallel[..1], 0.01), Err(RayError::TooFewRays)));
        // Noisy rays: the miss distance reports the noise, so `triangulate` can reject it.
        let noisy = [ray([0.0, 0.0, 0.0], x), ray([5.0, 5.0, 0.0], [10.0, 0.0, 0.3])];
        let hit = intersect_rays(&noisy, 0.01).unwrap();
        assert!(hit.miss > 0.1, "{hit:?}");
    }

    #[test]
    fn corners_of_a_rendered_pair_triangulate_to_the_true_point_moved_by_the_common_dg_error() {
        // The near range, where a 1024-px panorama resolves 3 cm.
        let config = MmConfig { half_extent: 9.0, ..MmConfig::default() };
        let ground = Ground::markings(17, [3.0, 0.0], 10.0);
        let rig = rig(true);
        let offset = [0.7, -1.1, 0.15];
        let a = scene_panorama("a", &ground, &rig, [0.0, 0.0], 1.4, offset);
        let b = scene_panorama("b", &ground, &rig, [6.0, -0.8], 1.45, offset);
        let ortho = |p| ortho_patch(p, &rig, config.gsd, config.half_extent).unwrap();
        let (pa, pb) = (ortho(&a), ortho(&b));
        let (fa, fb) = (features(&pa, "a", &config).unwrap(), features(&pb, "b", &config).unwrap());
        let t = pair_transform(&pa, &fa, &pb, &fb, &config);
        let found = match_corners(&pa, &pb, &t, "a", &config).unwrap();
        let (points, stats) = triangulate((&pa, &a), (&pb, &b), &rig, &found.matches, &config);
        assert!(
            points.len() >= 25 && points.len() * 10 >= found.matches.len() * 8,
            "{} of {}: {stats:?}",
            points.len(),
            found.matches.len()
        );
        // The direction in A's camera frame, cast from the TRUE pose, hits the true ground point; a DG error
        // shared by both poses moves the triangulated point rigidly by that error.
        let truth = rig.mount.camera_pose(&true_pose(&ground, [0.0, 0.0], 1.4));
        let errors: Vec<f64> = points
            .iter()
            .map(|p| {
                let d = truth.rotation.apply(&p.direction_a);
                let g = intersect_height(&truth.translation, &d, ground.height).unwrap();
                let want = Point3::<Map>::new(g.x() + offset[0], g.y() + offset[1], g.z() + offset[2]);
                (p.position - want).norm()
            })
            .collect();
        // Near corners agree to a few cm; far ones (blurred, flat rays) to about an aerial pixel.
        let good = errors.iter().filter(|&&e| e < 0.05).count();
        assert!(good * 100 >= errors.len() * 90, "{good} of {} within 5 cm: {errors:?}", errors.len());
        assert!(errors.iter().all(|&e| e < 0.15), "{errors:?}");
        assert!(points.iter().all(|p| p.sigma > 0.0 && p.sigma < 0.01 && p.miss <= config.max_miss));
    }
}
