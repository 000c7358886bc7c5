//! The bad-input corpus: zero-length, truncated, garbage and wrong-type files of every input kind, decompression
//! bombs, NaN/unsorted/duplicate trajectory records, wrong or missing CRS, huge attributes, non-UTF-8 bytes.
//!
//! Every case starts from one simulated `tiny` campaign (made once per test build), replaces one input in an
//! overlay directory (the other files are symbolic links to the campaign's), runs one command of the real
//! binary under a 4 GiB address-space limit, and asserts the exit code and that the message names the file and
//! the record or field. No case may end in a signal (segfault, abort) or a panic. Item-level defects must
//! leave the campaign valid (exit 0) with a warning naming them; `item_level_defects_are_skipped_and_the_run_goes_on`
//! runs the whole campaign with several of them at once.

#![allow(clippy::unwrap_used)] // test helpers outside #[test] functions

use crate::support;

use std::path::{Path, PathBuf};
use std::process::Command;

use gdal::vector::LayerAccess as _;

use plumbline_testkit::images::{png_bomb, png_claiming};
use support::once_per_build;

/// The simulated campaign every case starts from.
fn base() -> PathBuf {
    once_per_build("bad-inputs-tiny", "campaign.toml", |out| {
        let out = out.to_str().unwrap();
        support::plumbline(&["simulate", "--preset", "tiny", "--seed", "3", "--out", out]).run().success();
    })
}

/// A campaign directory for one case: the base campaign's entries as symbolic links, replaced ones as files.
struct Overlay {
    base: PathBuf,
    dir: tempfile::TempDir,
}

impl Overlay {
    fn new(base: &Path) -> Self {
        let dir = tempfile::tempdir().unwrap();
        link_entries(base, dir.path());
        Self { base: base.to_owned(), dir }
    }

    fn path(&self, relative: &str) -> String {
        self.dir.path().join(relative).to_str().unwrap().to_owned()
    }

    fn manifest(&self) -> String {
        self.path("campaign.toml")
    }

    /// The base campaign's file.
    fn original(&self, relative: &str) -> Vec<u8> {
        std::fs::read(self.base.join(relative)).unwrap()
    }

    /// Replace a file (its directories become real directories whose other entries stay links).
    fn write(&self, relative: &str, bytes: impl AsRef<[u8]>) {
        let target = self.dir.path().join(relative);
        self.materialise(target.parent().unwrap());
        let _ = std::fs::remove_file(&target);
        std::fs::write(&target, bytes).unwrap();
    }

    /// Replace a file by what `program args…` writes to `{out}` (`{in}` = the base campaign's file).
    fn tool(&self, relative: &str, program: &str, args: &[&str]) {
        let target = self.dir.path().join(relative);
        self.materialise(target.parent().unwrap());
        let _ = std::fs::remove_file(&target);
        let (input, output) = (self.base.join(relative), target.to_str().unwrap().to_owned());
        let args: Vec<String> =
            args.iter().map(|a| a.replace("{in}", input.to_str().unwrap()).replace("{out}", &output)).collect();
        let status = Command::new(program).args(&args).output().unwrap();
        assert!(status.status.success(), "{program} {args:?}: {}", String::from_utf8_lossy(&status.stderr));
    }

    fn edit_manifest(&self, edit: impl FnOnce(&str) -> String) {
        let text = String::from_utf8(self.original("campaign.toml")).unwrap();
        self.write("campaign.toml", edit(&text));
    }

    /// Turn the directory `dir` (inside the overlay) and its ancestors into real directories (made when missing).
    fn materialise(&self, dir: &Path) {
        let relative = dir.strip_prefix(self.dir.path()).unwrap();
        let mut at = self.dir.path().to_owned();
        for part in relative.components() {
            at.push(part);
            if !at.exists() {
                std::fs::create_dir(&at).unwrap();
            } else if std::fs::symlink_metadata(&at).is_ok_and(|m| m.file_type().is_symlink()) {
                let source = std::fs::read_link(&at).unwrap();
                std::fs::remove_file(&at).unwrap();
                std::fs::create_dir(&at).unwrap();
                link_entries(&source, &at);
            }
        }
    }

    /// The `file` column of the first row of an index.
    fn first_file(&self, index: &str, column: usize) -> String {
        let text = String::from_utf8(self.original(index)).unwrap();
        text.lines().nth(1).unwrap().split(',').nth(column).unwrap().to_owned()
    }
}

fn link_entries(from: &Path, to: &Path) {
    for entry in std::fs::read_dir(from).unwrap().flatten() {
        std::os::unix::fs::symlink(entry.path(), to.join(entry.file_name())).unwrap();
    }
}

/// The outcome of one case's command.
struct Outcome {
    code: Option<i32>,
    text: String,
}

/// Run the binary with `args` under a 4 GiB address-space limit: an allocation sized from the data aborts.
fn run(args: &[String]) -> Outcome {
    let out = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 4194304 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_plumbline"))
        .args(args)
        .env_remove("PLUMBLINE_S3_ENDPOINT")
        .output()
        .unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    Outcome { code: out.status.code(), text }
}

fn validate(o: &Overlay) -> Vec<String> {
    vec!["validate".into(), o.manifest()]
}

/// One corpus case: a name, what it does to the overlay (returning the command's arguments), the exit code,
/// and what the message must contain (the file, and the record or field).
struct Case {
    name: &'static str,
    setup: fn(&Overlay) -> Vec<String>,
    exit: i32,
    needles: &'static [&'static str],
}

const fn case(
    name: &'static str,
    exit: i32,
    needles: &'static [&'static str],
    setup: fn(&Overlay) -> Vec<String>,
) -> Case {
    Case { name, setup, exit, needles }
}

// --- byte makers -----------------------------------------------------------------------------------------------

const SBET_RECORD: usize = 17 * 8;

/// Set field `field` (0 = time, 1 = latitude, …) of SBET/smrmsg record `record` (`width` fields of 8 bytes).
fn set_f64(bytes: &mut [u8], width: usize, record: usize, field: usize, value: f64) {
    let at = (record * width + field) * 8;
    bytes[at..at + 8].copy_from_slice(&value.to_le_bytes());
}

fn get_f64(bytes: &[u8], width: usize, record: usize, field: usize) -> f64 {
    let at = (record * width + field) * 8;
    f64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
}

