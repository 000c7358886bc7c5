//! The per-pixel ground truth of a panorama, each checked by an independent route: ground pixels' ranges
//! against the ray through the pixel intersected with the flat ground (`plumbline_geo::dg`), a pole's true
//! axis projected into the panorama lands on pole pixels whose points lie on the pole's surface, and the
//! vehicle pixels are exactly the panorama's mask.
#![allow(clippy::unwrap_used)]

use plumbline_fixtures::synth::{lonely_lights, pano_mount, world};
use plumbline_geo::Point3;
use plumbline_geo::camera::{Equirectangular, Pixel};
use plumbline_geo::dg::intersect_height;
use plumbline_synth::render::{Scene, SurfaceClass, VehicleBody, render_panorama, render_surfaces, surface_point};
use plumbline_synth::world::Epoch;

#[test]
fn ground_pixels_range_to_the_ground_plane_along_their_ray() {
    let cam = Equirectangular::new(512, 256).unwrap();
    let mount = pano_mount();
    let (mut ground, mut checked) = (0usize, 0usize);
    for seed in [1, 2] {
        let w = world(seed);
        let g = w.config.ground_height;
        for (_, body) in lonely_lights(&w, 4.0).into_iter().take(2) {
            let truth = render_surfaces(&w, Epoch::Mobile, &cam, &mount, &body, &VehicleBody::van());
            let pose = mount.camera_pose(&body);
            for row in (0..256).step_by(3) {
                for col in (0..512).step_by(3) {
                    let class = SurfaceClass::from_code(truth.class.get_pixel(col, row)[0]).unwrap();
                    if class != SurfaceClass::Ground {
                        continue;
                    }
                    ground += 1;
                    let range = f64::from(truth.range_mm.get_pixel(col, row)[0]) / 1000.0;
                    let centre = Pixel::new(f64::from(col) + 0.5, f64::from(row) + 0.5);
                    let (c, d) = mount.ray(&cam, &body, centre).unwrap();
                    let on_plane = intersect_height(&c, &d, g).unwrap();
                    let expected = (on_plane.p - c.p).norm();
                    assert!((range - expected).abs() < 0.001, "seed {seed} ({col},{row}): {range} vs {expected}");
                    let p = surface_point(&cam, &pose, col, row, range).unwrap();
                    assert!((p.z() - g).abs() < 0.001 && (p.p - on_plane.p).norm() < 0.001);
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 2000 && checked == ground, "{checked} ground pixels checked of {ground}");
}

#[test]
fn a_poles_true_axis_lands_on_pole_pixels_on_its_surface() {
    let cam = Equirectangular::new(1024, 512).unwrap();
    let mount = pano_mount();
    let mut n = 0;
    for seed in [1, 2, 3] {
        let w = world(seed);
        for (pole, body) in lonely_lights(&w, 4.0).into_iter().take(3) {
            let truth = render_surfaces(&w, Epoch::Mobile, &cam, &mount, &body, &VehicleBody::van());
            let pose = mount.camera_pose(&body);
            let r = pole.diameter / 2.0;
            for z in [1.6, 2.2, 2.8] {
                let axis = Point3::new(pole.base[0], pole.base[1], w.config.ground_height + z);
                let px = mount.project(&cam, &body, &axis).unwrap();
                let (col, row) = (px.u.floor() as u32, px.v.floor() as u32);
                let class = SurfaceClass::from_code(truth.class.get_pixel(col, row)[0]).unwrap();
                assert_eq!(class, SurfaceClass::Pole, "seed {seed} pole {} at {z} m", pole.id);
                let range = f64::from(truth.range_mm.get_pixel(col, row)[0]) / 1000.0;
                let p = surface_point(&cam, &pose, col, row, range).unwrap();
                let off_axis = (p.x() - pole.base[0]).hypot(p.y() - pole.base[1]);
                assert!((off_axis - r).abs() < 0.005, "seed {seed}: {off_axis} m off the axis, radius {r}");
                // The pixel centre is within a pixel of the projected axis point: 1.5 pixel footprints.
                let footprint = 1.5 * range * std::f64::consts::TAU / 1024.0;
                assert!((p.z() - axis.z()).abs() < footprint, "seed {seed}: height {} vs {}", p.z(), axis.z());
                n += 1;
            }
        }
    }
    assert!(n >= 18, "{n} pole samples");
}

#[test]
fn vehicle_pixels_are_the_panoramas_mask() {
    let w = world(1);
    let cam = Equirectangular::new(256, 128).unwrap();
    let (_, body) = lonely_lights(&w, 4.0).into_iter().next().unwrap();
    let vehicle = VehicleBody::van();
    let truth = render_surfaces(&w, Epoch::Mobile, &cam, &pano_mount(), &body, &vehicle);
    let pano = render_panorama(&Scene::mobile(&w), &cam, &pano_mount(), &body, &vehicle);
    let mut vehicle_px = 0;
    for (m, c) in pano.mask.pixels().zip(truth.class.pixels()) {
        let is_vehicle = c[0] == SurfaceClass::Vehicle as u8;
        assert_eq!(m[0] == 0, is_vehicle);
        vehicle_px += usize::from(is_vehicle);
        // Nothing is stored where the vehicle hides the scene.
    }
    assert!(vehicle_px > 100, "{vehicle_px} vehicle pixels");
    let none_with_range =
        truth.class.pixels().zip(truth.range_mm.pixels()).filter(|(c, r)| matches!(c[0], 0 | 7) && r[0] != 0).count();
    assert_eq!(none_with_range, 0);
}
