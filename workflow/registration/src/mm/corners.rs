//! Step 3, Jende et al. 2017 §3.4: Förstner corners at subpixel precision in ortho-image A, transferred into B with
//! the step-2 transformation, matched by NCC in a small window and refined by least-squares matching.

use plumbline_imaging::GrayImage;
use plumbline_imaging::corners::Corner;
use plumbline_imaging::lsm::{LsmConfig, least_squares_match};
use plumbline_imaging::ncc::NccSearcher;
use plumbline_imaging::warp::apply_h;

use super::ortho::OrthoPatch;
use super::transform::{PairTransform, TransformSource};
use super::{MmConfig, MmError};

/// One corner found in both ortho-images.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerMatch {
    /// Subpixel Förstner position in A, continuous pixels.
    pub a: [f64; 2],
    /// Its LSM-refined position in B, continuous pixels.
    pub b: [f64; 2],
    /// Zero-mean NCC coefficient of the match.
    pub ncc: f64,
    /// LSM standard deviation of the position in B, pixels.
    pub std: [f64; 2],
}

/// The corners of one pair: how many were detected in A and the ones matched in B.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CornerMatches {
    /// Förstner corners detected in A (before any check).
    pub detected: usize,
    /// Corners whose template and search window lie on valid cells of both images.
    pub candidates: usize,
    /// The matches.
    pub matches: Vec<CornerMatch>,
}

/// Detect, transfer, correlate and refine (Jende et al. 2017 §3.4). Corners whose windows leave the valid area of
/// either image, whose NCC peak is weak, or whose LSM does not settle near the NCC peak are dropped.
pub fn match_corners(
    a: &OrthoPatch,
    b: &OrthoPatch,
    transform: &PairTransform,
    image_id: &str,
    config: &MmConfig,
) -> Result<CornerMatches, MmError> {
    let mut corners = config.foerstner.detect(&a.image).map_err(|source| MmError::Imaging {
        image: image_id.to_owned(),
        step: "förstner corners",
        source,
    })?;
    let detected = corners.len();
    let radius = match transform.source {
        TransformSource::Kaze { .. } => config.search_radius,
        TransformSource::Orientation(_) => config.fallback_search_radius,
    };
    let t = config.template_half;
    let (cu, cv, reach) =
        (a.grid.width as f64 / 2.0, a.grid.height as f64 / 2.0, config.max_corner_distance / a.grid.gsd);
    corners.retain(|c| {
        let Some((bu, bv)) = apply_h(&transform.matrix, c.u, c.v) else { return false };
        // The grid is centred below the camera.
        (c.u - cu).hypot(c.v - cv) <= reach
            && a.valid_around(c.u.floor() as isize, c.v.floor() as isize, t + 1)
            && b.valid_around(bu.floor() as isize, bv.floor() as isize, t + radius + 2)
    });
    corners.sort_by(|x, y| y.strength.total_cmp(&x.strength));
    corners.truncate(config.max_corners);
    let searcher = NccSearcher::new(&b.image);
    let matches =
        corners.iter().filter_map(|c| match_one(c, &a.image, &b.image, &searcher, transform, radius, config)).collect();
    Ok(CornerMatches { detected, candidates: corners.len(), matches })
}