fn sbet_with(o: &Overlay, edit: impl FnOnce(&mut Vec<u8>)) -> Vec<String> {
    let mut bytes = o.original("nav/dg.sbet");
    edit(&mut bytes);
    o.write("nav/dg.sbet", bytes);
    validate(o)
}

fn garbage(n: usize) -> Vec<u8> {
    (0..n).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect()
}

/// A PNG of `w × h` gray pixels of the given bit depth.
fn png(w: u32, h: u32, sixteen: bool) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    if sixteen {
        image::ImageBuffer::<image::Luma<u16>, _>::from_pixel(w, h, image::Luma([1000]))
            .write_to(&mut out, image::ImageFormat::Png)
    } else {
        image::GrayImage::from_pixel(w, h, image::Luma([128])).write_to(&mut out, image::ImageFormat::Png)
    }
    .unwrap();
    out.into_inner()
}

fn index_with(o: &Overlay, index: &str, edit: impl FnOnce(&str) -> String) -> Vec<String> {
    let text = String::from_utf8(o.original(index)).unwrap();
    o.write(index, edit(&text));
    validate(o)
}

/// Replace the first data row's `column` by `value`.
fn first_row(text: &str, column: usize, value: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let mut cells: Vec<String> = lines[1].split(',').map(str::to_owned).collect();
    cells[column] = value.to_owned();
    lines[1] = cells.join(",");
    lines.join("\n") + "\n"
}

fn first_panorama(o: &Overlay, bytes: &[u8]) -> Vec<String> {
    let file = o.first_file("panoramas/index.csv", 2);
    o.write(&format!("panoramas/{file}"), bytes);
    validate(o)
}

fn first_depth(o: &Overlay, bytes: &[u8]) -> Vec<String> {
    let file = o.first_file("depth/right/index.csv", 2);
    o.write(&format!("depth/right/{file}"), bytes);
    validate(o)
}

fn first_aerial(o: &Overlay, bytes: &[u8]) -> Vec<String> {
    let file = o.first_file("aerial/exterior_orientation.csv", 1);
    o.write(&format!("aerial/frames/{file}"), bytes);
    validate(o)
}

fn ortho(o: &Overlay, args: &[&str]) -> Vec<String> {
    o.tool("aerial/orthophoto.tif", "gdal_translate", args);
    validate(o)
}

fn terrain(o: &Overlay, args: &[&str]) -> Vec<String> {
    o.tool("aerial/terrain.tif", "gdal_translate", args);
    validate(o)
}

fn cadastre_bytes(o: &Overlay, bytes: &[u8]) -> Vec<String> {
    o.write("cadastre/poles.gpkg", bytes);
    validate(o)
}

/// The cadastre copied, then changed with SQL through GDAL's GeoPackage driver (`ogrinfo -sql`).
fn cadastre_sql(o: &Overlay, statements: &[&str]) {
    o.tool("cadastre/poles.gpkg", "cp", &["{in}", "{out}"]);
    let path = o.path("cadastre/poles.gpkg");
    for sql in statements {
        let out = Command::new("ogrinfo").args(["-q", &path, "-sql", sql]).output().unwrap();
        assert!(out.status.success(), "{sql}: {}", String::from_utf8_lossy(&out.stderr));
    }
}

fn manifest_edit(o: &Overlay, edit: impl FnOnce(&str) -> String) -> Vec<String> {
    o.edit_manifest(edit);
    validate(o)
}

fn cadastre_section(o: &Overlay, from: &str, to: &str) -> Vec<String> {
    manifest_edit(o, |m| {
        assert!(m.contains(from), "{from}");
        m.replacen(from, to, 1)
    })
}

/// Point clouds named in the manifest: each (name, bytes) written under `lidar/`.
fn clouds(o: &Overlay, files: &[(&str, Vec<u8>)]) -> Vec<String> {
    let mut list = Vec::new();
    for (name, bytes) in files {
        o.write(&format!("lidar/{name}"), bytes);
        list.push(format!("\"lidar/{name}\""));
    }
    manifest_edit(o, |m| m.replacen("output = ", &format!("point_clouds = [{}]\noutput = ", list.join(", ")), 1))
}

/// A small LAS 1.2 file (format `format`) with points at `(e, n)` offsets from the drive's start.
fn las(format: u8, at: (f64, f64), points: usize) -> Vec<u8> {
    let mut builder = las::Builder::from((1, 2));
    builder.point_format = las::point::Format::new(format).unwrap();
    let transform = |offset: f64| las::Transform { scale: 0.001, offset: offset.floor() };
    builder.transforms = las::Vector { x: transform(at.0), y: transform(at.1), z: transform(0.0) };
    let header = builder.into_header().unwrap();
    let mut writer = las::Writer::new(std::io::Cursor::new(Vec::new()), header).unwrap();
    for i in 0..points {
        let mut p = las::Point { x: at.0 + i as f64 * 0.1, y: at.1, z: 10.0, ..Default::default() };
        if format == 1 {
            p.gps_time = Some(345_610.0 + i as f64 * 1e-3);
        }
        writer.write_point(p).unwrap();
    }
    writer.into_inner().unwrap().into_inner()
}

/// Where the tiny drive is (the first row of its truth trajectory).
fn drive_start(o: &Overlay) -> (f64, f64) {
    let text = String::from_utf8(o.original("truth/trajectory.csv")).unwrap();
    let cells: Vec<f64> = text.lines().nth(1).unwrap().split(',').map(|c| c.parse().unwrap()).collect();
    (cells[1], cells[2])
}

fn convert(o: &Overlay, csv: &[u8]) -> Vec<String> {
    o.write("in.csv", csv);
    let args = ["trajectory", "convert", &o.path("in.csv"), &o.path("out.sbet"), "--from-epsg", "25832"];
    args.into_iter().map(str::to_owned).collect()
}

fn reference_csv(o: &Overlay, edit: impl FnOnce(Vec<String>) -> Vec<String>) -> Vec<String> {
    let text = String::from_utf8(o.original("truth/trajectory.csv")).unwrap();
    let lines: Vec<String> = text.lines().take(400).map(str::to_owned).collect();
    convert(o, (edit(lines).join("\n") + "\n").as_bytes())
}

