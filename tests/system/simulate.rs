//! End-to-end tests of `plumbline simulate`: the written campaign validates, its trajectories parse back,
//! and `trajectory compare` of DG against truth reports the DG error series and the profile's error level;
//! the sensor data (panoramas, depth, cadastre, aerial) is complete, opens through GDAL and is geometrically
//! consistent with the truth (`simulate_sensors.rs`-style checks in `sensors_*` below).

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

use crate::support;

use support::plumbline;

/// Simulate a tiny campaign with `profile` into a fresh temp dir; returns the dir and the campaign prefix.
fn simulate(profile: &str, seed: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("camp").to_str().unwrap().to_owned();
    let args =
        ["simulate", "--preset", "tiny", "--seed", seed, "--profile", profile, "--navigation-only", "--out", &out];
    plumbline(&args).run().success();
    (dir, out)
}

/// `trajectory compare ESTIMATE truth/trajectory.csv --json` in EPSG 25832.
fn compare(out: &str, estimate: &str) -> serde_json::Value {
    let truth = format!("{out}/truth/trajectory.csv");
    let r =
        plumbline(&["trajectory", "compare", &format!("{out}/{estimate}"), &truth, "--epsg", "25832", "--json"]).run();
    r.success();
    serde_json::from_str(&r.stdout).unwrap()
}

/// 3D RMS of the DG error series file.
fn error_series_rms(out: &str) -> (f64, usize) {
    let text = std::fs::read_to_string(format!("{out}/truth/dg_errors.csv")).unwrap();
    let mut sum = 0.0;
    let mut n = 0;
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line.split(',').skip(1).take(3).map(|x| x.parse().unwrap()).collect();
        sum += f.iter().map(|x| x * x).sum::<f64>();
        n += 1;
    }
    ((sum / n as f64).sqrt(), n)
}

