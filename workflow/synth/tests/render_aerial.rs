//! Panorama ↔ aerial consistency by an independent route: the ground under panorama pixels (ground-truth
//! query), projected into an aerial frame with its own orientation (plumbline-geo's OPK + pinhole), lands on the
//! same texture — high zero-mean NCC at the true pose; with a known error in the vehicle pose, the NCC peak
//! moves by exactly that error.
#![allow(clippy::unwrap_used)]

use image::RgbImage;
use plumbline_fixtures::synth::{body_at, pano_mount, world};
use plumbline_geo::camera::{CameraModel, Equirectangular, Pinhole, Pixel};
use plumbline_geo::{MapFromBody, MapFromCamera, OmegaPhiKappa, Point3, Vec3};
use plumbline_synth::render::{
    AerialOptics, Illumination, Scene, VehicleBody, ground_truth, render_aerial, render_panorama,
};
use plumbline_synth::world::{Epoch, Surface, World};

fn lum(img: &RgbImage, c: u32, r: u32) -> f64 {
    let p = img.get_pixel(c, r);
    (f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2])) / 3.0
}

/// Bilinear luminance at a continuous pixel position (pixel centres at +0.5).
fn bilinear(img: &RgbImage, px: Pixel) -> Option<f64> {
    let (x, y) = (px.u - 0.5, px.v - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    if x0 < 0.0 || y0 < 0.0 || x0 + 1.0 >= f64::from(img.width()) || y0 + 1.0 >= f64::from(img.height()) {
        return None;
    }
    let (fx, fy, c, r) = (x - x0, y - y0, x0 as u32, y0 as u32);
    let top = lum(img, c, r) * (1.0 - fx) + lum(img, c + 1, r) * fx;
    let bottom = lum(img, c, r + 1) * (1.0 - fx) + lum(img, c + 1, r + 1) * fx;
    Some(top * (1.0 - fy) + bottom * fy)
}

fn ncc(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt()
}

struct Aerial {
    cam: Pinhole,
    pose: MapFromCamera,
    image: RgbImage,
}

/// A 12.5 cm GSD frame from 1000 m, slightly tilted, centred near (e, n).
fn aerial_over(w: &World, e: f64, n: f64) -> Aerial {
    let cam = Pinhole::new(900, 900, 8000.0, 8000.0, 452.3, 447.8, -1.0, 2.0).unwrap();
    let opk = OmegaPhiKappa::from_degrees(0.8, -0.6, 12.0);
    let pose = MapFromCamera::new(opk.to_rotation(), Point3::new(e + 12.0, n - 9.0, w.config.ground_height + 1000.0));
    // Shadows off in both epochs: this test is about geometry; shadow differences are realistic but not
    // what it checks (exposure, contrast, gamma, cars and worn paint still differ).
    let light = Illumination { shadows: false, ..Illumination::aerial() };
    let image = render_aerial(&Scene { world: w, epoch: Epoch::Aerial, light }, &cam, &pose, &AerialOptics::typical(3));
    Aerial { cam, pose, image }
}

fn project(a: &Aerial, p: &Point3<plumbline_geo::Map>) -> Option<Pixel> {
    let v: Vec3<plumbline_geo::Camera> = a.pose.inverse().transform_point(p) - Point3::origin();
    a.cam.project(&v)
}

/// Panorama luminances of ground pixels the aerial camera also sees, their true ground points and pixels.
fn ground_samples(
    w: &World,
    aerial: &Aerial,
    pano: &RgbImage,
    mask: &image::GrayImage,
    cam: &Equirectangular,
    truth: &MapFromBody,
) -> (Vec<f64>, Vec<Point3<plumbline_geo::Map>>, Vec<Pixel>) {
    let pose = pano_mount().camera_pose(truth);
    let (mut lums, mut pts, mut pixels) = (Vec::new(), Vec::new(), Vec::new());
    for r in (cam.height * 58 / 100..cam.height * 76 / 100).step_by(3) {
        for c in (0..cam.width).step_by(3) {
            if mask.get_pixel(c, r)[0] == 0 {
                continue;
            }
            let px = Pixel::new(f64::from(c) + 0.5, f64::from(r) + 0.5);
            if let Some((p, Surface::Ground)) = ground_truth(w, Epoch::Mobile, cam, &pose, px)
                && visible_from_the_air(w, aerial, &p)
            {
                lums.push(lum(pano, c, r));
                pts.push(p);
                pixels.push(px);
            }
        }
    }
    (lums, pts, pixels)
}

/// The aerial camera sees the point (no crown, roof, facade or aerial-epoch car in between).
fn visible_from_the_air(w: &World, a: &Aerial, p: &Point3<plumbline_geo::Map>) -> bool {
    let Some(px) = project(a, p) else { return false };
    match ground_truth(w, Epoch::Aerial, &a.cam, &a.pose, px) {
        Some((q, Surface::Ground)) => (q - *p).norm() < 0.05,
        _ => false,
    }
}

/// NCC of the panorama samples against the aerial image at the points shifted by (de, dn).
fn score(a: &Aerial, lums: &[f64], pts: &[Point3<plumbline_geo::Map>], de: f64, dn: f64) -> f64 {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for (l, p) in lums.iter().zip(pts) {
        if let Some(v) = project(a, &(*p + Vec3::new(de, dn, 0.0))).and_then(|px| bilinear(&a.image, px)) {
            x.push(*l);
            y.push(v);
        }
    }
    ncc(&x, &y)
}

/// The best (NCC, de, dn) over a square grid of shifts around `centre`.
fn search(
    a: &Aerial,
    lums: &[f64],
    pts: &[Point3<plumbline_geo::Map>],
    centre: (f64, f64),
    step: f64,
    half: i32,
) -> (f64, f64, f64) {
    let mut best = (f64::NEG_INFINITY, 0.0, 0.0);
    for i in -half..=half {
        for j in -half..=half {
            let (de, dn) = (centre.0 + f64::from(i) * step, centre.1 + f64::from(j) * step);
            let s = score(a, lums, pts, de, dn);
            if s > best.0 {
                best = (s, de, dn);
            }
        }
    }
    best
}

#[test]
fn ground_under_panorama_pixels_matches_the_aerial_texture_and_moves_with_the_pose_error() {
    let cam = Equirectangular::new(2048, 1024).unwrap();
    let error = (0.6, -0.4);
    let mut checked = 0;
    for seed in [11, 12] {
        let w = world(seed);
        let route = w.route(seed, 400.0);
        for k in [20, 45, 70] {
            let (p, q) = (route.waypoints[k], route.waypoints[k + 1]);
            let heading = (q.east - p.east).atan2(q.north - p.north);
            let truth = body_at(&w, p.east, p.north, heading);
            let light = Illumination { shadows: false, ..Illumination::mobile() };
            let pano = render_panorama(
                &Scene { world: &w, epoch: Epoch::Mobile, light },
                &cam,
                &pano_mount(),
                &truth,
                &VehicleBody::van(),
            );
            let aerial = aerial_over(&w, p.east, p.north);
            let (lums, pts, pixels) = ground_samples(&w, &aerial, &pano.image, &pano.mask, &cam, &truth);
            assert!(lums.len() > 10_000, "{}", lums.len());
            let at_truth = score(&aerial, &lums, &pts, 0.0, 0.0);
            assert!(at_truth > 0.7, "seed {seed} waypoint {k}: NCC {at_truth}");
            // The same pixels georeferenced with a vehicle pose off by `error`.
            let dg = body_at(&w, p.east + error.0, p.north + error.1, heading);
            let dg_pose = pano_mount().camera_pose(&dg);
            let (mut lums_dg, mut pts_dg, mut pts_same) = (Vec::new(), Vec::new(), Vec::new());
            for ((l, px), p_true) in lums.iter().zip(&pixels).zip(&pts) {
                if let Some((q, Surface::Ground)) = ground_truth(&w, Epoch::Mobile, &cam, &dg_pose, *px) {
                    lums_dg.push(*l);
                    pts_dg.push(q);
                    pts_same.push(*p_true);
                }
            }
            let at_dg = score(&aerial, &lums_dg, &pts_dg, 0.0, 0.0);
            assert!(at_dg < at_truth - 0.03, "seed {seed} waypoint {k}: {at_dg} vs {at_truth}");
            // Searching shifts of the DG points finds the error (coarse 0.2 m grid, then 0.05 m around the best).
            let coarse = search(&aerial, &lums_dg, &pts_dg, (0.0, 0.0), 0.2, 6);
            let best = search(&aerial, &lums_dg, &pts_dg, (coarse.1, coarse.2), 0.05, 4);
            assert!(
                (best.1 + error.0).abs() < 0.06 && (best.2 + error.1).abs() < 0.06,
                "seed {seed} waypoint {k}: {best:?}"
            );
            // The peak is the true points' NCC over the same pixels (those whose DG ray still meets the ground).
            let truth_same = score(&aerial, &lums_dg, &pts_same, 0.0, 0.0);
            assert!((best.0 - truth_same).abs() < 0.005, "seed {seed} waypoint {k}: peak {best:?} vs {truth_same}");
            checked += 1;
        }
    }
    assert_eq!(checked, 6);
}