fn inspect(o: &Overlay, bytes: &[u8]) -> Vec<String> {
    o.write("x.gpkg", bytes);
    vec!["cadastre".into(), "inspect".into(), o.path("x.gpkg")]
}

fn lines_export(o: &Overlay, gpkg: &[u8]) -> Vec<String> {
    o.write("x.gpkg", gpkg);
    ["lines", "export", &o.path("x.gpkg"), "--out", &o.path("lines.geojson")].into_iter().map(str::to_owned).collect()
}

fn lines_compare(o: &Overlay, gpkg: &[u8], markings: &str) -> Vec<String> {
    o.write("x.gpkg", gpkg);
    o.write("m.csv", markings);
    ["lines", "compare", &o.path("x.gpkg"), &o.path("m.csv")].into_iter().map(str::to_owned).collect()
}

fn navigate(o: &Overlay, gnss: Option<&[u8]>, imu: Option<&[u8]>) -> Vec<String> {
    if let Some(g) = gnss {
        o.write("nav/gnss.csv", g);
    }
    if let Some(i) = imu {
        o.write("nav/imu.csv", i);
    }
    vec![
        "navigate".into(),
        "--gnss".into(),
        o.path("nav/gnss.csv"),
        "--imu".into(),
        o.path("nav/imu.csv"),
        "--out".into(),
        o.path("nav-out"),
    ]
}

fn adjust(o: &Overlay, observations: &[u8]) -> Vec<String> {
    o.write("obs.json", observations);
    let sbet = o.path("nav/dg.sbet");
    let (obs, out) = (o.path("obs.json"), o.path("adj-out"));
    let args = ["adjust", "--trajectory", &sbet, "--epsg", "25832", "--observations", &obs, "--out", &out];
    args.into_iter().map(str::to_owned).collect()
}

fn match_pair(o: &Overlay, a: &[u8], b: &[u8]) -> Vec<String> {
    o.write("a.png", a);
    o.write("b.png", b);
    vec!["match".into(), o.path("a.png"), o.path("b.png")]
}

/// A PNG of random-looking gray noise (nothing to match).
fn noise_png(seed: u32) -> Vec<u8> {
    let img = image::GrayImage::from_fn(256, 256, |x, y| {
        image::Luma([
            ((x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663) ^ seed.wrapping_mul(83_492_791)) >> 7) as u8
        ])
    });
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

// --- the corpus ------------------------------------------------------------------------------------------------

const INVALID: i32 = 2;

