//! Validation rules, case by case: each input names the fields whose problems it must produce,
//! in manifest order, so a case with several faults shows that all are reported at once.

use plumbline_campaign::Manifest;
use plumbline_campaign::manifest::CloudTime;

/// A valid manifest that cases extend with tables or edit.
const BASE: &str = r#"
version = "1"
crs = 25832
output = "results/"

[campaign]
id = "hh-test"
name = "Validation test"

[[trajectory]]
format = "csv"
url = "nav/drive-01.csv"
"#;

/// Validates `text` and compares the paths of the problems found with `expect`.
fn check_doc(text: &str, expect: &[&str]) {
    let manifest = Manifest::from_toml_str(text).unwrap_or_else(|e| panic!("does not parse: {e}\n{text}"));
    let found: Vec<String> = match manifest.validate() {
        Ok(_) => Vec::new(),
        Err(problems) => problems.iter().map(|p| p.path.to_string()).collect(),
    };
    assert_eq!(found, expect, "\n{text}\n{:?}", manifest.validate().err().map(|p| p.to_string()));
}

/// [`check_doc`] on [`BASE`] followed by the tables in `extra`.
fn check(extra: &str, expect: &[&str]) {
    check_doc(&format!("{BASE}{extra}"), expect);
}

#[test]
fn base_is_valid() {
    check("", &[]);
}

#[test]
fn crs_must_be_plausibly_projected() {
    check_doc(&BASE.replace("crs = 25832", "crs = 2056"), &[]);
    check_doc(&BASE.replace("crs = 25832", "crs = 4326"), &["crs"]);
    check_doc(&BASE.replace("crs = 25832", "crs = 4258"), &["crs"]);
    check_doc(&BASE.replace("crs = 25832", "crs = 4978"), &["crs"]);
    check_doc(&BASE.replace("crs = 25832", "crs = 99999"), &["crs"]);
}

#[test]
fn campaign_and_output() {
    check_doc(
        &BASE.replace("name = \"Validation test\"", "name = \" \"\nagency = \"\""),
        &["campaign.name", "campaign.agency"],
    );
    check_doc(&BASE.replace("output = \"results/\"", "output = \"/tmp/results\""), &["output"]);
    check_doc(&BASE.replace("output = \"results/\"", "output = \"ftp://host/results/\""), &["output"]);
}

#[test]
fn trajectory_sources() {
    check("[[trajectory]]\nformat = \"csv\"\nurl = \"nav/drive-02.csv\"\nepsg = 4258\n", &[]);
    check("[[trajectory]]\nformat = \"csv\"\nurl = \"nav/drive-02.csv\"\nepsg = 4978\n", &["trajectory[1].epsg"]);
    check("[[trajectory]]\nformat = \"csv\"\nurl = \"nav/drive-01.csv\"\n", &["trajectory[1].url"]);
    check(
        "[[trajectory]]\nformat = \"sbet\"\nurl = \"../sbet.out\"\ngnss = \"gnss.csv\"\n",
        &["trajectory[1].url", "trajectory[1].imu"],
    );
    check(
        "[[trajectory]]\nformat = \"sbet\"\nurl = \"a.out\"\nimu = \"imu.imr\"\nreference = \"a//b.csv\"\n",
        &["trajectory[1].reference", "trajectory[1].gnss"],
    );
}

const PANORAMAS: &str = "[panoramas]\nindex = \"pano/index.csv\"\nimages = \"pano/\"\n";

#[test]
fn panoramas_and_mounts() {
    let mount = "[panoramas.mount]\nlever_arm_m = [0.4, 0.0, -2.0]\nboresight_deg = [0.0, 0.0, 90.0]\n";
    check(&format!("{PANORAMAS}width_px = 8000\nheight_px = 4000\n{mount}"), &[]);
    check(&format!("{PANORAMAS}width_px = 8000\nheight_px = 3000\n{mount}"), &["panoramas.width_px"]);
    let bad_mount = "[panoramas.mount]\nlever_arm_m = [0.4, 20.0, nan]\nboresight_deg = [0.0, 0.0, 400.0]\n";
    check(
        &format!("{PANORAMAS}{bad_mount}"),
        &["panoramas.mount.lever_arm_m[1]", "panoramas.mount.lever_arm_m[2]", "panoramas.mount.boresight_deg[2]"],
    );
    // A ring of stitched cameras: 2–32 of them, 0–1 m from the centre.
    check(&format!("{PANORAMAS}{mount}[panoramas.rig]\ncameras = 6\nradius_m = 0.08\n"), &[]);
    check(
        &format!("{PANORAMAS}{mount}[panoramas.rig]\ncameras = 1\nradius_m = -0.1\n"),
        &["panoramas.rig.cameras", "panoramas.rig.radius_m"],
    );
    // A rolling shutter's readout: 0–0.5 s.
    check(
        &format!(
            "{PANORAMAS}readout_s = 0.033
{mount}"
        ),
        &[],
    );
    check(
        &format!(
            "{PANORAMAS}readout_s = -0.01
{mount}"
        ),
        &["panoramas.readout_s"],
    );
    check(
        &format!(
            "{PANORAMAS}readout_s = 2.0
{mount}"
        ),
        &["panoramas.readout_s"],
    );
}

