//! Illumination: buildings cast shadows away from the sun (checked against the sun direction by geometry),
//! and the tone curve maps radiance monotonically with the configured exposure, contrast and gamma. Sensor
//! realism: each nuisance of a rig and of the radiometry is present where it belongs and of its size.
#![allow(clippy::unwrap_used)]

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
    let w = plumbline_fixtures::synth::world(1);
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

mod realism {
    use image::RgbImage;
    use nalgebra::Vector3;
    use plumbline_fixtures::synth::{lonely_lights, pano_mount, world};
    use plumbline_geo::camera::{Equirectangular, Pinhole};
    use plumbline_geo::{MapFromCamera, OmegaPhiKappa, Point3};
    use plumbline_synth::render::{
        AerialOptics, Radiometry, Realism, RealismLevel, Rig, Scene, VehicleBody, render_aerial_with, render_panorama,
        render_panorama_with,
    };

    const W: u32 = 1024;
    const H: u32 = 512;

    /// A panorama beside a street light, ideal and through `realism` while moving at `speed` m/s forward.
    fn pair(realism: Realism, speed: f64) -> (RgbImage, RgbImage, image::GrayImage) {
        let w = world(1);
        let (_, body) = lonely_lights(&w, 4.0).into_iter().next().unwrap();
        let cam = Equirectangular::new(W, H).unwrap();
        let scene = Scene::mobile(&w);
        let forward = body.rotation.apply(&plumbline_geo::Vec3::new(1.0, 0.0, 0.0)).v;
        let ideal = render_panorama(&scene, &cam, &pano_mount(), &body, &VehicleBody::van());
        let real = render_panorama_with(
            &scene,
            &cam,
            &pano_mount(),
            &body,
            &VehicleBody::van(),
            &(forward * speed),
            &realism,
            5,
        );
        (ideal.image, real.image, ideal.mask)
    }

    fn with_rig(rig: Rig) -> Realism {
        Realism { rig, ..Realism::of(RealismLevel::Ideal) }
    }

    fn with_street(street: Radiometry) -> Realism {
        Realism { street, rig: Rig { sub_cameras: 6, ..Rig::IDEAL }, ..Realism::of(RealismLevel::Ideal) }
    }

