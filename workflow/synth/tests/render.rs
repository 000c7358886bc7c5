//! Geometric consistency of the renderer, each checked by an independent route: a pole's true position,
//! projected with plumbline-geo's camera models, lands on the pole's pixels in the depth image and in the
//! panorama; depth noise has the configured statistics; the body mask covers the vehicle; rendering is
//! deterministic down to the JPEG bytes.
#![allow(clippy::unwrap_used)]

use plumbline_fixtures::synth::{depth_mount, lonely_lights, pano_mount, world};
use plumbline_geo::Point3;
use plumbline_geo::camera::{Equirectangular, Pinhole};
use plumbline_synth::render::{
    DepthNoise, Illumination, Scene, VehicleBody, encode_jpeg, encode_png_gray, encode_png_gray16,
};
use plumbline_synth::render::{render_depth, render_panorama};
use plumbline_synth::world::Epoch;

fn depth_cam() -> Pinhole {
    // The D455 depth stream of Meyer et al. (2023): 1280 × 720, ~87° horizontal field of view.
    Pinhole::new(1280, 720, 640.0, 640.0, 640.0, 360.0, 0.0, 0.0).unwrap()
}

#[test]
fn a_pole_lands_on_its_pixels_in_the_depth_image() {
    let mut checked = 0;
    for seed in [1, 2, 3] {
        let w = world(seed);
        for (pole, body) in lonely_lights(&w, 3.0).into_iter().take(3) {
            let mount = depth_mount();
            let pose = mount.camera_pose(&body);
            let noise = DepthNoise { share: 0.0, ..DepthNoise::realsense(1) };
            let depth = render_depth(&w, Epoch::Mobile, &depth_cam(), &pose, &noise);
            // The axis point 2.2 m above the road (above parked cars), through the geo crate's projection.
            let axis = Point3::new(pole.base[0], pole.base[1], w.config.ground_height + 2.2);
            let px = mount.project(&depth_cam(), &body, &axis).unwrap();
            let z_axis = mount.to_camera(&body, &axis).z();
            let (col, row) = (px.u.floor() as u32, px.v.floor() as u32);
            let d = f64::from(depth.get_pixel(col, row)[0]) / 1000.0;
            // The visible surface is the front of the cylinder: one radius nearer than the axis.
            let r = pole.diameter / 2.0;
            assert!((d - (z_axis - r)).abs() < 0.01, "pole {}: depth {d} vs {}", pole.id, z_axis - r);
            // Beside the pole (two radii plus 3 px away) the depth jumps to the background or no return.
            let off = (r / z_axis * 640.0).ceil() as u32 + 3;
            for c in [col - off, col + off] {
                let b = f64::from(depth.get_pixel(c, row)[0]) / 1000.0;
                assert!(b == 0.0 || b > z_axis + 0.5, "pole {} neighbour {c}: {b}", pole.id);
            }
            checked += 1;
        }
    }
    assert!(checked >= 5, "{checked}");
}

#[test]
fn a_pole_lands_on_its_pixels_in_the_panorama() {
    let mut checked = 0;
    for seed in [1, 2] {
        let w = world(seed);
        let cam = Equirectangular::new(1024, 512).unwrap();
        let light = Illumination { shadows: false, ..Illumination::mobile() };
        for (pole, body) in lonely_lights(&w, 4.0).into_iter().take(3) {
            // Render with and without the pole: the pixels that change are the pole's.
            let mut gone = w.clone();
            gone.poles[pole.id as usize].diameter = 0.0;
            let with = render_panorama(
                &Scene { world: &w, epoch: Epoch::Mobile, light },
                &cam,
                &pano_mount(),
                &body,
                &VehicleBody::van(),
            );
            let without = render_panorama(
                &Scene { world: &gone, epoch: Epoch::Mobile, light },
                &cam,
                &pano_mount(),
                &body,
                &VehicleBody::van(),
            );
            let axis = Point3::new(pole.base[0], pole.base[1], w.config.ground_height + 2.2);
            let px = pano_mount().project(&cam, &body, &axis).unwrap();
            let row = px.v.floor() as u32;
            let changed: Vec<f64> = (0..cam.width)
                .filter(|&c| with.image.get_pixel(c, row) != without.image.get_pixel(c, row))
                .map(|c| f64::from(c) + 0.5)
                .collect();
            assert!(!changed.is_empty(), "pole {} not visible", pole.id);
            let centre = changed.iter().sum::<f64>() / changed.len() as f64;
            let dist = pano_mount().to_camera(&body, &axis).norm();
            let expected_width = pole.diameter / dist * f64::from(cam.width) / std::f64::consts::TAU;
            assert!((centre - px.u).abs() < 1.0, "pole {}: centre {centre} vs projected {}", pole.id, px.u);
            assert!((changed.len() as f64 - expected_width).abs() < 2.0, "width {} vs {expected_width}", changed.len());
            assert!(changed.iter().all(|c| (c - px.u).abs() < expected_width / 2.0 + 1.5));
            checked += 1;
        }
    }
    assert!(checked >= 3, "{checked}");
}

