//! End-to-end test of the `city` preset's aerial products (one short city simulated once, several checks):
//! the campaign validates with its frames, orthophoto and terrain mosaics; the ground under panorama pixels
//! (per-pixel truth, true pose), projected into the aerial frames that see it with the written orientations,
//! lands on the same texture — the zero-mean NCC peaks at no shift, for panoramas of every leg; and the VRT
//! mosaics read back through GDAL with each tile's pixels at each tile's georeference, across the borders
//! between tiles made for different legs; the road-marking truth written leg by leg is the city's own.

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

use crate::support;

use std::collections::HashMap;

use image::GrayImage;
use plumbline_geo::camera::{CameraModel, Equirectangular, MetricInterior, Pinhole, Pixel};
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::{Attitude, Map, MapFromBody, MapFromCamera, OmegaPhiKappa, Point3, Vec3};
use plumbline_runtime::gdal_read::{MapBox, RasterSource};
use plumbline_synth::render::ground_truth;
use plumbline_synth::world::city::City;
use plumbline_synth::world::{Epoch, Preset, Surface, World, WorldConfig};
use support::plumbline;

type Row = HashMap<String, String>;

/// Rows of a CSV file as maps from header to value.
fn csv_rows(path: &str) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(str::to_owned).collect();
    lines.map(|l| header.iter().cloned().zip(l.split(',').map(str::to_owned)).collect()).collect()
}

fn f(row: &Row, key: &str) -> f64 {
    row[key].parse().unwrap()
}

/// A 0.6 km city (two legs and a bit), small panoramas: the same arguments as the simulate test's city.
fn simulate(dir: &tempfile::TempDir) -> String {
    let out = dir.path().join("city").to_str().unwrap().to_owned();
    let sizes = ["--panorama-width", "512", "--panorama-spacing", "40", "--depth-rate", "0.1"];
    let args = [&["simulate", "--preset", "city", "--length", "0.6km", "--seed", "3"][..], &sizes, &["--out", &out]];
    plumbline(&args.concat()).run().success();
    out
}

/// An aerial frame: camera, written (AT-reported) orientation, high-passed luminance.
struct Frame {
    cam: Pinhole,
    pose: MapFromCamera,
    truth: MapFromCamera,
    fine: Vec<f64>,
}

impl Frame {
    fn pixel(&self, p: &Point3<Map>) -> Option<Pixel> {
        let v: Vec3<_> = self.pose.inverse().transform_point(p) - Point3::origin();
        self.cam.project(&v).filter(|px| px.u > 1.0 && px.v > 1.0 && px.u < 998.0 && px.v < 748.0)
    }

    /// Bilinear luminance (pixel centres at +0.5).
    fn lum(&self, px: Pixel) -> f64 {
        let (x, y) = (px.u - 0.5, px.v - 0.5);
        let (c, r, fx, fy) = (x.floor() as u32, y.floor() as u32, x - x.floor(), y - y.floor());
        let g = |c: u32, r: u32| self.fine[r as usize * self.cam.width as usize + c as usize];
        let top = g(c, r) * (1.0 - fx) + g(c + 1, r) * fx;
        top * (1.0 - fy) + (g(c, r + 1) * (1.0 - fx) + g(c + 1, r + 1) * fx) * fy
    }
}

/// Luminance minus its mean over the (2r+1)² neighbourhood: the fine texture (markings, paving, kerbs), without
/// the broad shading that differs between the epochs (sun, exposure).
fn high_pass(image: &GrayImage, r: usize) -> Vec<f64> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    // Integral image with a zero first row and column.
    let mut sum = vec![0.0; (w + 1) * (h + 1)];
    for row in 0..h {
        for c in 0..w {
            let v = f64::from(image.get_pixel(c as u32, row as u32)[0]);
            sum[(row + 1) * (w + 1) + c + 1] =
                v + sum[row * (w + 1) + c + 1] + sum[(row + 1) * (w + 1) + c] - sum[row * (w + 1) + c];
        }
    }
    let mut out = vec![0.0; w * h];
    for row in 0..h {
        let (r0, r1) = (row.saturating_sub(r), (row + r + 1).min(h));
        for c in 0..w {
            let (c0, c1) = (c.saturating_sub(r), (c + r + 1).min(w));
            let s = sum[r1 * (w + 1) + c1] - sum[r0 * (w + 1) + c1] - sum[r1 * (w + 1) + c0] + sum[r0 * (w + 1) + c0];
            out[row * w + c] = f64::from(image.get_pixel(c as u32, row as u32)[0]) - s / ((r1 - r0) * (c1 - c0)) as f64;
        }
    }
    out
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

