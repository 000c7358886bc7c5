//! Ground truth for the registration report: how much road paint (lane lines, stop lines, zebra crossings,
//! arrows) visible at both epochs lies in the ground patch around a panorama, from the synthetic world.
//!
//! A sample counts as paint when it lies on the carriageway of a street with markings (the street whose
//! carriageway is nearest, as the texture decides) and is bright in both epochs' albedo: asphalt stays below
//! 0.27 in luma, fresh paint is 0.86 and paint worn to half strength still ≥ 0.5 (synth `texture`).

use plumbline_synth::texture::Texture;
use plumbline_synth::world::{Epoch, Street, World, polyline};
use rayon::prelude::*;

/// Sample spacing (and footprint) of the paint census, metres; lane lines are 0.12 m wide.
const STEP: f64 = 0.1;
/// Luma above which a carriageway sample is paint (asphalt ≤ 0.27, worn paint ≥ 0.5) in the MM epoch.
const PAINT_MOBILE: f32 = 0.4;
/// The same in the aerial epoch, where paint is worn more (strength down to ~0.3 still shows).
const PAINT_AERIAL: f32 = 0.3;

fn luma(c: [f32; 3]) -> f32 {
    0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]
}

/// The street whose carriageway is nearest to `p` among `streets`, with the distance from its centre line.
fn nearest_street<'w>(streets: &[&'w Street], p: [f64; 2]) -> Option<(&'w Street, f64)> {
    streets
        .iter()
        .map(|st| (*st, polyline::nearest(&st.points, &st.cum, p).t.abs()))
        .min_by(|a, b| (a.1 - a.0.carriageway() / 2.0).total_cmp(&(b.1 - b.0.carriageway() / 2.0)))
}

/// Paint area (m²) visible in both epochs inside the square of half-size `half` (m) around `centre`.
pub fn paint_area(world: &World, centre: [f64; 2], half: f64) -> f64 {
    let reach = half * std::f64::consts::SQRT_2;
    let streets: Vec<&Street> = world
        .streets
        .iter()
        .filter(|st| polyline::nearest(&st.points, &st.cum, centre).t.abs() < reach + st.half_corridor())
        .collect();
    let (mobile, aerial) = (Texture::new(world, Epoch::Mobile), Texture::new(world, Epoch::Aerial));
    let n = (2.0 * half / STEP).round() as usize;
    let painted: usize = (0..n)
        .into_par_iter()
        .map(|r| {
            let north = centre[1] - half + (r as f64 + 0.5) * STEP;
            (0..n)
                .filter(|&c| {
                    let east = centre[0] - half + (c as f64 + 0.5) * STEP;
                    let on_marked_carriageway = nearest_street(&streets, [east, north])
                        .is_some_and(|(st, t)| st.markings && t < st.carriageway() / 2.0);
                    on_marked_carriageway
                        && luma(mobile.albedo(east, north, STEP)) > PAINT_MOBILE
                        && luma(aerial.albedo(east, north, STEP)) > PAINT_AERIAL
                })
                .count()
        })
        .sum();
    painted as f64 * STEP * STEP
}