/// A depth camera with the extra keys `keys` and the intrinsics table `intrinsics`.
fn depth(keys: &str, intrinsics: &str) -> String {
    format!(
        "[[depth]]\nindex = \"depth/index.csv\"\nimages = \"depth/\"\n{keys}\n\
         [depth.mount]\nlever_arm_m = [1.0, 0.4, -1.6]\nboresight_deg = [0.0, 5.0, 45.0]\n\
         [depth.intrinsics]\n{intrinsics}\n"
    )
}

#[test]
fn depth_cameras() {
    let good = "fx = 640.0\nfy = 640.0\ncx = 640.0\ncy = 360.0\nwidth_px = 1280\nheight_px = 720";
    check(&depth("", good), &[]);
    check(&depth("range_error_share = 0.0", good), &["depth[0].range_error_share"]);
    let bad = "fx = 0.0\nfy = 640.0\ncx = 1400.0\ncy = 360.0\nwidth_px = 1280\nheight_px = 720\nmin_range_m = 12.0";
    check(&depth("", bad), &["depth[0].intrinsics.fx", "depth[0].intrinsics.cx", "depth[0].intrinsics.min_range_m"]);
}

#[test]
fn point_clouds() {
    let with = |clouds: &str| {
        BASE.replace("output = \"results/\"", &format!("output = \"results/\"\npoint_clouds = {clouds}"))
    };
    check_doc(&with("[\"lidar/a.laz\", \"s3://b/c.LAS\"]"), &[]);
    check_doc(&with("[\"lidar/a.e57\", \"../b.laz\"]"), &["point_clouds[0].url", "point_clouds[1].url"]);
    // The table form says how to read the cloud; a location alone reads it as its header says.
    let table = "[\"a.laz\", { url = \"b.laz\", epsg = 25832, time = \"adjusted_standard\", \
                 mount = { lever_arm_m = [-0.9, 0.0, -1.2], boresight_deg = [0.0, 0.0, 0.0] } }]";
    let Manifest::V1(m) = Manifest::from_toml_str(&with(table)).unwrap();
    assert_eq!(m.point_clouds[0].time, CloudTime::Header);
    assert_eq!(
        (m.point_clouds[1].time, m.point_clouds[1].epsg.map(|e| e.0)),
        (CloudTime::AdjustedStandard, Some(25832))
    );
    assert_eq!(m.point_clouds[1].mount.unwrap().lever_arm_m, [-0.9, 0.0, -1.2]);
    let far = "[{ url = \"b.laz\", mount = { lever_arm_m = [40.0, 0.0, 0.0], boresight_deg = [0.0, 0.0, 0.0] } }]";
    check_doc(&with(far), &["point_clouds[0].mount.lever_arm_m[0]"]);
    // A misspelt key or time scale is an error naming it.
    for bad in ["[{ url = \"b.laz\", tme = \"none\" }]", "[{ url = \"b.laz\", time = \"gps\" }]"] {
        let e = Manifest::from_toml_str(&with(bad)).unwrap_err().to_string();
        assert!(e.contains("point_clouds") && (e.contains("tme") || e.contains("gps")), "{e}");
    }
}

const FRAMES: &str = "[aerial.frames]\nindex = \"aerial/eo.csv\"\nimages = \"aerial/\"\n";

#[test]
fn aerial() {
    let interior = "[aerial.frames.interior]\nfocal_length_mm = 100.5\npixel_size_mm = 0.004\nwidth_px = 14790\nheight_px = 23010\n";
    check(&format!("{FRAMES}{interior}"), &[]);
    check("[aerial]\n", &["aerial"]);
    check("[aerial.orthophoto]\nimage = \"dop.tif\"\nterrain = \"/dgm.tif\"\n", &["aerial.orthophoto.terrain"]);
    let bad = "[aerial.frames.interior]\nfocal_length_mm = -100.5\npixel_size_mm = 4.0\nwidth_px = 0\nheight_px = 23010\n\
               principal_point_mm = [0.1, 50.0]\n";
    check(
        &format!("{FRAMES}gsd_m = 3.0\n{bad}"),
        &[
            "aerial.frames.interior.focal_length_mm",
            "aerial.frames.interior.pixel_size_mm",
            "aerial.frames.interior.width_px",
            "aerial.frames.interior.principal_point_mm[0]",
            "aerial.frames.gsd_m",
        ],
    );
}

fn cadastre(url: &str, body: &str) -> String {
    format!("[[cadastres]]\nurl = \"{url}\"\n{body}\n")
}