    fn lum(img: &RgbImage, c: u32, r: u32) -> f64 {
        let p = img.get_pixel(c % W, r);
        (f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2])) / 3.0
    }

    /// Mean |difference| of luminance between `a` and `b` over columns `cols` and rows `rows`.
    fn diff(a: &RgbImage, b: &RgbImage, cols: &[u32], rows: std::ops::Range<u32>) -> f64 {
        let mut sum = 0.0;
        for &c in cols {
            for r in rows.clone() {
                sum += (lum(a, c, r) - lum(b, c, r)).abs();
            }
        }
        sum / (cols.len() * rows.len()) as f64
    }

    /// The six-camera rig's borders: the last column of each sub-camera.
    fn borders() -> Vec<u32> {
        let rig = Rig { sub_cameras: 6, ..Rig::IDEAL };
        (0..W).filter(|&c| rig.sector(c, W) != rig.sector((c + 1) % W, W)).collect()
    }

    /// Mean |step| between neighbouring columns across the sub-camera borders and elsewhere, rows `rows`.
    fn seam_and_interior(img: &RgbImage, rows: std::ops::Range<u32>) -> (f64, f64) {
        let step = |c: u32| rows.clone().map(|r| (lum(img, c, r) - lum(img, c + 1, r)).abs()).sum::<f64>();
        let borders = borders();
        let seam = borders.iter().map(|&c| step(c)).sum::<f64>() / borders.len() as f64;
        let others: Vec<u32> = (0..W).filter(|c| borders.iter().all(|b| c.abs_diff(*b) > 3)).collect();
        let interior = others.iter().map(|&c| step(c)).sum::<f64>() / others.len() as f64;
        let n = rows.len() as f64;
        (seam / n, interior / n)
    }

    fn border_columns() -> Vec<u32> {
        borders().into_iter().flat_map(|c| [c, (c + 1) % W]).collect()
    }

    fn axis_columns() -> Vec<u32> {
        let rig = Rig { sub_cameras: 6, ..Rig::IDEAL };
        (0..6).map(|k| rig.axis_column(k, W).floor() as u32).flat_map(|c| [c, c + 1]).collect()
    }

    #[test]
    fn exposure_steps_make_seams_at_the_sub_camera_borders() {
        let (ideal, real, _) = pair(with_rig(Rig { sub_cameras: 6, exposure_step: 0.15, ..Rig::IDEAL }), 0.0);
        let (seam, interior) = seam_and_interior(&real, 0..H);
        let (ideal_seam, ideal_interior) = seam_and_interior(&ideal, 0..H);
        assert!(ideal_seam < 2.0 * ideal_interior, "ideal: seam {ideal_seam:.2}, interior {ideal_interior:.2}");
        assert!(seam > 2.0 * interior && seam > ideal_seam + 2.0, "rig: seam {seam:.2}, interior {interior:.2}");
    }

    #[test]
    fn sub_camera_centres_give_parallax_at_the_seams() {
        let (ideal, real, _) = pair(with_rig(Rig { sub_cameras: 6, radius_m: 0.1, ..Rig::IDEAL }), 0.0);
        // The ground below the horizon: near, so 10 cm between centres moves it by pixels across a seam.
        let ground = H * 5 / 8..H * 7 / 8;
        let (seam, interior) = seam_and_interior(&real, ground.clone());
        let (ideal_seam, ideal_interior) = seam_and_interior(&ideal, ground);
        assert!(ideal_seam < 1.5 * ideal_interior, "ideal: seam {ideal_seam:.2}, interior {ideal_interior:.2}");
        assert!(seam > 2.0 * interior, "rig: seam {seam:.2}, interior {interior:.2}");
    }

    #[test]
    fn a_rolling_shutter_shifts_the_top_and_bottom_rows_not_the_middle() {
        let rig = Rig { sub_cameras: 6, readout_s: 0.033, ..Rig::IDEAL };
        let (ideal, real, _) = pair(with_rig(rig), 14.0);
        let all: Vec<u32> = (0..W).collect();
        let middle = diff(&ideal, &real, &all, H / 2 - 4..H / 2 + 4);
        let bottom = diff(&ideal, &real, &all, H * 11 / 16..H * 13 / 16);
        assert!(bottom > 1.0 && middle < 0.2 * bottom, "middle rows {middle:.2}, bottom rows {bottom:.2}");
    }

    #[test]
    fn motion_blur_is_the_exposure_averaged_over_the_drive() {
        // 14 cm of travel during the exposure: a few pixels on the ground of a 1024-pixel panorama.
        let rig = Rig { sub_cameras: 6, exposure_s: 0.01, ..Rig::IDEAL };
        let (ideal, real, mask) = pair(with_rig(rig), 14.0);
        // The independent route: ideal panoramas from 9 positions along the travel, averaged.
        let w = world(1);
        let (_, body) = lonely_lights(&w, 4.0).into_iter().next().unwrap();
        let cam = Equirectangular::new(W, H).unwrap();
        let forward = body.rotation.apply(&plumbline_geo::Vec3::new(1.0, 0.0, 0.0)).v;
        let mut average = vec![0f64; (W * H * 3) as usize];
        for k in 0..9 {
            let at = body.translation.p + forward * (0.14 * (f64::from(k) / 8.0 - 0.5));
            let moved = plumbline_geo::MapFromBody::new(body.rotation, Point3::new(at.x, at.y, at.z));
            let img = render_panorama(&Scene::mobile(&w), &cam, &pano_mount(), &moved, &VehicleBody::van()).image;
            for (a, v) in average.iter_mut().zip(img.as_raw()) {
                *a += f64::from(*v) / 9.0;
            }
        }
        // Where the travel changes the picture (the sharp image is over 2 levels off the average; elsewhere
        // both sit at the quantisation floor).
        let off = |img: &RgbImage, i: usize| {
            (0..3).map(|k| (f64::from(img.as_raw()[i + k]) - average[i + k]).abs()).sum::<f64>() / 3.0
        };
        let (mut sharp, mut blurred, mut n) = (0.0, 0.0, 0.0);
        for r in H / 2 + 8..H * 7 / 8 {
            for c in (0..W).filter(|&c| mask.get_pixel(c, r)[0] == 255) {
                let i = ((r * W + c) * 3) as usize;
                if off(&ideal, i) > 2.0 {
                    (sharp, blurred, n) = (sharp + off(&ideal, i), blurred + off(&real, i), n + 1.0);
                }
            }
        }
        let (sharp, blurred) = (sharp / n, blurred / n);
        assert!(
            n > 1000.0 && blurred < 0.5 * sharp,
            "{n} pixels: |sharp − average| {sharp:.3}, |blurred − average| {blurred:.3}"
        );
        let all: Vec<u32> = (0..W).collect();
        assert_eq!(diff(&ideal, &real, &all, 0..8), 0.0, "the sky is infinitely far: no smear");
    }

    #[test]
    fn white_balance_vignetting_and_noise_are_of_their_size() {
        let harsh = Realism::of(RealismLevel::Harsh).street;
        let only = |r: Radiometry| pair(with_street(r), 0.0);
        // White balance: red over blue rises.
        let (ideal, real, mask) = only(Radiometry { white_balance: harsh.white_balance, ..Radiometry::IDEAL });
        let ratio = |img: &RgbImage| {
            let (mut r, mut b) = (0.0, 0.0);
            for (p, m) in img.pixels().zip(mask.pixels()) {
                if m[0] == 255 {
                    (r, b) = (r + f64::from(p[0]), b + f64::from(p[2]));
                }
            }
            r / b
        };
        assert!(ratio(&real) > 1.1 * ratio(&ideal), "R/B {:.3} → {:.3}", ratio(&ideal), ratio(&real));
        // Vignetting: near the horizon, darker at the sub-camera borders, untouched on the axes.
        let (ideal, real, _) = only(Radiometry { vignetting: 0.35, ..Radiometry::IDEAL });
        let mean = |img: &RgbImage, cols: &[u32]| {
            cols.iter()
                .flat_map(|&c| (H / 2 - 16..H / 2 + 16).map(move |r| (c, r)))
                .map(|(c, r)| lum(img, c, r))
                .sum::<f64>()
        };
        let border = mean(&real, &border_columns()) / mean(&ideal, &border_columns());
        let axis = mean(&real, &axis_columns()) / mean(&ideal, &axis_columns());
        assert!(border < 0.85 && axis > 0.98, "border {border:.3}, axis {axis:.3}");
        // Noise: 4 levels at mid-grey, ∝ √signal.
        let (ideal, real, mask) = only(Radiometry { noise: 4.0, ..Radiometry::IDEAL });
        let d: Vec<f64> = ideal
            .pixels()
            .zip(real.pixels())
            .zip(mask.pixels())
            .filter(|((a, _), m)| m[0] == 255 && (100..156).contains(&a[1]))
            .map(|((a, b), _)| f64::from(b[1]) - f64::from(a[1]))
            .collect();
        let sd = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
        assert!(d.len() > 10_000 && (3.4..4.6).contains(&sd), "{} samples, sd {sd:.2}", d.len());
    }

    #[test]
    fn an_aerial_frame_is_vignetted_and_tinted_by_its_radiometry() {
        let w = world(1);
        let cam = Pinhole::new(400, 300, 2000.0, 2000.0, 200.0, 150.0, 0.0, 0.0).unwrap();
        let [e, n] = w.streets[0].points[0];
        let pose = MapFromCamera::new(
            OmegaPhiKappa::from_degrees(0.0, 0.0, 0.0).to_rotation(),
            Point3::new(e, n, w.config.ground_height + 300.0),
        );
        let optics = AerialOptics { blur_px: 0.0, noise: 0.0, seed: 1 };
        let scene = Scene::aerial(&w);
        let ideal = render_aerial_with(&scene, &cam, &pose, &optics, &Radiometry::IDEAL);
        let vignetted = Radiometry { vignetting: 0.25, ..Radiometry::IDEAL };
        let real = render_aerial_with(&scene, &cam, &pose, &optics, &vignetted);
        let mean = |img: &RgbImage, centre: bool| {
            let keep = |c: u32, r: u32| {
                let d = (f64::from(c) - 200.0).hypot(f64::from(r) - 150.0);
                if centre { d < 40.0 } else { d > 220.0 }
            };
            let v: Vec<f64> =
                img.enumerate_pixels().filter(|(c, r, _)| keep(*c, *r)).map(|(_, _, p)| f64::from(p[1])).collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        let (centre, corners) = (mean(&real, true) / mean(&ideal, true), mean(&real, false) / mean(&ideal, false));
        assert!(centre > 0.98 && corners < 0.9, "centre {centre:.3}, corners {corners:.3}");
        let _ = Vector3::<f64>::zeros();
    }
}