/// The block's frames with the manifest's interior orientation and the written exterior orientations.
fn frames(out: &str, manifest: &plumbline_campaign::manifest::ManifestV1) -> Vec<Frame> {
    let block = manifest.aerial.as_ref().unwrap().frames.as_ref().unwrap();
    let i = &block.interior;
    let metric = MetricInterior {
        focal_mm: i.focal_length_mm,
        xp_mm: i.principal_point_mm[0],
        yp_mm: i.principal_point_mm[1],
        k1: i.k1,
        k2: i.k2,
        pixel_mm: i.pixel_size_mm,
        width: i.width_px,
        height: i.height_px,
    };
    let cam = Pinhole::from_metric(&metric).unwrap();
    let pose = |r: &Row| {
        let rotation = OmegaPhiKappa::from_degrees(f(r, "omega_deg"), f(r, "phi_deg"), f(r, "kappa_deg"));
        MapFromCamera::new(rotation.to_rotation(), Point3::new(f(r, "x"), f(r, "y"), f(r, "z")))
    };
    let rows = csv_rows(&format!("{out}/aerial/exterior_orientation.csv"));
    let truth = csv_rows(&format!("{out}/truth/aerial_orientation.csv"));
    rows.iter()
        .zip(&truth)
        .map(|(r, t)| {
            let image = image::open(format!("{out}/aerial/frames/{}", r["file"])).unwrap().to_luma8();
            Frame { cam, pose: pose(r), truth: pose(t), fine: high_pass(&image, 2) }
        })
        .collect()
}

/// Luminance and true ground point of the panorama's ground pixels 3–15 m from the camera (per-pixel truth).
fn ground_samples(out: &str, img: &Row, mount: &CameraMount, cam: &Equirectangular) -> Vec<(f64, Point3<Map>)> {
    let attitude = Attitude::from_degrees(f(img, "roll_deg"), f(img, "pitch_deg"), f(img, "heading_deg"));
    let body =
        MapFromBody::new(attitude.to_rotation(), Point3::new(f(img, "easting"), f(img, "northing"), f(img, "height")));
    let pose = mount.camera_pose(&body);
    let id = &img["image_id"];
    let pano = image::open(format!("{out}/panoramas/{id}.jpg")).unwrap().to_luma8();
    let fine = high_pass(&pano, 3);
    let range = image::open(format!("{out}/truth/pixels/{id}_range.png")).unwrap().to_luma16();
    let class = image::open(format!("{out}/truth/pixels/{id}_class.png")).unwrap().to_luma8();
    let mut samples = Vec::new();
    for row in (cam.height / 2..cam.height).step_by(3) {
        for col in (0..cam.width).step_by(3) {
            let metres = f64::from(range.get_pixel(col, row)[0]) / 1000.0;
            if class.get_pixel(col, row)[0] != 1 || !(3.0..15.0).contains(&metres) {
                continue;
            }
            let lum = fine[(row * cam.width + col) as usize];
            samples.push((lum, plumbline_synth::render::surface_point(cam, &pose, col, row, metres).unwrap()));
        }
    }
    samples
}

