//! KAZE's detector as the authors define it (Alcantarilla et al. 2012 §4.1): the Hessian determinant normalised by
//! σ_i⁴ with σ_i = round(σ) the derivative spacing, maxima over 3×3 pixels × 3 levels (every level but
//! the first and the last), refined in position and scale by a 3-D quadratic fit (Brown & Lowe 2002).

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use crate::akaze::detector::{Candidate, Derivatives, level_maxima};
use crate::image::GrayImage;

/// Candidates on levels 1..N−1: above `threshold`, strictly above their 8 neighbours on the level and not
/// below any of the 9 on the levels beneath and above (the authors' test); refined by `refine`. `sigma`
/// maps a fractional level index to its scale in input pixels.
pub(crate) fn candidates(ders: &[Derivatives], threshold: f32, sigma: impl Fn(f64) -> f64 + Sync) -> Vec<Candidate> {
    let n = ders.len();
    (1..n.saturating_sub(1))
        .into_par_iter()
        .flat_map_iter(|i| {
            let (below, here, above) = (&ders[i - 1].det, &ders[i].det, &ders[i + 1].det);
            let sigma = &sigma;
            level_maxima(here, threshold).into_iter().filter_map(move |(c, r)| {
                let x = here.get(c, r);
                let peak = |d: &GrayImage| (r - 1..=r + 1).all(|rr| d.row(rr)[c - 1..=c + 1].iter().all(|&y| y <= x));
                if !(peak(below) && peak(above)) {
                    return None;
                }
                let (dx, dy, ds) = refine([below, here, above], c, r)?;
                Some(Candidate {
                    u: c as f64 + 0.5 + dx,
                    v: r as f64 + 0.5 + dy,
                    response: x,
                    level: i,
                    radius: ders[i].step as f64,
                    sigma: sigma(i as f64 + ds),
                })
            })
        })
        .collect()
}

/// Offset (dx, dy, ds) of the vertex of the quadratic through the 3×3×3 neighbourhood of the determinant
/// (Alcantarilla et al. 2012 §4.1, Brown & Lowe 2002); `None` if the fit is singular or the vertex leaves the
/// neighbourhood (any |offset| > 1, the authors' test).
fn refine(det: [&GrayImage; 3], c: usize, r: usize) -> Option<(f64, f64, f64)> {
    let at =
        |l: usize, dc: isize, dr: isize| f64::from(det[l].get((c as isize + dc) as usize, (r as isize + dr) as usize));
    let centre = at(1, 0, 0);
    let g = Vector3::new(
        0.5 * (at(1, 1, 0) - at(1, -1, 0)),
        0.5 * (at(1, 0, 1) - at(1, 0, -1)),
        0.5 * (at(2, 0, 0) - at(0, 0, 0)),
    );
    let dxx = at(1, 1, 0) + at(1, -1, 0) - 2.0 * centre;
    let dyy = at(1, 0, 1) + at(1, 0, -1) - 2.0 * centre;
    let dss = at(2, 0, 0) + at(0, 0, 0) - 2.0 * centre;
    let dxy = 0.25 * (at(1, 1, 1) + at(1, -1, -1) - at(1, -1, 1) - at(1, 1, -1));
    let dxs = 0.25 * (at(2, 1, 0) + at(0, -1, 0) - at(2, -1, 0) - at(0, 1, 0));
    let dys = 0.25 * (at(2, 0, 1) + at(0, 0, -1) - at(2, 0, -1) - at(0, 0, 1));
    let h = Matrix3::new(dxx, dxy, dxs, dxy, dyy, dys, dxs, dys, dss);
    let d = -(h.try_inverse()? * g);
    d.iter().all(|v| v.abs() <= 1.0).then_some((d.x, d.y, d.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refinement_finds_the_vertex_of_a_known_quadratic_in_position_and_scale() {
        // f(x, y, s) = −(x − 0.3)² − 2(y + 0.2)² − 0.5(s − 0.4)² + 0.1(x − 0.3)(s − 0.4), sampled on the grid.
        let f = |x: f64, y: f64, s: f64| {
            let (a, b, c) = (x - 0.3, y + 0.2, s - 0.4);
            (-a * a - 2.0 * b * b - 0.5 * c * c + 0.1 * a * c) as f32
        };
        let levels: Vec<GrayImage> = (0..3)
            .map(|l| GrayImage::from_fn(5, 5, |c, r| f(c as f64 - 2.0, r as f64 - 2.0, l as f64 - 1.0)))
            .collect();
        let (dx, dy, ds) = refine([&levels[0], &levels[1], &levels[2]], 2, 2).unwrap();
        assert!((dx - 0.3).abs() < 1e-5 && (dy + 0.2).abs() < 1e-5 && (ds - 0.4).abs() < 1e-5, "{dx} {dy} {ds}");
        // A vertex two samples away is refused.
        let far: Vec<GrayImage> = (0..3)
            .map(|l| GrayImage::from_fn(5, 5, |c, r| f(c as f64 - 4.0, r as f64 - 2.0, l as f64 - 1.0)))
            .collect();
        assert!(refine([&far[0], &far[1], &far[2]], 2, 2).is_none());
    }
}
