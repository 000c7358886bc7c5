//! Known-answer tests of the corner operators on rendered corners with subpixel positions.

use super::*;

/// Render a convex polygon (bright on dark) by 16×16 supersampling: an exact area-coverage image.
fn render_polygon(w: usize, h: usize, poly: &[[f64; 2]]) -> GrayImage {
    let inside = |x: f64, y: f64| {
        (0..poly.len()).all(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]) >= 0.0
        })
    };
    GrayImage::from_fn(w, h, |c, r| {
        let hits = (0..256)
            .filter(|i| {
                inside(c as f64 + (f64::from(i % 16) + 0.5) / 16.0, r as f64 + (f64::from(i / 16) + 0.5) / 16.0)
            })
            .count();
        40.0 + 160.0 * hits as f32 / 256.0
    })
}

/// A quadrilateral with corners listed clockwise on screen (v down), turned by `angle` about `centre`.
fn quad(centre: [f64; 2], half: [f64; 2], skew: f64, angle: f64) -> Vec<[f64; 2]> {
    let (s, c) = angle.sin_cos();
    [[-half[0] + skew, -half[1]], [half[0] + skew, -half[1]], [half[0] - skew, half[1]], [-half[0] - skew, half[1]]]
        .iter()
        .map(|p| [centre[0] + c * p[0] - s * p[1], centre[1] + s * p[0] + c * p[1]])
        .collect()
}

#[test]
fn foerstner_locates_rendered_corners_to_a_tenth_of_a_pixel() {
    let params = Foerstner::default();
    // A sweep of rectangles and parallelograms (corner angles 66°–114°) at subpixel positions and rotations.
    for k in 0..10 {
        let k = f64::from(k);
        let centre = [39.5 + (k * 0.713) % 1.0, 40.2 + (k * 0.419) % 1.0];
        let skew = if k < 6.0 { 0.0 } else { 5.0 - 2.5 * (k - 6.0) };
        let poly = quad(centre, [15.0, 12.0], skew, 0.05 + k * 0.29);
        let img = render_polygon(80, 80, &poly);
        for p in &poly {
            let c = params.locate(&img, p[0] as usize, p[1] as usize).unwrap();
            let err = (c.u - p[0]).hypot(c.v - p[1]);
            assert!(err < 0.1, "corner {p:?} located at ({:.3}, {:.3}), off by {err:.3} px", c.u, c.v);
        }
    }
}

#[test]
fn foerstner_detects_exactly_the_corners_of_a_polygon() {
    let poly = quad([55.3, 50.7], [22.0, 16.0], 3.0, 0.4);
    let img = render_polygon(110, 100, &poly);
    let found = Foerstner::default().detect(&img).unwrap();
    assert_eq!(found.len(), 4, "{found:?}");
    for p in &poly {
        let best = found.iter().map(|c| (c.u - p[0]).hypot(c.v - p[1])).fold(f64::INFINITY, f64::min);
        assert!(best < 0.1, "corner {p:?}: nearest detection {best:.3} px away");
    }
    // A straight edge alone (q → 0) and a flat image yield no corners.
    let edge = GrayImage::from_fn(60, 60, |c, r| if c as f64 + 0.3 * r as f64 > 30.0 { 200.0 } else { 40.0 });
    assert!(Foerstner::default().detect(&edge).unwrap().is_empty());
    assert!(Foerstner::default().detect(&GrayImage::filled(30, 30, 9.0)).unwrap().is_empty());
}

#[test]
fn harris_finds_checkerboard_junctions_at_their_subpixel_positions() {
    let (ox, oy, side) = (10.3, 9.6, 12.0);
    let square = |x: f64, y: f64| ((x - ox) / side).floor() as i64 + ((y - oy) / side).floor() as i64;
    // Area coverage by 8×8 supersampling, so the junctions sit exactly at (ox + i·side, oy + j·side).
    let img = GrayImage::from_fn(96, 84, |c, r| {
        let bright = (0..64)
            .filter(|i| {
                let (x, y) = (c as f64 + (f64::from(i % 8) + 0.5) / 8.0, r as f64 + (f64::from(i / 8) + 0.5) / 8.0);
                square(x, y).rem_euclid(2) == 0
            })
            .count();
        50.0 + 150.0 * bright as f32 / 64.0
    });
    let found = Harris::default().detect(&img).unwrap();
    // Detection skips a 3σ border (5 px); junctions lie at u = 10.3 … 82.3 and v = 9.6 … 69.6 inside it.
    let expected: Vec<[f64; 2]> =
        (0..7).flat_map(|i| (0..6).map(move |j| [ox + f64::from(i) * side, oy + f64::from(j) * side])).collect();
    assert_eq!(found.len(), expected.len(), "{found:?}");
    // Within 3σ of the image border the replicated edge breaks the symmetry; judge precision inside it.
    for p in expected.iter().filter(|p| p[0] > 15.0 && p[1] > 15.0) {
        let best = found.iter().map(|c| (c.u - p[0]).hypot(c.v - p[1])).fold(f64::INFINITY, f64::min);
        // Gradients cancel at the junction itself, so R has a flat top and the parabola overshoots by up to
        // ~0.2 px: Harris selects points (Cazzaniga et al. 2007 §4.3), Förstner or LSM locates them precisely.
        assert!(best < 0.3, "junction {p:?}: nearest detection {best:.3} px away");
    }
}