#[test]
fn cadastres() {
    check(&cadastre("trees.gpkg", "layers = [\"baeume\"]\nclass = \"tree\""), &[]);
    check(
        &cadastre("poles.gpkg", "layers = [\"masten\"]\nclass_attribute = \"art\"\nclass_values = { Mast = \"pole\" }"),
        &[],
    );
    check(&cadastre("trees.shp", "layers = []\nclass = \"tree\""), &["cadastres[0].url", "cadastres[0].layers"]);
    check(
        &cadastre("t.gpkg", "layers = [\"a\", \"a\"]\nclass_attribute = \"art\"\nclass = \"tree\""),
        &["cadastres[0].layers[1]", "cadastres[0].class"],
    );
    check(&cadastre("t.gpkg", "layers = [\"a\"]\nclass_values = { Baum = \"tree\" }"), &["cadastres[0]"]);
    check(
        &cadastre("t.gpkg", "layers = [\"a\"]\nclass = \"tree\"\nclass_values = { Baum = \"tree\" }"),
        &["cadastres[0].class_values"],
    );
    let accuracy = "layers = [\"a\"]\nclass = \"tree\"\naccuracy = { trees = 0.0, signs = 11.0 }\nepsg = 4978";
    check(
        &cadastre("t.gpkg", accuracy),
        &["cadastres[0].accuracy.signs", "cadastres[0].accuracy.trees", "cadastres[0].epsg"],
    );
}

#[test]
fn cadastre_layers_are_read_once() {
    let lights = cadastre("c.gpkg", "layers = [\"leuchten\", \"masten\"]\nclass = \"light\"");
    let again = cadastre("c.gpkg", "layers = [\"baeume\", \"masten\"]\nclass = \"tree\"");
    let other_file = cadastre("d.gpkg", "layers = [\"masten\"]\nclass = \"pole\"");
    check(&format!("{lights}{again}{other_file}"), &["cadastres[1].layers[1]"]);
}

#[test]
fn tiling() {
    check("[tiling]\ntile_size_m = 500.0\noverlap_m = 0.0\n", &[]);
    check("[tiling]\ntile_size_m = 250.0\noverlap_m = 250.0\n", &["tiling.overlap_m"]);
    check("[tiling]\ntile_size_m = -1.0\n", &["tiling.tile_size_m", "tiling.overlap_m"]);
    check("[tiling]\ntile_size_m = nan\noverlap_m = -5.0\n", &["tiling.tile_size_m", "tiling.overlap_m"]);
}

#[test]
fn parameters() {
    let good =
        "[parameters.registration]\nmm_gsd_m = 0.02\naerial_gsd_m = 0.2\n[parameters.adjustment]\nloss = \"none\"\n";
    check(good, &[]);
    let bad = "[parameters.registration]\nmm_gsd_m = 0.0\naerial_gsd_m = 2.0\nmin_aerial_images = 0\nmin_correspondences = 2\n\
               [parameters.poles]\nmax_range_m = -1.0\n\
               [parameters.adjustment]\nhuber_k = 0.0\nsnooping_alpha = 0.5\nmax_iterations = 0\n";
    check(
        bad,
        &[
            "parameters.registration.mm_gsd_m",
            "parameters.registration.aerial_gsd_m",
            "parameters.registration.min_aerial_images",
            "parameters.registration.min_correspondences",
            "parameters.poles.max_range_m",
            "parameters.adjustment.huber_k",
            "parameters.adjustment.snooping_alpha",
            "parameters.adjustment.max_iterations",
        ],
    );
}

#[test]
fn problems_say_what_is_wrong_and_what_is_expected() {
    let text = format!("{BASE}[tiling]\ntile_size_m = 250.0\noverlap_m = 300.0\n");
    let problems = Manifest::from_toml_str(&text).ok().and_then(|m| m.validate().err()).map(|p| p.to_string());
    let expect =
        "tiling.overlap_m: 300 m is not less than tile_size_m (250 m); expected an overlap smaller than the tile size";
    assert_eq!(problems.as_deref(), Some(expect));
}

#[test]
fn aerial_gsd_defaults_from_the_aerial_frames() {
    let gsd = |extra: &str| {
        let manifest = Manifest::from_toml_str(&format!("{BASE}{extra}")).map(Manifest::into_latest);
        manifest.map(|m| m.aerial_gsd_m()).map_err(|e| e.to_string())
    };
    let interior = "[aerial.frames.interior]\nfocal_length_mm = 100.5\npixel_size_mm = 0.004\nwidth_px = 14790\nheight_px = 23010\n";
    assert_eq!(gsd(""), Ok(0.12));
    assert_eq!(gsd(&format!("{FRAMES}gsd_m = 0.08\n{interior}")), Ok(0.08));
    assert_eq!(
        gsd(&format!("{FRAMES}gsd_m = 0.08\n{interior}[parameters.registration]\naerial_gsd_m = 0.1\n")),
        Ok(0.1)
    );
}