/// The samples the frame sees: the first surface along the TRUE aerial ray through the sample's pixel is the
/// ground at the sample (not a roof, facade, crown or a car of the aerial epoch in between).
fn seen_from_the_air(world: &World, frame: &Frame, samples: &[(f64, Point3<Map>)]) -> Vec<(f64, Point3<Map>)> {
    samples
        .iter()
        .filter(|(_, p)| {
            let Some(px) = frame.pixel(p) else { return false };
            match ground_truth(world, Epoch::Aerial, &frame.cam, &frame.truth, px) {
                Some((q, Surface::Ground)) => (q - *p).norm() < 0.1,
                _ => false,
            }
        })
        .copied()
        .collect()
}

/// NCC of panorama samples against a frame with the ground points shifted by (de, dn); `None` with < 500 pairs.
fn score(frame: &Frame, samples: &[(f64, Point3<Map>)], de: f64, dn: f64) -> Option<f64> {
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for (lum, p) in samples {
        if let Some(px) = frame.pixel(&(*p + Vec3::new(de, dn, 0.0))) {
            a.push(*lum);
            b.push(frame.lum(px));
        }
    }
    (a.len() >= 500).then(|| ncc(&a, &b))
}

/// The simulated city (seed 3) around the panoramas, to tell which ground the aerial frames see.
fn city_around(images: &[Row]) -> World {
    let config = WorldConfig::new(Preset::City, 3);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for img in images {
        let p = [f(img, "easting"), f(img, "northing")];
        lo = [lo[0].min(p[0] - 100.0), lo[1].min(p[1] - 100.0)];
        hi = [hi[0].max(p[0] + 100.0), hi[1].max(p[1] + 100.0)];
    }
    City::new(&config).window_box(lo, hi).world
}

/// Shifts of the ground points searched: ±[`STEPS`] steps of 0.12 m (the frames' GSD) in easting and northing.
const STEPS: i32 = 6;

/// Per (panorama, frame) pair with enough visible samples: the panorama id and the NCC at each shift
/// (index (i + STEPS) · (2 STEPS + 1) + j + STEPS for the shift (0.12 i, 0.12 j) m).
fn pano_frame_scores(out: &str) -> Vec<(String, Vec<f64>)> {
    let text = std::fs::read_to_string(format!("{out}/campaign.toml")).unwrap();
    let manifest = plumbline_campaign::Manifest::from_toml_str(&text).unwrap().into_latest();
    let m = manifest.panoramas.as_ref().unwrap();
    let [r, p, y] = m.mount.boresight_deg;
    let mount = CameraMount::new(m.mount.lever_arm_m, &Boresight::from_degrees(r, p, y));
    let cam = Equirectangular::new(m.width_px.unwrap(), m.height_px.unwrap()).unwrap();
    let frames = frames(out, &manifest);
    let images = csv_rows(&format!("{out}/truth/images.csv"));
    let world = city_around(&images);
    let mut scores = Vec::new();
    for img in images.iter().step_by(2) {
        let all = ground_samples(out, img, &mount, &cam);
        for frame in &frames {
            let samples = seen_from_the_air(&world, frame, &all);
            let grid: Option<Vec<f64>> = (-STEPS..=STEPS)
                .flat_map(|i| (-STEPS..=STEPS).map(move |j| (i, j)))
                .map(|(i, j)| score(frame, &samples, f64::from(i) * 0.12, f64::from(j) * 0.12))
                .collect();
            if let Some(grid) = grid {
                scores.push((img["image_id"].clone(), grid));
            }
        }
    }
    scores
}

/// The shift (i, j) in steps of the largest value of a score grid.
fn peak(grid: &[f64]) -> (i32, i32) {
    let k = (0..grid.len()).max_by(|&a, &b| grid[a].total_cmp(&grid[b])).unwrap() as i32;
    let side = 2 * STEPS + 1;
    (k / side - STEPS, k % side - STEPS)
}