/// NCC around the transferred corner, then LSM started from the NCC peak.
fn match_one(
    corner: &Corner,
    a: &GrayImage,
    b: &GrayImage,
    searcher: &NccSearcher<'_>,
    transform: &PairTransform,
    radius: usize,
    config: &MmConfig,
) -> Option<CornerMatch> {
    let (col, row) = (corner.u.floor() as usize, corner.v.floor() as usize);
    let template = a.patch(col, row, config.template_half).ok()?;
    // The template is centred on pixel (col, row); predict where that centre lands in B.
    let (cu, cv) = (col as f64 + 0.5, row as f64 + 0.5);
    let (pu, pv) = apply_h(&transform.matrix, cu, cv)?;
    let found = searcher.search(&template, pu.floor() as usize, pv.floor() as usize, radius).ok()?;
    if found.score < config.min_ncc {
        return None;
    }
    // LSM starts at the NCC peak with the transformation's linear part.
    let m = &transform.matrix;
    let start = [found.u, m[(0, 0)], m[(0, 1)], found.v, m[(1, 0)], m[(1, 1)]];
    let lsm = least_squares_match(&template, b, start, &LsmConfig::default()).ok()?;
    let aff = lsm.affine;
    let shift = (aff[0] - found.u).hypot(aff[3] - found.v);
    if shift > config.max_lsm_shift || lsm.std[0].max(lsm.std[1]) > config.max_lsm_std {
        return None;
    }
    // The corner sits at (corner − template centre) in template coordinates; carry it through the affine.
    let (x, y) = (corner.u - cu, corner.v - cv);
    let b_pos = [aff[0] + aff[1] * x + aff[2] * y, aff[3] + aff[4] * x + aff[5] * y];
    Some(CornerMatch { a: [corner.u, corner.v], b: b_pos, ncc: found.score, std: lsm.std })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mm::ortho::ortho_patch;
    use crate::mm::testing::{Ground, rig, scene_panorama};
    use crate::mm::transform::{FallbackReason, features, orientation_transform, pair_transform};

    #[test]
    fn matched_corners_land_on_the_same_ground_point_in_both_images() {
        // The near range, where a 1024-px panorama resolves 3 cm.
        let config = MmConfig { half_extent: 9.0, ..MmConfig::default() };
        let ground = Ground::markings(13, [2.0, 0.0], 9.0);
        let rig = rig(true);
        let relative = [0.06, -0.1];
        let a = scene_panorama("a", &ground, &rig, [0.0, 0.0], 0.3, [1.0, 0.4, 0.0]);
        let b = scene_panorama("b", &ground, &rig, [4.2, 0.3], 0.2, [1.0 + relative[0], 0.4 + relative[1], 0.0]);
        let ortho = |p| ortho_patch(p, &rig, config.gsd, config.half_extent).unwrap();
        let (pa, pb) = (ortho(&a), ortho(&b));
        let (fa, fb) = (features(&pa, "a", &config).unwrap(), features(&pb, "b", &config).unwrap());
        let kaze = pair_transform(&pa, &fa, &pb, &fb, &config);
        assert!(matches!(kaze.source, TransformSource::Kaze { .. }), "{:?}", kaze.source);
        let fallback = PairTransform {
            matrix: orientation_transform(&pa, &pb),
            source: TransformSource::Orientation(FallbackReason::TooFewMatches { matches: 0 }),
            fit: None,
        };
        for t in [kaze, fallback] {
            let found = match_corners(&pa, &pb, &t, "a", &config).unwrap();
            assert!(found.matches.len() >= 30, "{} of {} candidates", found.matches.len(), found.candidates);
            // Truth: A's pixel is a ground point of A's ortho frame; in B's frame it is shifted by the
            // relative DG error (4 px here). The far range is blurred differently in both ortho-images, so
            // allow 2 px (6 cm, half an aerial pixel) for 95 % and ask for a sub-pixel median.
            let errors: Vec<f64> = found
                .matches
                .iter()
                .map(|m| {
                    let [e, n] = pa.grid.to_map(m.a[0], m.a[1]);
                    let want = pb.grid.to_pixel(e + relative[0], n + relative[1]);
                    (m.b[0] - want[0]).hypot(m.b[1] - want[1])
                })
                .collect();
            let good = errors.iter().filter(|&&e| e < 2.0).count();
            assert!(good * 100 >= errors.len() * 95, "{good} of {} within 2 px: {errors:?}", errors.len());
            let mut sorted = errors.clone();
            sorted.sort_by(f64::total_cmp);
            assert!(sorted[sorted.len() / 2] < 0.7, "median {}", sorted[sorted.len() / 2]);
        }
    }
}