#[test]
fn depth_noise_is_the_configured_share_of_depth() {
    let w = world(4);
    let (_, body) = lonely_lights(&w, 3.0).into_iter().next().unwrap();
    let pose = depth_mount().camera_pose(&body);
    let exact =
        render_depth(&w, Epoch::Mobile, &depth_cam(), &pose, &DepthNoise { share: 0.0, ..DepthNoise::realsense(9) });
    let noisy = render_depth(&w, Epoch::Mobile, &depth_cam(), &pose, &DepthNoise::realsense(9));
    let ratios: Vec<f64> = exact
        .pixels()
        .zip(noisy.pixels())
        .filter(|(e, n)| e[0] > 0 && n[0] > 0)
        .map(|(e, n)| f64::from(n[0]) / f64::from(e[0]) - 1.0)
        .collect();
    assert!(ratios.len() > 200_000, "{}", ratios.len());
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    let sd = (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / ratios.len() as f64).sqrt();
    assert!(mean.abs() < 0.002 && (sd - 0.08).abs() < 0.003, "mean {mean} sd {sd}");
    // Out of range: nothing nearer than 0.4 m or (before noise) beyond 10 m.
    assert!(exact.pixels().all(|p| p[0] == 0 || (400..=10_000).contains(&p[0])));
    let png = encode_png_gray16(&noisy).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn body_mask_covers_the_vehicle_below_and_nothing_above_the_horizon() {
    let w = world(5);
    let (_, body) = lonely_lights(&w, 3.0).into_iter().next().unwrap();
    let cam = Equirectangular::new(512, 256).unwrap();
    let pano = render_panorama(&Scene::mobile(&w), &cam, &pano_mount(), &body, &VehicleBody::van());
    let masked = |c: u32, r: u32| pano.mask.get_pixel(c, r)[0] == 0;
    assert!((0..512).all(|c| masked(c, 255)), "straight down is the roof");
    assert!((0..512).all(|c| (0..128).all(|r| !masked(c, r))), "nothing above the horizon");
    let share = pano.mask.pixels().filter(|p| p[0] == 0).count() as f64 / (512.0 * 256.0);
    // The roof (4.6 × 1.9 m) seen from 1.4 m above it at 0.6 m forward of the IMU.
    assert!((0.1..0.4).contains(&share), "{share}");
    let png = encode_png_gray(&pano.mask).unwrap();
    assert_eq!(image::load_from_memory(&png).unwrap().to_luma8(), pano.mask);
    // Each masked pixel's ray, checked through the geo crate, meets the body box.
    for (c, r, p) in pano.mask.enumerate_pixels().step_by(97) {
        let (o, d) = pano_mount()
            .ray(&cam, &body, plumbline_geo::camera::Pixel::new(f64::from(c) + 0.5, f64::from(r) + 0.5))
            .unwrap();
        let (ob, db) = (body.inverse().transform_point(&o), body.rotation.inverse().apply(&d));
        let van = VehicleBody::van();
        let hits = (0..3).fold((0.0f64, f64::INFINITY), |(t0, t1), k| {
            let (a, b) = ((van.min[k] - ob.p[k]) / db.v[k], (van.max[k] - ob.p[k]) / db.v[k]);
            (t0.max(a.min(b)), t1.min(a.max(b)))
        });
        assert_eq!(p[0] == 0, hits.0 <= hits.1, "pixel {c} {r}");
    }
}

#[test]
fn same_seed_same_jpeg_bytes_on_any_thread_count() {
    let cam = Equirectangular::new(512, 256).unwrap();
    let render = |seed: u64| {
        let w = world(seed);
        let (_, body) = lonely_lights(&w, 3.0).into_iter().next().unwrap();
        encode_jpeg(&render_panorama(&Scene::mobile(&w), &cam, &pano_mount(), &body, &VehicleBody::van()).image, 90)
            .unwrap()
    };
    let (a, b) = (render(6), render(6));
    assert_eq!(a, b);
    // The thread count does not change a pixel.
    let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| render(6));
    assert_eq!(a, single);
    assert_eq!(&a[..2], &[0xFF, 0xD8]);
    assert_ne!(a, render(7));
}