#[test]
fn simulated_campaign_validates_and_compares_like_its_error_series() {
    let (_dir, out) = simulate("open", "5");
    plumbline(&["validate", &format!("{out}/campaign.toml")]).run().success();
    let png = std::fs::read(format!("{out}/overview.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let csv = compare(&out, "nav/dg.csv");
    let (series_rms, epochs) = error_series_rms(&out);
    // Same epochs as the truth: the comparison's 3D RMSE is the error series' RMS.
    let rmse_3d = csv["rmse_3d"].as_f64().unwrap();
    assert!((rmse_3d - series_rms).abs() < 1e-4, "compare {rmse_3d} vs series {series_rms}");
    assert_eq!(csv["cross"]["count"].as_u64().unwrap() as usize, epochs);
    // The SBET (WGS 84, through the CRS round trip) compares the same to 1 mm.
    let sbet = compare(&out, "nav/dg.sbet");
    assert!((sbet["rmse_3d"].as_f64().unwrap() - rmse_3d).abs() < 1e-3, "{sbet}");
    // Open sky: centimetre level (module doc of `motion::dg`: horizontal RMS 1–3.5 cm, 99 % 3–7 cm).
    let rmse_2d = csv["rmse_2d"].as_f64().unwrap();
    assert!(rmse_2d < 0.07 && csv["cross"]["p99"].as_f64().unwrap() < 0.12, "{csv}");
}

#[test]
fn canyon_campaigns_are_worse_than_open_sky_and_bad_arguments_exit_2() {
    let (_open_dir, open) = simulate("open", "6");
    let open_2d = compare(&open, "nav/dg.csv")["rmse_2d"].as_f64().unwrap();
    // A tiny drive holds only a few multipath jumps, so pool three seeds (module doc of `motion::dg`:
    // canyon RMS 25–60 cm over an hour, 1–3.5 cm in the open).
    let mut sum_sq = 0.0;
    let mut worst: f64 = 0.0;
    for seed in ["6", "7", "8"] {
        let (_dir, canyon) = simulate("canyon", seed);
        let c = compare(&canyon, "nav/dg.csv");
        sum_sq += c["rmse_2d"].as_f64().unwrap().powi(2);
        worst = worst.max(c["cross"]["max"].as_f64().unwrap());
    }
    let canyon_2d = (sum_sq / 3.0).sqrt();
    assert!(canyon_2d > 0.1 && canyon_2d > 3.0 * open_2d, "canyon {canyon_2d} vs open {open_2d}");
    assert!(worst > 0.2, "largest canyon cross-track difference {worst}");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    plumbline(&["simulate", "--preset", "huge", "--out", out]).run().failure_with(2);
    plumbline(&["simulate", "--aerial-frame-px", "14000", "--out", out]).run().failure_with(2);
}

/// Rows of a CSV file as maps from header to value.
fn csv_rows(path: &str) -> Vec<std::collections::HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(str::to_owned).collect();
    lines.map(|l| header.iter().cloned().zip(l.split(',').map(str::to_owned)).collect()).collect()
}

fn tool(cmd: &str, args: &[&str]) -> String {
    let out = std::process::Command::new(cmd).args(args).output().unwrap();
    assert!(out.status.success(), "{cmd} {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn sensor_data_is_complete_opens_through_gdal_and_validates() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("camp").to_str().unwrap().to_owned();
    let args = ["simulate", "--seed", "4", "--panorama-width", "1024", "--panorama-spacing", "12"];
    let frames = ["--aerial-frame-px", "1200x900", "--aerial-format", "tiff16"];
    let rest = ["--depth-rate", "1", "--aerial-gsd", "0.5", "--out", &out];
    plumbline(&[&args[..], &frames[..], &rest[..]].concat()).run().success();
    plumbline(&["validate", &format!("{out}/campaign.toml")]).run().success();
    assert_eq!(&std::fs::read(format!("{out}/map.png")).unwrap()[1..4], b"PNG");
    // Frames as large-format cameras deliver them: 16-bit R, G, B, NIR, tiled, of the interior's size.
    let frame = csv_rows(&format!("{out}/aerial/exterior_orientation.csv"))[0]["file"].clone();
    let json: serde_json::Value =
        serde_json::from_str(&tool("gdalinfo", &["-json", &format!("{out}/aerial/frames/{frame}")])).unwrap();
    assert_eq!(json["size"], serde_json::json!([1200, 900]), "{frame}");
    let bands = json["bands"].as_array().unwrap();
    assert_eq!(bands.len(), 4, "{frame}");
    assert!(bands.iter().all(|b| b["type"] == "UInt16" && b["block"] == serde_json::json!([512, 512])), "{bands:?}");
    assert!(std::fs::read_to_string(format!("{out}/campaign.toml")).unwrap().contains("width_px = 1200"));
    // Every index row names an existing file; the truth tables have one row per image.
    for (index, images) in [
        ("panoramas/index.csv", "panoramas"),
        ("depth/right/index.csv", "depth/right"),
        ("aerial/exterior_orientation.csv", "aerial/frames"),
    ] {
        let rows = csv_rows(&format!("{out}/{index}"));
        assert!(rows.len() > 3, "{index}: {} rows", rows.len());
        for row in &rows {
            assert!(std::path::Path::new(&format!("{out}/{images}/{}", row["file"])).is_file(), "{index}: {row:?}");
        }
    }
    assert_eq!(
        csv_rows(&format!("{out}/truth/images.csv")).len(),
        csv_rows(&format!("{out}/panoramas/index.csv")).len()
    );
    // The GeoPackage: two layers, EPSG 4258, as many features as truth/poles.csv lists per layer.
    let truth = csv_rows(&format!("{out}/truth/poles.csv"));
    let listed =
        |tree: bool| truth.iter().filter(|r| !r["cadastre_id"].is_empty() && (r["class"] == "tree") == tree).count();
    let info = tool("ogrinfo", &["-ro", "-so", "-al", &format!("{out}/cadastre/poles.gpkg")]);
    for (layer, count) in [("poles", listed(false)), ("trees", listed(true))] {
        let part = info.split("Layer name: ").find(|p| p.starts_with(layer)).unwrap();
        assert!(part.contains(&format!("Feature Count: {count}\n")), "{layer}: {count} expected in {part}");
        assert!(part.contains("ID[\"EPSG\",4258]"), "{part}");
    }
    assert!(
        truth.iter().any(|r| r["defect"] == "missing_from_cadastre")
            && truth.iter().any(|r| r["defect"] == "gone_in_reality")
    );
    // GeoTIFFs: georeferenced in the campaign CRS at the declared GSDs.
    for (file, gsd) in [("orthophoto.tif", 0.5), ("terrain.tif", 1.0)] {
        let json: serde_json::Value =
            serde_json::from_str(&tool("gdalinfo", &["-json", &format!("{out}/aerial/{file}")])).unwrap();
        let gt: Vec<f64> = json["geoTransform"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert!(
            (gt[1] - gsd).abs() < 1e-9 && (gt[5] + gsd).abs() < 1e-9 && gt[2] == 0.0 && gt[4] == 0.0,
            "{file}: {gt:?}"
        );
        assert!(gt[0] > 500_000.0 && gt[3] > 5_000_000.0, "{file}: {gt:?}");
        assert!(json["coordinateSystem"]["wkt"].as_str().unwrap().contains("ID[\"EPSG\",25832]"), "{file}");
    }
    let (on, beside, n) = street_light_pixels(&out, [0.0, 0.0, 0.0]);
    assert!(n >= 12, "only {} street lights near panoramas", n / 4);
    assert!(on > 0.75 && beside > 0.75, "green on the lights {on:.2}, different 1 m beside {beside:.2}");
    let (on_pole, ground_ok, samples) = pixel_truth_agrees(&out);
    assert!(
        samples.0 >= 12 && on_pole > 0.75,
        "{on_pole:.2} of {} light-axis pixels are pole pixels on the light",
        samples.0
    );
    assert!(samples.1 > 1000 && ground_ok == 1.0, "{ground_ok:.4} of {} ground pixels on the ground", samples.1);
    let (agree, depth_n) = pole_depths_agree(&out);
    assert!(depth_n >= 5 && agree > 0.8, "{depth_n} pole samples in depth images, {agree:.2} agree");
    // The same check with the lever arm 30 cm off forward (across the line of sight to kerbside poles) fails: it can tell a wrong mount.
    let (on_wrong, _, _) = street_light_pixels(&out, [0.3, 0.0, 0.0]);
    assert!(on_wrong < 0.5, "a wrong lever arm still lands on the lights: {on_wrong:.2}");
}

/// Geometric consistency by an independent route: the TRUE base of every listed street light 3–10 m from
/// the nearest panorama, projected with the true pose and the manifest's mount (`CameraMount::project`,
/// not the ray caster), lands on the lights' dark-green pixels from 0.5 to 2 m above the road, and the
/// pixels 1 m beside it mostly differ in colour. A lever arm or boresight off by a few decimetres / a degree
/// misses poles of 12–20 cm at these ranges.
/// Returns the share of green pixels on the lights, of differing pixels beside them, and the sample count;
/// `lever_arm_error` is added to the manifest's lever arm.
fn street_light_pixels(out: &str, lever_arm_error: [f64; 3]) -> (f64, f64, usize) {
    use plumbline_geo::camera::Equirectangular;
    use plumbline_geo::dg::{Boresight, CameraMount};
    use plumbline_geo::{Attitude, MapFromBody, Point3};
    let text = std::fs::read_to_string(format!("{out}/campaign.toml")).unwrap();
    let manifest = plumbline_campaign::Manifest::from_toml_str(&text).unwrap().into_latest();
    let m = manifest.panoramas.unwrap();
    let [r, p, y] = m.mount.boresight_deg;
    let lever: [f64; 3] = std::array::from_fn(|k| m.mount.lever_arm_m[k] + lever_arm_error[k]);
    let mount = CameraMount::new(lever, &Boresight::from_degrees(r, p, y));
    let cam = Equirectangular::new(m.width_px.unwrap(), m.height_px.unwrap()).unwrap();
    let f = |row: &std::collections::HashMap<String, String>, k: &str| row[k].parse::<f64>().unwrap();
    let images = csv_rows(&format!("{out}/truth/images.csv"));
    let green = |c: [u8; 3]| c[1] > c[0] + 8 && c[1] > c[2] + 8;
    let differs =
        |a: [u8; 3], b: [u8; 3]| a.iter().zip(b).map(|(x, y)| (i32::from(*x) - i32::from(y)).abs()).sum::<i32>() > 40;
    let (mut on, mut beside, mut n) = (0, 0, 0);
    let lights = csv_rows(&format!("{out}/truth/poles.csv"));
    for light in lights.iter().filter(|r| r["class"] == "light" && r["defect"] == "none") {
        let (e, north) = (f(light, "true_e"), f(light, "true_n"));
        let dist =
            |img: &std::collections::HashMap<String, String>| (f(img, "easting") - e).hypot(f(img, "northing") - north);
        let img = images.iter().min_by(|a, b| dist(a).total_cmp(&dist(b))).unwrap();
        if !(3.0..10.0).contains(&dist(img)) {
            continue;
        }
        let attitude = Attitude::from_degrees(f(img, "roll_deg"), f(img, "pitch_deg"), f(img, "heading_deg"));
        let body = MapFromBody::new(
            attitude.to_rotation(),
            Point3::new(f(img, "easting"), f(img, "northing"), f(img, "height")),
        );
        let pano = image::open(format!("{out}/panoramas/{}.jpg", img["image_id"])).unwrap().to_rgb8();
        // The IMU is 1 m above the road (VehicleBody::van); sideways = horizontal, across the line of sight.
        let ground = f(img, "height") - 1.0;
        let (dx, dy) = ((e - f(img, "easting")) / dist(img), (north - f(img, "northing")) / dist(img));
        let pixel_at = |e: f64, n: f64, z: f64| {
            let px = mount.project(&cam, &body, &Point3::new(e, n, z)).unwrap();
            pano.get_pixel((px.u as u32).min(cam.width - 1), (px.v as u32).min(cam.height - 1)).0
        };
        for z in [0.5, 1.0, 1.5, 2.0] {
            let c = pixel_at(e, north, ground + z);
            n += 1;
            on += usize::from(green(c));
            for side in [pixel_at(e - dy, north + dx, ground + z), pixel_at(e + dy, north - dx, ground + z)] {
                beside += usize::from(differs(c, side));
            }
        }
    }
    (on as f64 / n.max(1) as f64, beside as f64 / (2 * n).max(1) as f64, n)
}

/// The depth images by an independent route: every listed non-tree pole's TRUE axis 2 m above the road
/// (above parked cars), put into the depth camera with the true pose and the manifest's depth mount,
/// finds the pole's depth (camera z less its radius, within 3σ of the 8 % noise) in the 16-bit PNG.
/// Returns the share of samples that agree and their number.
fn pole_depths_agree(out: &str) -> (f64, usize) {
    use plumbline_geo::camera::{CameraModel, Pinhole};
    use plumbline_geo::dg::{Boresight, CameraMount};
    use plumbline_geo::{Attitude, MapFromBody, Point3};
    let text = std::fs::read_to_string(format!("{out}/campaign.toml")).unwrap();
    let manifest = plumbline_campaign::Manifest::from_toml_str(&text).unwrap().into_latest();
    let d = &manifest.depth[0];
    let [r, p, y] = d.mount.boresight_deg;
    let mount = CameraMount::new(d.mount.lever_arm_m, &Boresight::from_degrees(r, p, y));
    let k = d.intrinsics;
    let cam = Pinhole::new(k.width_px, k.height_px, k.fx, k.fy, k.cx, k.cy, 0.0, 0.0).unwrap();
    let f = |row: &std::collections::HashMap<String, String>, k: &str| row[k].parse::<f64>().unwrap();
    let poles = csv_rows(&format!("{out}/truth/poles.csv"));
    let poles: Vec<_> = poles.iter().filter(|r| r["class"] != "tree" && r["defect"] == "none").collect();
    let (mut agree, mut n) = (0usize, 0usize);
    for img in csv_rows(&format!("{out}/truth/depth_images.csv")) {
        let attitude = Attitude::from_degrees(f(&img, "roll_deg"), f(&img, "pitch_deg"), f(&img, "heading_deg"));
        let position = Point3::new(f(&img, "easting"), f(&img, "northing"), f(&img, "height"));
        let body = MapFromBody::new(attitude.to_rotation(), position);
        let ground = f(&img, "height") - 1.0;
        let mut depth = None;
        for pole in &poles {
            let c = mount.to_camera(&body, &Point3::new(f(pole, "true_e"), f(pole, "true_n"), ground + 2.0));
            let Some(px) = cam.project(&c) else { continue };
            let inside =
                px.u >= 1.0 && px.v >= 1.0 && px.u < f64::from(k.width_px) - 1.0 && px.v < f64::from(k.height_px) - 1.0;
            if !(inside && (1.0..8.0).contains(&c.z())) {
                continue;
            }
            let image = depth.get_or_insert_with(|| {
                image::open(format!("{out}/depth/right/{}.png", img["image_id"])).unwrap().to_luma16()
            });
            let measured = f64::from(image.get_pixel(px.u as u32, px.v as u32).0[0]) / 1000.0;
            let expected = c.z() - f(pole, "diameter_m") / 2.0;
            n += 1;
            agree += usize::from((measured - expected).abs() < 3.0 * 0.08 * expected + 0.05);
        }
    }
    (agree as f64 / n.max(1) as f64, n)
}

/// The per-pixel truth files by an independent route: the TRUE axis of every listed street light 3–10 m from
/// the nearest panorama, 1.6–2.8 m above the road (above parked cars), projected with the true pose and the
/// manifest's mount, falls on pixels whose class is "pole" and whose point (camera centre + range · ray) lies
/// on the light's surface (its radius from the axis, ±1 cm); and every "ground" pixel of the lower image
/// half decodes to a point on the flat ground of the world's configuration (±3 mm).
/// Returns the shares that agree and the sample counts (light pixels, ground pixels).
fn pixel_truth_agrees(out: &str) -> (f64, f64, (usize, usize)) {
    use plumbline_geo::camera::Equirectangular;
    use plumbline_geo::dg::{Boresight, CameraMount};
    use plumbline_geo::{Attitude, MapFromBody, Point3};
    use plumbline_synth::render::surface_point;
    let text = std::fs::read_to_string(format!("{out}/campaign.toml")).unwrap();
    let manifest = plumbline_campaign::Manifest::from_toml_str(&text).unwrap().into_latest();
    let m = manifest.panoramas.unwrap();
    let [r, p, y] = m.mount.boresight_deg;
    let mount = CameraMount::new(m.mount.lever_arm_m, &Boresight::from_degrees(r, p, y));
    let (w, h) = (m.width_px.unwrap(), m.height_px.unwrap());
    let cam = Equirectangular::new(w, h).unwrap();
    let world = plumbline_synth::world::WorldConfig::new(plumbline_synth::world::Preset::Tiny, 4);
    let f = |row: &std::collections::HashMap<String, String>, k: &str| row[k].parse::<f64>().unwrap();
    let images = csv_rows(&format!("{out}/truth/images.csv"));
    let lights = csv_rows(&format!("{out}/truth/poles.csv"));
    let (mut on, mut n, mut ground_ok, mut ground_n) = (0, 0, 0, 0);
    let mut checked_ground = std::collections::HashSet::new();
    for light in lights.iter().filter(|r| r["class"] == "light" && r["defect"] == "none") {
        let (e, north) = (f(light, "true_e"), f(light, "true_n"));
        let dist =
            |img: &std::collections::HashMap<String, String>| (f(img, "easting") - e).hypot(f(img, "northing") - north);
        let img = images.iter().min_by(|a, b| dist(a).total_cmp(&dist(b))).unwrap();
        if !(3.0..10.0).contains(&dist(img)) {
            continue;
        }
        let attitude = Attitude::from_degrees(f(img, "roll_deg"), f(img, "pitch_deg"), f(img, "heading_deg"));
        let body = MapFromBody::new(
            attitude.to_rotation(),
            Point3::new(f(img, "easting"), f(img, "northing"), f(img, "height")),
        );
        let pose = mount.camera_pose(&body);
        let ground = world.ground_height;
        let id = &img["image_id"];
        let range = image::open(format!("{out}/truth/pixels/{id}_range.png")).unwrap().to_luma16();
        let class = image::open(format!("{out}/truth/pixels/{id}_class.png")).unwrap().to_luma8();
        let point = |col: u32, row: u32| {
            surface_point(&cam, &pose, col, row, f64::from(range.get_pixel(col, row)[0]) / 1000.0).unwrap()
        };
        for z in [1.6, 2.2, 2.8] {
            let px = mount.project(&cam, &body, &Point3::new(e, north, ground + z)).unwrap();
            let (col, row) = ((px.u as u32).min(w - 1), (px.v as u32).min(h - 1));
            n += 1;
            if class.get_pixel(col, row)[0] == 4 {
                let q = point(col, row);
                let off_axis = (q.x() - e).hypot(q.y() - north);
                on += usize::from((off_axis - f(light, "diameter_m") / 2.0).abs() < 0.01);
            }
        }
        if checked_ground.insert(id.clone()) {
            for row in (h / 2 + 8..h).step_by(7) {
                for col in (0..w).step_by(11) {
                    if class.get_pixel(col, row)[0] == 1 {
                        ground_n += 1;
                        ground_ok += usize::from((point(col, row).z() - ground).abs() < 0.003);
                    }
                }
            }
        }
    }
    (on as f64 / n.max(1) as f64, ground_ok as f64 / ground_n.max(1) as f64, (n, ground_n))
}

#[test]
fn city_streams_legs_into_one_valid_continuous_campaign() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("city").to_str().unwrap().to_owned();
    // Coarse aerial data: this test is about the legs (`city.rs` checks the aerial block).
    let sizes = ["--panorama-width", "128", "--panorama-spacing", "40", "--depth-rate", "0.1", "--aerial-gsd", "0.6"];
    // At the harsh level: the city's windows carry pedestrians, and the manifest names the rig of cameras.
    let args =
        [&["simulate", "--preset", "city", "--length", "0.7km", "--seed", "3", "--profile", "canyon"][..], &sizes];
    plumbline(&[&args.concat()[..], &["--realism", "harsh", "--out", &out]].concat()).run().success();
    plumbline(&["validate", &format!("{out}/campaign.toml")]).run().success();
    let manifest = std::fs::read_to_string(format!("{out}/campaign.toml")).unwrap();
    assert!(manifest.contains("[panoramas.rig]\ncameras = 6\nradius_m = 0.1\n"), "{manifest}");
    // One trajectory across the legs: 200 Hz without gaps, and no step between epochs beyond driving speed.
    let truth = csv_rows(&format!("{out}/truth/trajectory.csv"));
    let errors = csv_rows(&format!("{out}/truth/dg_errors.csv"));
    assert!(truth.len() > 60_000 && errors.len() == truth.len(), "{} epochs, {} errors", truth.len(), errors.len());
    let time_key = truth[0].keys().find(|k| k.starts_with("time")).unwrap().clone();
    let xyz: Vec<[f64; 4]> = truth
        .iter()
        .map(|r| {
            let v = |prefix: &str| r.iter().find(|(k, _)| k.starts_with(prefix)).unwrap().1.parse::<f64>().unwrap();
            [v(&time_key), v("east"), v("north"), v("height")]
        })
        .collect();
    for w in xyz.windows(2) {
        assert!((w[1][0] - w[0][0] - 0.005).abs() < 1e-6, "time step at {}", w[0][0]);
        let step = ((w[1][1] - w[0][1]).powi(2) + (w[1][2] - w[0][2]).powi(2) + (w[1][3] - w[0][3]).powi(2)).sqrt();
        assert!(step < 0.1, "{step} m between epochs at {}", w[0][0]);
    }
    let compared = compare(&out, "nav/dg.csv");
    assert_eq!(compared["cross"]["count"].as_u64().unwrap() as usize, truth.len());
    // Images of every leg, unique ids, each with its per-pixel truth; every listed cadastre object once.
    let index = csv_rows(&format!("{out}/panoramas/index.csv"));
    let ids: std::collections::HashSet<_> = index.iter().map(|r| r["image_id"].clone()).collect();
    assert!(ids.len() == index.len() && ids.iter().any(|i| i.starts_with("pano0001_")), "{ids:?}");
    for id in &ids {
        for file in [
            format!("panoramas/{id}.jpg"),
            format!("truth/pixels/{id}_range.png"),
            format!("truth/pixels/{id}_class.png"),
        ] {
            assert!(std::path::Path::new(&format!("{out}/{file}")).is_file(), "{file}");
        }
    }
    let poles = csv_rows(&format!("{out}/truth/poles.csv"));
    let listed: Vec<_> =
        poles.iter().filter(|r| !r["cadastre_id"].is_empty()).map(|r| r["cadastre_id"].clone()).collect();
    let unique: std::collections::HashSet<_> = listed.iter().collect();
    assert!(listed.len() > 50 && unique.len() == listed.len(), "{} listed, {} unique", listed.len(), unique.len());
}