/// Every tile's corner pixels read through the VRT equal the tile's own, at the tile's georeference.
fn mosaic_agrees_with_tiles(out: &str, name: &str, gsd: f64) -> usize {
    let mosaic = RasterSource::open_path(std::path::Path::new(&format!("{out}/aerial/{name}.vrt"))).unwrap();
    assert_eq!(mosaic.epsg(), Some(25832), "{name}");
    let gt = mosaic.geotransform();
    assert!((gt[1] - gsd).abs() < 1e-9 && (gt[5] + gsd).abs() < 1e-9, "{name}: {gt:?}");
    let mut checked = 0;
    for entry in std::fs::read_dir(format!("{out}/aerial/{name}")).unwrap() {
        let tile = RasterSource::open_path(&entry.unwrap().path()).unwrap();
        let t = tile.geotransform();
        let (w, h) = tile.size();
        for (c, r) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
            // The pixel's centre and a box a tenth of a pixel around it.
            let (e, n) = (t[0] + (c as f64 + 0.5) * t[1], t[3] + (r as f64 + 0.5) * t[5]);
            let d = gsd / 10.0;
            let area = MapBox { min_e: e - d, min_n: n - d, max_e: e + d, max_n: n + d };
            let (a, b) = (tile.window(&area).unwrap().unwrap(), mosaic.window(&area).unwrap().unwrap());
            assert_eq!((a.width, a.height, b.width, b.height), (1, 1, 1, 1), "{name} at ({e}, {n})");
            assert!(
                (a.geotransform[0] - b.geotransform[0]).abs() < 1e-6
                    && (a.geotransform[3] - b.geotransform[3]).abs() < 1e-6
            );
            assert_eq!(a.data, b.data, "{name} at ({e}, {n})");
            checked += 1;
        }
    }
    checked
}

