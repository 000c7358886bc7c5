//! End-to-end tests of `plumbline validate` on the golden examples and on manifests written into a temp dir.

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

use crate::support;

use support::{plumbline, write};

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../schemas/examples");

fn manifest(crs: u32, extra: &str) -> String {
    format!(
        "version = \"1\"\ncrs = {crs}\noutput = \"results/\"\n\n[campaign]\nid = \"test-drive\"\nname = \"Test\"\n\n\
         [[trajectory]]\nformat = \"csv\"\nurl = \"nav/dg.csv\"\n{extra}"
    )
}

#[test]
fn the_golden_examples_are_valid_offline() {
    for name in ["manifest.v1.minimal.toml", "manifest.v1.full.toml", "manifest.v1.full.json"] {
        let r = plumbline(&["validate", &format!("{EXAMPLES}/{name}"), "--offline"]).run();
        r.success();
        assert!(r.stdout.contains("valid"), "{}", r.stdout);
    }
}

#[test]
fn invalid_examples_exit_2_naming_the_field() {
    for (name, field) in [
        ("unknown_field.toml", "tiling.tile_size"),
        ("overlap_too_large.toml", "tiling.overlap_m"),
        ("geographic_crs.toml", "crs"),
        ("unsupported_version.toml", "version"),
    ] {
        let r = plumbline(&["validate", &format!("{EXAMPLES}/invalid/{name}"), "--offline"]).run();
        r.failure_with(2);
        assert!(r.stderr.contains(name) && r.stderr.contains(field), "{name}: {}", r.stderr);
    }
}

#[test]
fn several_problems_are_all_listed() {
    let r = plumbline(&["validate", &format!("{EXAMPLES}/invalid/several_problems.toml"), "--offline"]).run();
    r.failure_with(2);
    let listed = r.stderr.lines().filter(|l| l.starts_with("  ")).count();
    assert!(listed >= 4, "{}", r.stderr);
}

#[test]
fn a_crs_unknown_to_proj_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(&dir, "campaign.toml", &manifest(30000, ""));
    let r = plumbline(&["validate", &path, "--offline"]).run();
    r.failure_with(2);
    assert!(r.stderr.contains("crs") && r.stderr.contains("30000"), "{}", r.stderr);
}

#[test]
fn inputs_are_looked_up_next_to_the_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let cadastre = "[[cadastres]]\nurl = \"cadastre/poles.gpkg\"\nlayers = [\"poles\"]\nclass = \"pole\"\n";
    let path = write(&dir, "campaign.toml", &manifest(25832, cadastre));
    std::fs::create_dir_all(dir.path().join("nav")).unwrap();
    std::fs::write(dir.path().join("nav/dg.csv"), "time,easting,northing,height,roll,pitch,heading\n").unwrap();

    let r = plumbline(&["validate", &path]).run();
    r.failure_with(2);
    assert!(r.stderr.contains("cadastres[0].url") && r.stderr.contains("poles.gpkg"), "{}", r.stderr);
    assert!(!r.stderr.contains("trajectory[0]"), "the trajectory exists: {}", r.stderr);

    std::fs::create_dir_all(dir.path().join("cadastre")).unwrap();
    std::fs::write(dir.path().join("cadastre/poles.gpkg"), b"").unwrap();
    // Now both exist, and are opened: an empty trajectory and a 0-byte GeoPackage are named for what they are.
    let r = plumbline(&["validate", &path]).run();
    r.failure_with(2);
    assert!(r.stderr.contains("trajectory[0]: dg.csv: trajectory is empty"), "{}", r.stderr);
    assert!(r.stderr.contains("cadastres[0]") && r.stderr.contains("empty (0 bytes"), "{}", r.stderr);
    // --offline checks the manifest alone, without looking at the files.
    plumbline(&["validate", &path, "--offline"]).run().success();
}