#[rustfmt::skip]
fn cases() -> Vec<Case> {
    vec![
        // The manifest itself.
        case("manifest: empty", INVALID, &["campaign.toml"], |o| { o.write("campaign.toml", ""); validate(o) }),
        case("manifest: binary garbage", INVALID, &["campaign.toml", "UTF-8"], |o| { o.write("campaign.toml", garbage(4096)); validate(o) }),
        case("manifest: non-UTF-8 byte in a string", INVALID, &["campaign.toml", "UTF-8"], |o| { let mut m = o.original("campaign.toml"); m[40] = 0xff; o.write("campaign.toml", m); validate(o) }),
        case("manifest: TOML syntax error", INVALID, &["campaign.toml", "line"], |o| manifest_edit(o, |m| m.replacen("crs = ", "crs == ", 1))),
        case("manifest: unknown version", INVALID, &["campaign.toml", "version"], |o| manifest_edit(o, |m| m.replacen("version = \"1\"", "version = \"7\"", 1))),
        case("manifest: geographic CRS", INVALID, &["campaign.toml", "crs", "4326"], |o| manifest_edit(o, |m| m.replacen("crs = 25832", "crs = 4326", 1))),
        case("manifest: CRS unknown to PROJ", INVALID, &["campaign.toml", "crs", "999999"], |o| manifest_edit(o, |m| m.replacen("crs = 25832", "crs = 999999", 1))),
        case("manifest: unknown field", INVALID, &["campaign.toml", "tile_size"], |o| manifest_edit(o, |m| format!("{m}\n[tiling]\ntile_size = 3\n"))),
        case("manifest: no trajectory", INVALID, &["campaign.toml", "trajectory"], |o| manifest_edit(o, |m| m.replacen("[[trajectory]]", "[[trajectory_]]", 1))),
        case("manifest: 100000-deep nested arrays", INVALID, &["campaign.toml"], |o| manifest_edit(o, |m| format!("{m}\nx = {}{}\n", "[".repeat(100_000), "]".repeat(100_000)))),
        case("manifest: 8 MB campaign name", INVALID, &["campaign.toml", "name"], |o| manifest_edit(o, |m| m.replacen("name = \"", &format!("name = \"{}", "x".repeat(8 << 20)), 1))),
        case("manifest: input missing", INVALID, &["trajectory[0]", "dg.sbet", "does not exist"], |o| { o.materialise(&o.dir.path().join("nav")); std::fs::remove_file(o.path("nav/dg.sbet")).unwrap(); validate(o) }),
        case("manifest: location escaping with a scheme it cannot read", INVALID, &["cadastres[0]", "ftp://"], |o| manifest_edit(o, |m| m.replacen("url = \"cadastre/poles.gpkg\"", "url = \"ftp://example.invalid/poles.gpkg\"", 1))),

        // SBET trajectory.
        case("sbet: empty", INVALID, &["trajectory[0]", "dg.sbet"], |o| sbet_with(o, Vec::clear)),
        case("sbet: truncated mid-record", INVALID, &["trajectory[0]", "dg.sbet", "136"], |o| sbet_with(o, |b| b.truncate(10 * SBET_RECORD + 50))),
        case("sbet: text file", INVALID, &["trajectory[0]", "dg.sbet"], |o| { o.write("nav/dg.sbet", "time,lat,lon\n1,2,3\n"); validate(o) }),
        case("sbet: one record", INVALID, &["trajectory[0]", "dg.sbet"], |o| sbet_with(o, |b| b.truncate(SBET_RECORD))),
        case("sbet: NaN latitude", INVALID, &["trajectory[0]", "dg.sbet", "record 100", "latitude"], |o| sbet_with(o, |b| set_f64(b, 17, 100, 1, f64::NAN))),
        case("sbet: infinite time", INVALID, &["trajectory[0]", "dg.sbet", "record 7", "time"], |o| sbet_with(o, |b| set_f64(b, 17, 7, 0, f64::INFINITY))),
        case("sbet: records out of order", INVALID, &["trajectory[0]", "dg.sbet", "record 11", "time"], |o| sbet_with(o, |b| { let t = get_f64(b, 17, 10, 0); set_f64(b, 17, 11, 0, t - 1.0); })),
        case("sbet: duplicate time", INVALID, &["trajectory[0]", "dg.sbet", "record 11", "time"], |o| sbet_with(o, |b| { let t = get_f64(b, 17, 10, 0); set_f64(b, 17, 11, 0, t); })),
        case("sbet: 1 km position jump", INVALID, &["trajectory[0]", "dg.sbet", "record 200"], |o| sbet_with(o, |b| { let lat = get_f64(b, 17, 200, 1); set_f64(b, 17, 200, 1, lat + 1.6e-4); })),
        case("sbet: latitude out of range", INVALID, &["trajectory[0]", "dg.sbet", "record 3", "latitude"], |o| sbet_with(o, |b| set_f64(b, 17, 3, 1, 4.0))),
        case("smrmsg: empty", INVALID, &["trajectory[0]", "dg.smrmsg"], |o| { o.write("nav/dg.smrmsg", ""); validate(o) }),
        case("smrmsg: truncated", INVALID, &["trajectory[0]", "dg.smrmsg"], |o| { let b = o.original("nav/dg.smrmsg"); o.write("nav/dg.smrmsg", &b[..1000]); validate(o) }),
        case("smrmsg: NaN sigma", INVALID, &["trajectory[0]", "dg.smrmsg", "record 5"], |o| { let mut b = o.original("nav/dg.smrmsg"); set_f64(&mut b, 10, 5, 1, f64::NAN); o.write("nav/dg.smrmsg", b); validate(o) }),
        case("reference trajectory: garbage is a warning, the campaign stays valid", 0, &["trajectory[0].reference", "trajectory.csv", "warning"], |o| { o.write("truth/trajectory.csv", garbage(3000)); validate(o) }),

        // Trajectory CSV (`trajectory convert`).
        case("csv: empty", INVALID, &["in.csv"], |o| convert(o, b"")),
        case("csv: header only", INVALID, &["in.csv"], |o| reference_csv(o, |l| l[..1].to_vec())),
        case("csv: missing northing column", INVALID, &["in.csv", "northing"], |o| reference_csv(o, |l| l.iter().map(|r| r.split(',').enumerate().filter(|(i, _)| *i != 2).map(|(_, c)| c).collect::<Vec<_>>().join(",")).collect())),
        case("csv: text in a number field", INVALID, &["in.csv", "line 5", "easting"], |o| reference_csv(o, |mut l| { l[4] = first_row(&format!("h\n{}", l[4]), 1, "abc").lines().nth(1).unwrap().to_owned(); l })),
        case("csv: NaN height", INVALID, &["in.csv", "line 9", "height"], |o| reference_csv(o, |mut l| { l[8] = first_row(&format!("h\n{}", l[8]), 3, "NaN").lines().nth(1).unwrap().to_owned(); l })),
        case("csv: unsorted times", INVALID, &["in.csv", "time"], |o| reference_csv(o, |mut l| { l.swap(20, 21); l })),
        case("csv: duplicate time", INVALID, &["in.csv", "time"], |o| reference_csv(o, |mut l| { let d = l[30].clone(); l.insert(31, d); l })),
        case("csv: non-UTF-8 bytes", INVALID, &["in.csv"], |o| { let mut b = o.original("truth/trajectory.csv")[..20_000].to_vec(); b[5000] = 0xfe; convert(o, &b) }),
        case("csv: a 16 MB line", INVALID, &["in.csv"], |o| reference_csv(o, |mut l| { l[3] = "9".repeat(16 << 20); l })),
        case("csv: unknown unit", INVALID, &["in.csv", "easting"], |o| reference_csv(o, |mut l| { l[0] = l[0].replacen("easting[m]", "easting[furlong]", 1); l })),
        case("csv: binary garbage", INVALID, &["in.csv"], |o| convert(o, &garbage(50_000))),

        // Image indexes.
        case("panorama index: empty", INVALID, &["panoramas.index", "index.csv"], |o| index_with(o, "panoramas/index.csv", |_| String::new())),
        case("panorama index: header only", INVALID, &["panoramas.index", "index.csv", "no usable row"], |o| index_with(o, "panoramas/index.csv", |t| t.lines().next().unwrap().to_owned() + "\n")),
        case("panorama index: no time column", INVALID, &["panoramas.index", "index.csv", "time"], |o| index_with(o, "panoramas/index.csv", |t| t.replacen("image_id,time,file", "image_id,when,file", 1))),
        case("panorama index: one bad time is a warning", 0, &["panoramas.index", "index.csv", "line 2", "time", "warning"], |o| index_with(o, "panoramas/index.csv", |t| first_row(t, 1, "soon"))),
        case("panorama index: duplicate id is a warning", 0, &["panoramas.index", "index.csv", "line 3", "warning"], |o| index_with(o, "panoramas/index.csv", |t| { let mut l: Vec<&str> = t.lines().collect(); let d = l[1]; l.insert(2, d); l.join("\n") + "\n" })),
        case("panorama index: all times outside the trajectory", INVALID, &["panoramas.index", "outside the trajectory"], |o| index_with(o, "panoramas/index.csv", |t| t.lines().enumerate().map(|(i, l)| if i == 0 { l.to_owned() } else { let c: Vec<&str> = l.split(',').collect(); format!("{},{},{}", c[0], c[1].parse::<f64>().unwrap() - 86_400.0, c[2]) }).collect::<Vec<_>>().join("\n") + "\n")),
        case("panorama index: an absolute path row", INVALID, &["panoramas.index", "/etc/hostname", "outside"], |o| index_with(o, "panoramas/index.csv", |t| first_row(t, 2, "/etc/hostname"))),
        case("panorama index: a parent-directory row", INVALID, &["panoramas.index", "../", "outside"], |o| index_with(o, "panoramas/index.csv", |t| first_row(t, 2, "../nav/dg.sbet"))),
        case("panorama index: another agency's URL", INVALID, &["panoramas.index", "s3://other-agency/", "outside"], |o| index_with(o, "panoramas/index.csv", |t| first_row(t, 2, "s3://other-agency/p.jpg"))),
        case("panorama index: non-UTF-8", INVALID, &["panoramas.index", "index.csv"], |o| { let mut b = o.original("panoramas/index.csv"); b[25] = 0xc3; b[26] = 0x28; o.write("panoramas/index.csv", b); validate(o) }),
        case("panorama index: binary garbage", INVALID, &["panoramas.index", "index.csv"], |o| { o.write("panoramas/index.csv", garbage(2048)); validate(o) }),
        case("depth index: empty", INVALID, &["depth[0].index", "index.csv"], |o| index_with(o, "depth/right/index.csv", |_| String::new())),
        case("depth index: all times outside the trajectory", INVALID, &["depth[0].index", "outside the trajectory"], |o| index_with(o, "depth/right/index.csv", |t| t.lines().enumerate().map(|(i, l)| if i == 0 { l.to_owned() } else { let c: Vec<&str> = l.split(',').collect(); format!("{},{},{}", c[0], c[1].parse::<f64>().unwrap() + 1e6, c[2]) }).collect::<Vec<_>>().join("\n") + "\n")),
        case("aerial orientations: empty", INVALID, &["aerial.frames.index", "exterior_orientation.csv"], |o| index_with(o, "aerial/exterior_orientation.csv", |_| String::new())),
        case("aerial orientations: missing column", INVALID, &["aerial.frames.index", "kappa"], |o| index_with(o, "aerial/exterior_orientation.csv", |t| t.replacen("kappa_deg", "kapa_deg", 1))),
        case("aerial orientations: NaN omega is a warning", 0, &["aerial.frames.index", "line 2", "omega", "warning"], |o| index_with(o, "aerial/exterior_orientation.csv", |t| first_row(t, 5, "NaN"))),
        case("aerial orientations: 100 km away (another CRS)", INVALID, &["aerial.frames.index", "within 2 km"], |o| index_with(o, "aerial/exterior_orientation.csv", |t| t.lines().enumerate().map(|(i, l)| if i == 0 { l.to_owned() } else { let mut c: Vec<String> = l.split(',').map(str::to_owned).collect(); c[2] = (c[2].parse::<f64>().unwrap() + 100_000.0).to_string(); c.join(",") }).collect::<Vec<_>>().join("\n") + "\n")),

        // Images named by the indexes (headers only).
        case("panorama: empty file", INVALID, &["panoramas.index", ".jpg", "not a readable image"], |o| first_panorama(o, b"")),
        case("panorama: text file", INVALID, &["panoramas.index", ".jpg", "not a readable image"], |o| first_panorama(o, b"<html>not found</html>")),
        case("panorama: truncated JPEG header", INVALID, &["panoramas.index", ".jpg"], |o| { let file = o.first_file("panoramas/index.csv", 2); let b = o.original(&format!("panoramas/{file}")); first_panorama(o, &b[..20]) }),
        case("panorama: wrong size", INVALID, &["panoramas.index", ".jpg", "100 × 50", "1024 × 512"], |o| first_panorama(o, &png(100, 50, false))),
        case("panorama: 20000² header (bomb)", INVALID, &["panoramas.index", ".jpg", "20000 × 20000"], |o| first_panorama(o, &png_claiming(20_000, 20_000))),
        case("depth: 8-bit instead of 16-bit", INVALID, &["depth[0].index", ".png", "16-bit"], |o| first_depth(o, &png(320, 180, false))),
        case("depth: wrong size", INVALID, &["depth[0].index", ".png", "64 × 64", "320 × 180"], |o| first_depth(o, &png(64, 64, true))),
        case("depth: empty file", INVALID, &["depth[0].index", ".png", "not a readable image"], |o| first_depth(o, b"")),
        case("aerial frame: wrong size", INVALID, &["aerial.frames.index", ".jpg", "1000 × 750"], |o| first_aerial(o, &png(500, 375, false))),
        case("aerial frame: garbage", INVALID, &["aerial.frames.index", ".jpg", "not a readable image"], |o| first_aerial(o, &garbage(10_000))),
        case("vehicle mask: wrong size", INVALID, &["panoramas.vehicle_mask", "vehicle_mask.png", "1024 × 512"], |o| { o.write("panoramas/vehicle_mask.png", png(512, 256, false)); validate(o) }),
        case("vehicle mask: garbage", INVALID, &["panoramas.vehicle_mask", "vehicle_mask.png", "not a readable image"], |o| { o.write("panoramas/vehicle_mask.png", garbage(700)); validate(o) }),

        // Orthophoto and terrain model.
        case("orthophoto: empty", INVALID, &["aerial.orthophoto.image", "orthophoto.tif", "empty"], |o| { o.write("aerial/orthophoto.tif", b""); validate(o) }),
        case("orthophoto: text file", INVALID, &["aerial.orthophoto.image", "orthophoto.tif"], |o| { o.write("aerial/orthophoto.tif", "GeoTIFF please"); validate(o) }),
        case("orthophoto: truncated TIFF", INVALID, &["aerial.orthophoto.image", "orthophoto.tif"], |o| { let b = o.original("aerial/orthophoto.tif"); o.write("aerial/orthophoto.tif", &b[..300]); validate(o) }),
        case("orthophoto: another CRS", INVALID, &["aerial.orthophoto.image", "orthophoto.tif", "EPSG:25833", "EPSG:25832"], |o| ortho(o, &["-q", "-a_srs", "EPSG:25833", "{in}", "{out}"])),
        case("orthophoto: no CRS", INVALID, &["aerial.orthophoto.image", "orthophoto.tif", "no CRS"], |o| ortho(o, &["-q", "-a_srs", "LOCAL_CS[\"arbitrary\"]", "{in}", "{out}"])),
        case("orthophoto: misses the drive", INVALID, &["aerial.orthophoto.image", "orthophoto.tif", "misses the drive"], |o| ortho(o, &["-q", "-a_ullr", "100000", "5100000", "100500", "5099500", "{in}", "{out}"])),
        case("orthophoto: two bands", INVALID, &["aerial.orthophoto.image", "orthophoto.tif", "2 band(s)"], |o| ortho(o, &["-q", "-b", "1", "-b", "1", "{in}", "{out}"])),
        case("orthophoto: 32-bit float", INVALID, &["aerial.orthophoto.image", "orthophoto.tif", "Float32"], |o| ortho(o, &["-q", "-ot", "Float32", "{in}", "{out}"])),
        case("orthophoto: 16-bit is fine", 0, &["valid"], |o| ortho(o, &["-q", "-ot", "UInt16", "-scale", "0", "255", "0", "65535", "{in}", "{out}"])),
        case("orthophoto: a PNG without georeferencing", INVALID, &["aerial.orthophoto.image", "orthophoto.tif", "georeferenced"], |o| { o.write("aerial/orthophoto.tif", png(64, 64, false)); validate(o) }),
        case("orthophoto: a VRT that is no XML", INVALID, &["aerial.orthophoto.image", "orthophoto.vrt"], |o| { o.write("aerial/orthophoto.vrt", "<VRTDataset rasterXSize=\"10\" <<<"); manifest_edit(o, |m| m.replacen("aerial/orthophoto.tif", "aerial/orthophoto.vrt", 1)) }),
        case("terrain: empty", INVALID, &["aerial.orthophoto.terrain", "terrain.tif", "empty"], |o| { o.write("aerial/terrain.tif", b""); validate(o) }),
        case("terrain: another CRS", INVALID, &["aerial.orthophoto.terrain", "terrain.tif", "EPSG:31467"], |o| terrain(o, &["-q", "-a_srs", "EPSG:31467", "{in}", "{out}"])),
        case("terrain: misses the drive", INVALID, &["aerial.orthophoto.terrain", "terrain.tif", "misses the drive"], |o| terrain(o, &["-q", "-a_ullr", "300000", "5100000", "300500", "5099500", "{in}", "{out}"])),

        // Cadastres.
        case("cadastre: 0-byte GeoPackage", INVALID, &["cadastres[0]", "poles.gpkg", "empty (0 bytes"], |o| cadastre_bytes(o, b"")),
        case("cadastre: text named .gpkg", INVALID, &["cadastres[0]", "poles.gpkg", "no SQLite header"], |o| cadastre_bytes(o, b"fid,x,y\n1,2,3\n")),
        case("cadastre: truncated GeoPackage", INVALID, &["cadastres[0]", "poles.gpkg"], |o| { let b = o.original("cadastre/poles.gpkg"); cadastre_bytes(o, &b[..b.len() / 3]) }),
        case("cadastre: raster-only GeoPackage", INVALID, &["cadastres[0]", "poles.gpkg", "raster tiles only"], |o| { o.tool("cadastre/poles.gpkg", "gdal_translate", &["-q", "-of", "GPKG", &o.base.join("aerial/terrain.tif").to_string_lossy(), "{out}"]); validate(o) }),
        case("cadastre: corrupted table page", INVALID, &["cadastres[0]", "poles.gpkg", "ReadFailed", "malformed"], |o| { let mut b = o.original("cadastre/poles.gpkg"); let size = usize::from(u16::from_be_bytes([b[16], b[17]])); let root = root_page(&o.base.join("cadastre/poles.gpkg"), "poles"); b[(root - 1) * size..root * size].fill(0xAB); cadastre_bytes(o, &b) }),
        case("cadastre: missing layer", INVALID, &["cadastres[0]", "poles.gpkg", "MissingLayer", "bäume"], |o| cadastre_section(o, "layers = [\"poles\", \"trees\"]", "layers = [\"poles\", \"bäume\"]")),
        case("cadastre: wrong class attribute", INVALID, &["cadastres[0]", "poles.gpkg", "field \"klasse\"", "MissingField"], |o| cadastre_section(o, "class_attribute = \"class\"", "class_attribute = \"klasse\"")),
        case("cadastre: wrong diameter attribute is a warning", 0, &["cadastres[0]", "poles.gpkg", "durchmesser", "warning"], |o| cadastre_section(o, "diameter_attribute = \"diameter_m\"", "diameter_attribute = \"durchmesser\"")),
        case("cadastre: no class values known", INVALID, &["cadastres[0]", "poles.gpkg", "no usable object"], |o| cadastre_section(o, "light = \"light\"\nsign = \"sign\"\ntraffic_light = \"sign\"\ntree = \"tree\"", "mast = \"light\"")),
        case("cadastre: layer without SRS, no epsg", INVALID, &["cadastres[0]", "poles.gpkg", "MissingSrs"], |o| { cadastre_sql(o, &["UPDATE gpkg_geometry_columns SET srs_id = -1", "UPDATE gpkg_contents SET srs_id = -1"]); validate(o) }),
        case("cadastre: layer without SRS, wrong epsg", INVALID, &["cadastres[0]", "poles.gpkg", "within 100 m of the drive"], |o| { cadastre_sql(o, &["UPDATE gpkg_geometry_columns SET srs_id = -1", "UPDATE gpkg_contents SET srs_id = -1"]); cadastre_section(o, "layers = [\"poles\", \"trees\"]", "layers = [\"poles\", \"trees\"]\nepsg = 25833") }),
        case("cadastre: epsg conflicting with the layer's SRS", INVALID, &["cadastres[0]", "poles.gpkg", "SrsConflict", "EPSG:31467"], |o| cadastre_section(o, "layers = [\"poles\", \"trees\"]", "layers = [\"poles\", \"trees\"]\nepsg = 31467")),
        case("cadastre: undecodable geometry blob is a warning", 0, &["cadastres[0]", "poles.gpkg", "BadGeometry", "warning"], |o| { cadastre_sql(o, &["UPDATE poles SET geom = X'47500001DEADBEEF' WHERE fid = (SELECT min(fid) FROM poles)"]); validate(o) }),
        case("cadastre: a 1 MB class value is a warning", 0, &["cadastres[0]", "poles.gpkg", "UnknownClass", "warning"], |o| { cadastre_sql(o, &["UPDATE poles SET class = hex(zeroblob(500000)) WHERE fid = (SELECT min(fid) FROM poles)"]); validate(o) }),
        case("lines export: 0-byte file", INVALID, &["x.gpkg", "empty (0 bytes"], |o| lines_export(o, b"")),
        case("lines export: garbage", INVALID, &["x.gpkg", "no SQLite header"], |o| lines_export(o, &garbage(8192))),
        case("lines export: a GeoPackage without road lines", INVALID, &["x.gpkg", "no layer `road_lines`", "poles"], |o| lines_export(o, &o.original("cadastre/poles.gpkg"))),
        case("lines compare: a bad WKT row", INVALID, &["m.csv", "line 3", "wkt"], |o| lines_compare(o, &o.original("cadastre/poles.gpkg"), "id,kind,width_m,wkt\na,solid,0.12,\"LINESTRING (0 0, 1 1)\"\nb,solid,0.12,\"LINESTRING (0 0, 1 y)\"\n")),
        case("lines compare: no markings", INVALID, &["m.csv", "no markings"], |o| lines_compare(o, &o.original("cadastre/poles.gpkg"), "id,kind,width_m,wkt\n")),
        case("cadastre inspect: 0-byte file", INVALID, &["x.gpkg", "empty (0 bytes"], |o| inspect(o, b"")),
        case("cadastre inspect: text file", INVALID, &["x.gpkg", "no SQLite header"], |o| inspect(o, b"hello\n")),
        case("cadastre inspect: binary garbage", INVALID, &["x.gpkg", "no SQLite header"], |o| inspect(o, &garbage(8192))),
        case("cadastre inspect: corrupted page is listed", 0, &["poles", "ReadFailed", "malformed"], |o| { let mut b = o.original("cadastre/poles.gpkg"); let size = usize::from(u16::from_be_bytes([b[16], b[17]])); let root = root_page(&o.base.join("cadastre/poles.gpkg"), "poles"); b[(root - 1) * size..root * size].fill(0xAB); inspect(o, &b) }),

        // Point clouds (headers only).
        case("point cloud: empty", INVALID, &["point_clouds[0]", "a.laz"], |o| clouds(o, &[("a.laz", Vec::new())])),
        case("point cloud: text file", INVALID, &["point_clouds[0]", "a.las", "LASF"], |o| clouds(o, &[("a.las", b"x y z\n1 2 3\n".to_vec())])),
        case("point cloud: truncated header", INVALID, &["point_clouds[0]", "a.las"], |o| { let b = las(1, drive_start(o), 10); clouds(o, &[("a.las", b[..120].to_vec())]) }),
        case("point cloud: points cut off", INVALID, &["point_clouds[0]", "a.las"], |o| { let b = las(1, drive_start(o), 100); clouds(o, &[("a.las", b[..b.len() - 500].to_vec())]) }),
        case("point cloud: bad point format", INVALID, &["point_clouds[0]", "a.las", "format"], |o| { let mut b = las(1, drive_start(o), 10); b[104] = 42; clouds(o, &[("a.las", b)]) }),
        case("point cloud: far from the drive", INVALID, &["point_clouds[0]", "a.las", "misses the drive"], |o| clouds(o, &[("a.las", las(1, (100_000.0, 100_000.0), 10))])),
        case("point cloud: no GPS time is a warning", 0, &["point_clouds[0]", "a.las", "GPS time", "warning"], |o| { let at = drive_start(o); clouds(o, &[("a.las", las(0, at, 10))]) }),
        case("point cloud: no CRS record is a warning", 0, &["point_clouds[0]", "a.las", "names no CRS", "warning"], |o| { let at = drive_start(o); clouds(o, &[("a.las", las(1, at, 10))]) }),
        case("point cloud: declared in another CRS", INVALID, &["point_clouds[0]", "a.las", "EPSG:25833 moved into EPSG:25832", "misses the drive"], |o| { let at = drive_start(o); o.write("lidar/a.las", las(1, at, 10)); manifest_edit(o, |m| m.replacen("output = ", "point_clouds = [{ url = \"lidar/a.las\", epsg = 25833 }]\noutput = ", 1)) }),
        case("point cloud: declared in another format", INVALID, &["point_clouds[0].format", "a.las", "declared `laz`", "header says las"], |o| { let at = drive_start(o); o.write("lidar/a.las", las(1, at, 10)); manifest_edit(o, |m| m.replacen("output = ", "point_clouds = [{ url = \"lidar/a.las\", format = \"laz\" }]\noutput = ", 1)) }),
        case("point cloud: declared without time is a warning", 0, &["point_clouds[0]", "a.las", "without GPS time", "warning"], |o| { let at = drive_start(o); o.write("lidar/a.las", las(1, at, 10)); manifest_edit(o, |m| m.replacen("output = ", "point_clouds = [{ url = \"lidar/a.las\", time = \"none\" }]\noutput = ", 1)) }),
        case("point cloud: unknown time scale", INVALID, &["point_clouds", "gps_seconds"], |o| { let at = drive_start(o); o.write("lidar/a.las", las(1, at, 10)); manifest_edit(o, |m| m.replacen("output = ", "point_clouds = [{ url = \"lidar/a.las\", time = \"gps_seconds\" }]\noutput = ", 1)) }),

        // navigate and adjust inputs.
        case("navigate: empty GNSS file", INVALID, &["gnss.csv"], |o| navigate(o, Some(b""), None)),
        case("navigate: garbage IMU file", INVALID, &["imu.csv"], |o| navigate(o, None, Some(&garbage(5000)))),
        case("navigate: NaN in a GNSS fix is skipped and named", 0, &["gnss.csv line 3: fix skipped"], |o| { let t = String::from_utf8(o.original("nav/gnss.csv")).unwrap(); let mut l: Vec<String> = t.lines().map(str::to_owned).collect(); l[2] = first_row(&format!("h\n{}", l[2]), 1, "NaN").lines().nth(1).unwrap().to_owned(); navigate(o, Some((l.join("\n") + "\n").as_bytes()), None) }),
        case("adjust: empty observations", INVALID, &["obs.json"], |o| adjust(o, b"")),
        case("adjust: garbage observations", INVALID, &["obs.json"], |o| adjust(o, &garbage(3000))),
        case("adjust: wrong version", INVALID, &["obs.json", "version"], |o| adjust(o, br#"{"version":"9","ties":[]}"#)),

        // match.
        case("match: 20000² PNG header (bomb)", INVALID, &["a.png", "20000"], |o| match_pair(o, &png_claiming(20_000, 20_000), &noise_png(1))),
        case("match: 12000² PNG header (bomb)", INVALID, &["b.png", "12000"], |o| match_pair(o, &noise_png(1), &png_claiming(12_000, 12_000))),
        case("match: a real 12000² decompression bomb", INVALID, &["a.png", "12000"], |o| match_pair(o, &png_bomb(12_000, 12_000), &noise_png(1))),
        case("panorama: a real 12000² decompression bomb", INVALID, &["panoramas.index", ".jpg", "12000 × 12000"], |o| first_panorama(o, &png_bomb(12_000, 12_000))),
        case("match: empty image", INVALID, &["a.png"], |o| match_pair(o, b"", &noise_png(1))),
        case("match: text file", INVALID, &["b.png"], |o| match_pair(o, &noise_png(1), b"not an image")),
        case("match: unrelated noise has no transform", 1, &["no similarity"], |o| match_pair(o, &noise_png(1), &noise_png(2))),
    ]
}

/// The root page of `table` in a GeoPackage (GDAL's SQL on `sqlite_master`).
fn root_page(path: &Path, table: &str) -> usize {
    let ds = gdal::Dataset::open(path).unwrap();
    let sql = format!("SELECT rootpage FROM sqlite_master WHERE name = '{table}'");
    let mut rows = ds.execute_sql(&sql, None, gdal::vector::sql::Dialect::DEFAULT).unwrap().unwrap();
    let root = rows.features().next().unwrap().field_as_integer(0).unwrap().unwrap();
    usize::try_from(root).unwrap()
}

#[test]
fn the_corpus_gives_clear_errors_and_nothing_crashes() {
    let base = base();
    let cases = cases();
    assert!(cases.len() >= 100, "the corpus holds {} cases", cases.len());
    let mut failures = Vec::new();
    for case in &cases {
        let overlay = Overlay::new(&base);
        let args = (case.setup)(&overlay);
        let out = run(&args);
        let crashed = out.code.is_none() || out.text.contains("panicked") || out.text.contains("memory allocation");
        let missing: Vec<&str> = case.needles.iter().copied().filter(|n| !out.text.contains(n)).collect();
        if crashed || out.code != Some(case.exit) || !missing.is_empty() {
            failures.push(format!(
                "{}: exit {:?} (expected {}), missing {missing:?}\n{}",
                case.name,
                out.code,
                case.exit,
                out.text.chars().take(1500).collect::<String>()
            ));
        }
    }
    assert!(failures.is_empty(), "{} of {} cases failed:\n\n{}", failures.len(), cases.len(), failures.join("\n\n"));
}

#[test]
fn item_level_defects_are_skipped_and_the_run_goes_on() {
    let o = Overlay::new(&base());
    // A broken panorama (not the first), a depth image of another size, a bad index row, an undecodable
    // cadastre geometry: each is skipped and reported, and the campaign is corrected without them.
    let panoramas = String::from_utf8(o.original("panoramas/index.csv")).unwrap();
    let broken = panoramas.lines().nth(5).unwrap().split(',').nth(2).unwrap().to_owned();
    o.write(&format!("panoramas/{broken}"), garbage(5000));
    let depth = String::from_utf8(o.original("depth/right/index.csv")).unwrap();
    let small = depth.lines().nth(4).unwrap().split(',').nth(2).unwrap().to_owned();
    o.write(&format!("depth/right/{small}"), png(64, 64, true));
    o.write("panoramas/index.csv", first_row(&panoramas, 1, "soon"));
    // An undecodable geometry has no place, so a tile's spatial filter never returns it: `validate`, which
    // reads every feature, names it. A class nobody maps is skipped by the tile that reads it.
    cadastre_sql(
        &o,
        &[
            "UPDATE poles SET geom = X'47500001DEADBEEF' WHERE fid = (SELECT min(fid) FROM poles)",
            "UPDATE poles SET class = 'ufo' WHERE fid IN (SELECT fid FROM poles ORDER BY fid LIMIT 30 OFFSET 1)",
        ],
    );

    // A point cloud of 10 points yields no pole: the run warns, and with --strict exits 4.
    clouds(&o, &[("a.las", las(1, drive_start(&o), 10))]);

    let v = run(&validate(&o));
    assert_eq!(v.code, Some(0), "item-level defects leave the campaign valid:\n{}", v.text);
    for needle in ["warning: panoramas.index", "line 2", "BadGeometry", "UnknownClass"] {
        assert!(v.text.contains(needle), "{needle}: {}", v.text);
    }

    // Rows naming another agency's object or a worker-local file (which `validate` refuses) are skipped by the
    // run, never read.
    let time = panoramas.lines().nth(3).unwrap().split(',').nth(1).unwrap().to_owned();
    let escaping = format!("evil1,{time},file:///etc/hostname\nevil2,{time},s3://agency-b/panoramas/p.jpg\n");
    o.write("panoramas/index.csv", first_row(&panoramas, 1, "soon") + &escaping);
    let r = run(&["run".to_owned(), o.manifest(), "--quiet".to_owned(), "--strict".to_owned()]);
    assert_eq!(r.code, Some(4), "--strict and a named input without control: {}", r.text);
    assert!(r.text.contains("WARNING no control from point_clouds[0]"), "in the summary: {}", r.text);
    assert!(r.text.contains("warning: 1 named input(s) gave no control"), "in the exit message: {}", r.text);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(o.path("results/report.json")).unwrap()).unwrap();
    let warnings = report["warnings"].as_array().unwrap();
    assert_eq!(warnings.len(), 1, "only the point cloud: {warnings:#?}");
    assert_eq!(warnings[0]["input"], "point_clouds[0]");
    let skipped = report["skipped"].as_array().unwrap();
    let find = |needle: &str, reason: &str| {
        skipped
            .iter()
            .any(|s| s["detail"].as_str().unwrap().contains(needle) && s["reason"].as_str().unwrap().contains(reason))
    };
    assert!(find(&broken, "decode"), "the broken panorama: {skipped:#?}");
    assert!(find(&small, "frame") && find("64 × 64 px", "frame"), "the depth image of another size: {skipped:#?}");
    assert!(find("index.csv line 2", "time"), "the bad index row: {skipped:#?}");
    assert!(find("file:///etc/hostname", "url") && find("s3://agency-b/", "url"), "escaping rows: {skipped:#?}");
    assert!(find("poles.gpkg", "unknown_class") && find("\"ufo\"", "unknown_class"), "the unknown class: {skipped:#?}");
    assert!(report["summary"]["images_matched"].as_u64().unwrap() > 0, "the rest was registered");
    assert!(report["summary"]["pole_updates"].as_u64().unwrap() > 0, "and matched to the cadastre");
}