#[test]
fn city_aerial_block_and_mosaics_agree_with_the_panoramas_and_their_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate(&dir);
    plumbline(&["validate", &format!("{out}/campaign.toml")]).run().success();
    let manifest = std::fs::read_to_string(format!("{out}/campaign.toml")).unwrap();
    for line in ["image = \"aerial/orthophoto.vrt\"", "terrain = \"aerial/terrain.vrt\"", "[aerial.frames]"] {
        assert!(manifest.contains(line), "{line} in\n{manifest}");
    }
    // Frames with unique ids (each file is read below), the truth table row for row.
    let rows = csv_rows(&format!("{out}/aerial/exterior_orientation.csv"));
    let ids: std::collections::HashSet<_> = rows.iter().map(|r| r["image_id"].clone()).collect();
    assert!(rows.len() > 20 && ids.len() == rows.len(), "{} rows, {} ids", rows.len(), ids.len());
    // Strips flown both ways (κ 0° and 180°).
    let kappas: std::collections::HashSet<i64> = rows.iter().map(|r| f(r, "kappa_deg").abs().round() as i64).collect();
    assert_eq!(kappas, [0, 180].into_iter().collect(), "κ of the frames");
    let truth = csv_rows(&format!("{out}/truth/aerial_orientation.csv"));
    assert_eq!(
        truth.iter().map(|r| r["image_id"].clone()).collect::<Vec<_>>(),
        rows.iter().map(|r| r["image_id"].clone()).collect::<Vec<_>>()
    );
    // The ground under panorama pixels lands on the same texture in the frames that see it.
    let scores = pano_frame_scores(&out);
    let legs: std::collections::HashSet<_> = scores.iter().map(|s| s.0[..8].to_owned()).collect();
    assert!(scores.len() >= 20 && legs.len() >= 2, "{} pairs over {legs:?}", scores.len());
    let centre = (STEPS * (2 * STEPS + 1) + STEPS) as usize;
    let n = scores.len() as f64;
    // Block-wide: the mean NCC over all pairs peaks at the written pose (no bias of a GSD or more).
    let mean: Vec<f64> = (0..scores[0].1.len()).map(|k| scores.iter().map(|s| s.1[k]).sum::<f64>() / n).collect();
    let best = mean.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(peak(&mean), (0, 0), "mean NCC {:.3} at the pose, {best:.3} at the peak", mean[centre]);
    // Per pair: the texture is found (NCC at the pose well above zero and above every shift of 0.72 m) and the
    // peak lies within three GSD steps of the pose (a 512 px panorama's ground pixel 10 m away spans ~0.4 m
    // along its ray, so single pairs place the fine texture to a few decimetres).
    let at_pose: Vec<f64> = scores.iter().map(|s| s.1[centre]).collect();
    let median = {
        let mut v = at_pose.clone();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let edge = |g: &[f64]| {
        [(-STEPS, 0), (STEPS, 0), (0, -STEPS), (0, STEPS)]
            .iter()
            .map(|&(i, j)| g[((i + STEPS) * (2 * STEPS + 1) + j + STEPS) as usize])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let above = scores.iter().filter(|s| s.1[centre] > edge(&s.1)).count() as f64 / n;
    let near = scores
        .iter()
        .filter(|s| {
            let (i, j) = peak(&s.1);
            i.abs() <= 3 && j.abs() <= 3
        })
        .count() as f64
        / n;
    eprintln!("{n} pairs: median NCC {median:.3}, above 0.72 m shifts {above:.2}, peak within 3 steps {near:.2}");
    assert!(median > 0.3, "median NCC at the written pose {median:.3}");
    assert!(above >= 0.9, "{above:.2} of the pairs correlate better at the pose than 0.72 m off");
    assert!(near >= 0.8, "{near:.2} of the NCC peaks within 3 steps (0.36 m) of the pose");
    // The mosaics hold every tile where its own georeference puts it.
    assert!(mosaic_agrees_with_tiles(&out, "orthophoto", 0.12) >= 16);
    assert!(mosaic_agrees_with_tiles(&out, "terrain", 1.0) >= 16);
    // The campaign map outlines the frames' footprints (blue), the overview (navigation only) does not.
    let blue = |name: &str| {
        let map = image::open(format!("{out}/{name}")).unwrap().to_rgb8();
        map.pixels().filter(|p| p.0 == [60, 90, 230]).count()
    };
    assert!(blue("map.png") > 1000, "{} footprint pixels on map.png", blue("map.png"));
    assert_eq!(blue("overview.png"), 0);
    road_markings_truth_matches_the_city(&out);
}

/// `truth/road_markings.csv`, written leg by leg: every row once and as the city's own markings give it,
/// and every marking within 10 m of a panorama (what `lines compare` scores) present.
fn road_markings_truth_matches_the_city(out: &str) {
    let text = std::fs::read_to_string(format!("{out}/truth/road_markings.csv")).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    let unique: std::collections::HashSet<&str> = rows.iter().copied().collect();
    assert!(rows.len() > 20 && unique.len() == rows.len(), "{} rows, {} distinct", rows.len(), unique.len());
    assert!(text.starts_with("id,kind,width_m,wkt\n") && text.matches("id,kind").count() == 1);
    let images = csv_rows(&format!("{out}/truth/images.csv"));
    let expected = plumbline_synth::texture::road_markings(&city_around(&images));
    let expected_csv = String::from_utf8(plumbline_synth::texture::markings_csv(&expected)).unwrap();
    let expected_rows: std::collections::HashSet<&str> = expected_csv.lines().skip(1).collect();
    let strange: Vec<&&str> = rows.iter().filter(|r| !expected_rows.contains(**r)).take(3).collect();
    assert!(strange.is_empty(), "rows the city does not have: {strange:?}");
    let panoramas: Vec<[f64; 2]> = images.iter().map(|r| [f(r, "easting"), f(r, "northing")]).collect();
    let near = |m: &plumbline_synth::texture::MarkingTruth| {
        m.points.iter().any(|p| panoramas.iter().any(|c| (p[0] - c[0]).hypot(p[1] - c[1]) <= 10.0))
    };
    let within_reach: Vec<_> = expected.iter().filter(|m| near(m)).collect();
    let missing: Vec<_> =
        within_reach.iter().filter(|m| !rows.iter().any(|r| r.starts_with(&format!("{},", m.id)))).take(3).collect();
    assert!(
        within_reach.len() > 10 && missing.is_empty(),
        "{} near panoramas; missing {missing:?}",
        within_reach.len()
    );
}
