//! Illumination: buildings cast shadows away from the sun (checked against the sun direction by geometry),
//! and the tone curve maps radiance monotonically with the configured exposure, contrast and gamma.
#![allow(clippy::unwrap_used)]

mod render_common;

use nalgebra::Vector3;
use plumbline_synth::render::{Illumination, Scene};
use plumbline_synth::world::{Epoch, Preset, World, WorldConfig};

/// Ground luminance seen from straight above a point, with and without shadows.
fn seen_from_above(w: &World, light: Illumination, e: f64, n: f64) -> (f32, f32) {
    let o = Vector3::new(e, n, w.config.ground_height + 300.0);
    let d = Vector3::new(0.0, 0.0, -1.0);
    let lum = |l: Illumination| {
        let c = Scene { world: w, epoch: Epoch::Aerial, light: l }.radiance(&o, &d, 1e-4);
        c.iter().sum::<f32>() / 3.0
    };
    (lum(light), lum(Illumination { shadows: false, ..light }))
}

#[test]
fn tall_buildings_shade_the_ground_away_from_the_sun() {
    let (mut shaded, mut lit, mut n) = (0, 0, 0);
    for seed in [3, 4, 5] {
        let w = World::generate(&WorldConfig::new(Preset::District, seed)).unwrap();
        count(&w, &mut shaded, &mut lit, &mut n);
    }
    assert!(n >= 30, "{n}");
    // Every shadow-side point is shaded. The sun side is lit unless a street tree or the buildings across
    // the street shade it, which happens in deep canyons: a minority, but not rare.
    assert_eq!(shaded, n);
    assert!(lit as f64 >= 0.4 * n as f64, "{lit} of {n}");
}

fn count(w: &World, shaded: &mut usize, lit: &mut usize, n: &mut usize) {
    let light = Illumination::aerial();
    let sun = light.sun();
    let away = -Vector3::new(sun.x, sun.y, 0.0).normalize();
    let shadow_len = 1.0 / light.sun_elevation.tan();
    for b in w.buildings.iter().filter(|b| b.shape.height > 20.0) {
        // Leave the footprint along `away`: the point 1 m beyond the building's edge on the shadow side.
        let c = Vector3::new(b.shape.center[0], b.shape.center[1], 0.0);
        let mut s = 0.0;
        while b.shape.contains([c.x + away.x * s, c.y + away.y * s], 0.0) {
            s += 0.05;
        }
        let dark = c + away * (s + 1.0);
        let bright = c - away * (s + 1.0);
        if w.buildings
            .iter()
            .any(|o| o.shape.contains([dark.x, dark.y], 0.3) || o.shape.contains([bright.x, bright.y], 0.3))
        {
            continue;
        }
        // A 1 m offset is inside the shadow of any building taller than tan(elevation) · 1 m.
        assert!(b.shape.height > shadow_len);
        *n += 1;
        let (with, without) = seen_from_above(w, light, dark.x, dark.y);
        if with < 0.7 * without {
            *shaded += 1;
        }
        let (with, without) = seen_from_above(w, light, bright.x, bright.y);
        if (with - without).abs() < 1e-6 {
            *lit += 1;
        }
    }
}

#[test]
fn tone_curve_is_monotonic_and_follows_exposure_and_gamma() {
    let w = render_common::world(1);
    let scene = Scene::aerial(&w);
    let mut last = 0u8;
    for k in 0..=100 {
        let v = k as f32 / 100.0;
        let t = scene.tone([v, v, v])[0];
        assert!(t >= last);
        last = t;
    }
    // Mid-grey maps to 255 · 0.5^(1/γ) when exposure pushes radiance r to 0.5: r = 0.5 / exposure.
    let l = scene.light;
    let t = scene.tone([0.5 / l.exposure; 3])[0];
    assert_eq!(t, (0.5f32.powf(1.0 / l.gamma) * 255.0 + 0.5) as u8);
}
