//! `plumbline simulate`: write a synthetic campaign with ground truth — truth and DG trajectories, raw GNSS
//! and IMU, the DG error series and a v1 manifest naming them — under a directory or object-store prefix.
//!
//! Layout under `--out` (paths relative to `campaign.toml`):
//! - `nav/dg.sbet`, `nav/dg.smrmsg`: the DG solution, WGS 84 geographic (SBET + standard deviations);
//! - `nav/dg.csv`: the same in the campaign CRS (the world's, EPSG 25832) with standard deviations;
//! - `nav/gnss.csv`, `nav/imu.csv`: raw GNSS fixes and IMU increments (columns: `plumbline_synth::motion::files`);
//! - `truth/trajectory.csv`: the true trajectory (campaign CRS, σ = 0), the manifest's `reference`;
//! - `truth/dg_errors.csv`: DG − truth per epoch with the environment and fault;
//! - `truth/road_markings.csv`: the road paint the panoramas see, one row per dash, solid line, stop line, zebra
//!   stripe and arrow shaft: `id,kind,width_m,wkt`, the centre line as a quoted WKT `LINESTRING` in the campaign
//!   CRS (`plumbline_synth::texture::road_markings`; for `--preset city` leg by leg, each street once, the
//!   streets the drive comes within 40 m of);
//! - `overview.png`: a map of the drive coloured by the horizontal DG error, standstills in black;
//! - `panoramas/`: equirectangular JPEGs every `--panorama-spacing` metres rendered with the TRUE pose,
//!   `index.csv` and `vehicle_mask.png` (non-zero = vehicle); `truth/images.csv`: true and DG poses then;
//! - `truth/pixels/{image_id}_range.png` and `_class.png`: the ground truth under every panorama pixel — the
//!   distance from the camera centre along the pixel-centre ray to the first surface (16-bit PNG, millimetres,
//!   0 = sky, the vehicle, or farther than 65.534 m) and what it is (8-bit PNG: 0 none, 1 ground, 2 facade,
//!   3 roof, 4 pole/trunk, 5 tree crown, 6 parked car, 7 own vehicle, 8 pedestrian). The mapping-frame point
//!   of pixel (col, row) is C + range · R·d, with C, R the TRUE camera pose (body pose of
//!   `truth/images.csv` through the manifest's `[panoramas.mount]`) and d the equirectangular ray through
//!   (col + 0.5, row + 0.5) (`plumbline_synth::render::surface_point`); a correspondence is scored against
//!   the point of its pixel;
//! - `depth/right/`: 16-bit PNG depth images (millimetres) of the side-looking camera, `index.csv`;
//!   `truth/depth_images.csv`;
//! - `lidar/strip_NNN.laz` with `--point-cloud laz`: a roof profile scanner's points (LAS 1.4 format 6, GPS
//!   week seconds, CRS as WKT), traced from the TRUE pose and georeferenced with the DG pose, in strips of at
//!   most 30 s of scanning (module `lidar`); with `--point-cloud copc` the same strips as COPC files
//!   `lidar/strip_NNN.copc.laz` (one LAZ chunk per octree node, declared `format = "copc"`);
//! - `cadastre/poles.gpkg` (layers `poles`, `trees`, EPSG 4258) and `truth/poles.csv` (module `cadastre`);
//! - `aerial/`: frames, `exterior_orientation.csv`, orthophoto and terrain GeoTIFFs (module `aerial`);
//! - `map.png`: the world's buildings, streets, poles, aerial footprints and the drive coloured by DG error;
//! - `campaign.toml`: the manifest.
//!
//! The drive follows a route through the procedural world (`plumbline_synth::world`) of the same seed;
//! `--profile` replaces the streets' canyons by one environment, `mixed` keeps the world's own.
//! Files stream to the store as they are made (a bounded channel), so large campaigns need not fit in memory;
//! `--preset city` (module `city`) also makes the drive leg by leg and appends to its files — local files, or
//! multipart uploads to object stores (module `writer`).

mod aerial;
pub use aerial::FrameFormat;
mod cadastre;
mod city;
mod city_aerial;
mod imagery;
mod lidar;
mod manifest;
mod writer;

use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, ValueEnum};
use plumbline_geo::formats::{self, RawTrajectory};
use plumbline_synth::map::campaign_map_png;
use plumbline_synth::motion::dg::{self, DgConfig, DgSolution};
use plumbline_synth::motion::imu::{self, ImuErrors};
use plumbline_synth::motion::routes::{DEEP_CANYON, URBAN_STREET};
use plumbline_synth::motion::{Drive, DriveConfig, files, gnss, overview_png};
use plumbline_synth::render::{Realism, RealismLevel};
use plumbline_synth::route::{Canyon, Route};
use plumbline_synth::texture;
use plumbline_synth::world::{self, World, WorldConfig};
use tokio::sync::mpsc;
pub(crate) use writer::Sink;
use writer::Writer;

use crate::exit::{OrInvalid, invalid};
use crate::io::Context;
use crate::trajectory::crs;

/// Width of the overview map, pixels.
const OVERVIEW_WIDTH_PX: u32 = 1600;
/// Files made but not yet written that the generator may run ahead by.
const WRITE_QUEUE: usize = 8;

/// Arguments of `simulate`.
#[derive(Debug, Clone, ClapArgs)]
pub struct Args {
    /// Size of the campaign: `tiny` ~0.4 km drive in a ~0.7 km street grid (for tests), `district` ~2 km.
    #[arg(long, value_enum, default_value_t = Preset::Tiny)]
    pub preset: Preset,
    /// Seed of every random choice; the same seed writes the same campaign.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Directory or object-store prefix to write the campaign under.
    #[arg(long, value_name = "DIR|URL")]
    pub out: String,
    /// GNSS environment along the drive: one profile everywhere, or `mixed` (the world's own streets and
    /// buildings decide, street by street).
    #[arg(long, value_enum, default_value_t = Profile::Mixed)]
    pub profile: Profile,
    /// Grade of the IMU: navigation (LN-100 class; `navigate --imu-model navigation` fits it) or consumer
    /// (BMI160 class).
    #[arg(long, value_enum, default_value_t = Grade::Navigation)]
    pub imu: Grade,
    /// Write only the navigation data (trajectories, GNSS, IMU, error series, overview): no images, no cadastre.
    #[arg(long)]
    pub navigation_only: bool,
    /// Length of the drive: metres, or with a unit (`500m`, `5km`); default 400 m for `tiny`, 2 km for
    /// `district`, 5 km for `city` (the route follows the world's streets and may double back; the world's size
    /// is the preset's, the city's is unbounded).
    #[arg(long, value_name = "LENGTH", value_parser = parse_length)]
    pub length: Option<f64>,
    /// Distance driven between panoramas, metres; default 5 (`tiny`: ~85 panoramas).
    #[arg(long)]
    pub panorama_spacing: Option<f64>,
    /// Panorama width in pixels (height = width / 2); default 1024 for `tiny`, 4096 for `district`.
    #[arg(long)]
    pub panorama_width: Option<u32>,
    /// Ground sample distance of the aerial frames and the orthophoto, metres.
    #[arg(long, default_value_t = 0.12)]
    pub aerial_gsd: f64,
    /// Depth images per second while the vehicle moves; default 1 for `tiny`, 5 for `district`.
    #[arg(long)]
    pub depth_rate: Option<f64>,
    /// Size of the aerial frames, `WIDTHxHEIGHT` pixels (`tiny` and `district`): the default 1000x750 flies a
    /// small-format camera with a little radial distortion; any other size a distortion-free virtual image, as
    /// large-format cameras deliver (e.g. `14000x10000`; the GSD stays `--aerial-gsd`, the block flies higher).
    #[arg(long, value_name = "WxH", value_parser = parse_frame_size)]
    pub aerial_frame_px: Option<(u32, u32)>,
    /// File format of the aerial frames (`tiny` and `district`).
    #[arg(long, value_enum, default_value_t = FrameFormat::Jpeg)]
    pub aerial_format: FrameFormat,
    /// Mobile laser scanning along the drive (`tiny` and `district`): `laz` writes a roof profile scanner's
    /// strips under `lidar/` and names them in the manifest; `copc` writes them as COPC files.
    #[arg(long, value_enum, default_value_t = PointCloudOutput::None)]
    pub point_cloud: PointCloudOutput,
    /// Write no depth images (e.g. to run pole control from the point cloud alone).
    #[arg(long)]
    pub no_depth: bool,
    /// What real cameras and a real street add to the images: `ideal` nothing; `default` a survey rig of six
    /// global-shutter sub-cameras (4 cm parallax, ±4 % exposure steps, 0.5 ms exposure), mild white-balance,
    /// tone-curve, vignetting, noise and JPEG 85, tree crowns 1.2× wider in the aerial flight and 4 pedestrians
    /// per 100 m at each epoch; `harsh` a rolling-shutter consumer rig at speed (10 cm, ±15 %, 2 ms exposure,
    /// 33 ms readout), strong radiometric differences, JPEG 70/75, crowns 1.6× wider, 12 pedestrians.
    #[arg(long, value_enum, default_value_t = RealismArg::Ideal)]
    pub realism: RealismArg,
}

/// Levels of `--realism`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RealismArg {
    /// Ideal cameras.
    Ideal,
    /// A current survey rig and aerial camera.
    Default,
    /// A consumer rolling-shutter rig at speed, a flight in other light.
    Harsh,
}

impl RealismArg {
    /// The renderer's figures for this level.
    pub(crate) fn realism(self) -> Realism {
        Realism::of(match self {
            Self::Ideal => RealismLevel::Ideal,
            Self::Default => RealismLevel::Default,
            Self::Harsh => RealismLevel::Harsh,
        })
    }
}

/// Point clouds `simulate` can write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PointCloudOutput {
    /// None.
    None,
    /// LAZ strips of a roof profile scanner.
    Laz,
    /// The same strips as COPC (cloud-optimised: points by octree node).
    Copc,
}

/// A frame size `WIDTHxHEIGHT`, each 100–40000 pixels.
fn parse_frame_size(text: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{text}`: expected WIDTHxHEIGHT in pixels, each 100–40000, e.g. 14000x10000");
    let (w, h) = text.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.trim().parse().map_err(|_| bad())?, h.trim().parse().map_err(|_| bad())?);
    if (100..=40_000).contains(&w) && (100..=40_000).contains(&h) { Ok((w, h)) } else { Err(bad()) }
}

/// A length in metres: a number, or a number with `m` or `km`.
fn parse_length(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let (number, factor) = match (t.strip_suffix("km"), t.strip_suffix('m')) {
        (Some(n), _) => (n, 1000.0),
        (None, Some(n)) => (n, 1.0),
        (None, None) => (t, 1.0),
    };
    number
        .trim()
        .parse::<f64>()
        .map(|v| v * factor)
        .map_err(|_| format!("`{text}`: expected metres, e.g. 500, 500m or 5km"))
}

/// Campaign sizes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Preset {
    /// ~0.4 km, a few minutes of driving.
    Tiny,
    /// ~2 km.
    District,
    /// Any `--length` (default 5 km) through an unbounded city, made and written leg by leg.
    City,
}

/// GNSS environments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Profile {
    /// Open sky.
    Open,
    /// Inner-city streets (height/width 0.75).
    Urban,
    /// Deep canyons (height/width 2).
    Canyon,
    /// The world's own canyons.
    Mixed,
}

/// IMU grades.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Grade {
    /// Navigation grade, the LN-100 quoted in Grejner-Brzezinska and Toth 2000 §2.1 (`tactical` is its former,
    /// wrong name).
    #[value(alias = "tactical")]
    Navigation,
    /// Consumer MEMS (Meyer et al. 2023 §3.1.1).
    Consumer,
}

/// Run `simulate`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let manifest = write(ctx, args).await?;
    println!("{manifest}");
    Ok(ExitCode::SUCCESS)
}

/// Simulate and write the campaign; returns its manifest's path or URL. On failure, appended files being
/// uploaded to an object store are aborted (no partial objects appear).
pub async fn write(ctx: &Context, args: Args) -> anyhow::Result<String> {
    let prefix = if args.out.ends_with('/') { args.out.clone() } else { format!("{}/", args.out) };
    let mut writer = Writer::new(ctx, &prefix)?;
    let (tx, mut rx) = mpsc::channel(WRITE_QUEUE);
    let task = tokio::task::spawn_blocking(move || generate(&args, &Sink::new(tx)));
    let mut failed = None;
    while let Some(output) = rx.recv().await {
        if let Err(e) = writer.write(output).await {
            failed = Some(e);
            break;
        }
    }
    drop(rx);
    let generated = task.await.context("simulation task");
    let summary = match (failed, generated) {
        (Some(e), _) => Err(e),
        (None, Err(e)) => Err(e),
        (None, Ok(result)) => result,
    };
    match summary {
        Ok(summary) => {
            let written = writer.finish().await?;
            eprintln!("{summary}; {written} files");
            Ok(format!("{prefix}campaign.toml"))
        }
        Err(e) => {
            writer.abort().await;
            Err(e)
        }
    }
}

/// Simulate the campaign and hand its files to `sink` (CPU and GDAL only; the writing is the caller's).
fn generate(args: &Args, sink: &Sink) -> anyhow::Result<String> {
    let (preset, seed) = (args.preset, args.seed);
    let (world_preset, default_length) = match preset {
        Preset::Tiny => (world::Preset::Tiny, 400.0),
        Preset::District => (world::Preset::District, 2000.0),
        Preset::City => (world::Preset::City, 5000.0),
    };
    let length = args.length.unwrap_or(default_length);
    if !(length.is_finite() && (50.0..=100_000.0).contains(&length)) {
        return Err(invalid(format!("--length {length}: expected 50–100000 m")));
    }
    if preset == Preset::City {
        if args.aerial_frame_px.is_some()
            || args.aerial_format != FrameFormat::Jpeg
            || args.point_cloud != PointCloudOutput::None
            || args.no_depth
        {
            return Err(invalid(
                "--aerial-frame-px, --aerial-format, --point-cloud and --no-depth apply to the tiny and district presets",
            ));
        }
        return city::generate(args, length, sink);
    }
    let realism = args.realism.realism();
    let world_config =
        WorldConfig { changes: realism.world, relief: realism.relief, ..WorldConfig::new(world_preset, seed) };
    let crs = world_config.epsg;
    let world = World::generate(&world_config).context("synthetic world")?;
    let route = with_profile(world.route(seed, length), args.profile);
    let (imu_errors, outage_growth) = imu_grade(args.imu);
    let drive_config = DriveConfig::default();
    let drive = Drive::simulate(&route, &drive_config, seed).or_invalid("simulated drive")?;
    let dg_config = DgConfig { outage_growth, ..DgConfig::default() };
    let dg = dg::simulate(&drive, &dg_config, seed).or_invalid("DG error process")?;
    let fixes = gnss::simulate(&drive, &dg, &dg_config, &gnss::GnssConfig::default(), seed).or_invalid("GNSS")?;
    let imu_data = imu::simulate(&drive, &imu_errors, seed).or_invalid("IMU")?;
    let geographic = crs::express(&dg.trajectory, crs, 4326).context("DG trajectory to WGS 84")?;
    let sbet = formats::raw_to_sbet(&geographic).context("DG trajectory as SBET")?;
    let id = format!("synth-{}-{seed}", name(preset));
    sink.put("nav/dg.sbet", formats::write_sbet(&sbet))?;
    sink.put("nav/dg.smrmsg", formats::write_smrmsg(&formats::raw_to_smrmsg(&geographic)))?;
    sink.put("nav/dg.csv", formats::write_csv(&RawTrajectory::from_map_projected(dg.trajectory.records())))?;
    sink.put("nav/gnss.csv", files::gnss_csv(&fixes))?;
    sink.put("nav/imu.csv", files::imu_csv(&imu_data))?;
    let truth_csv = formats::write_csv(&RawTrajectory::from_map_projected(drive.trajectory.records()));
    sink.put("truth/trajectory.csv", truth_csv)?;
    sink.put("truth/dg_errors.csv", files::dg_errors_csv(&dg.errors))?;
    sink.put("truth/road_markings.csv", texture::markings_csv(&texture::road_markings(&world)))?;
    sink.put("overview.png", overview_png(&drive, &dg, OVERVIEW_WIDTH_PX).context("overview map")?)?;
    let mut sections = manifest::Sections::default();
    if !args.navigation_only {
        let sizes = imagery::Sizes::of(args)?;
        sections.panoramas = Some(imagery::panoramas(&world, &drive, &drive_config, &dg, &sizes, sink)?);
        if !args.no_depth {
            sections.depth = Some(imagery::depth(&world, &drive, &dg, &sizes, seed, sink)?);
        }
        if args.point_cloud != PointCloudOutput::None {
            let copc = args.point_cloud == PointCloudOutput::Copc;
            sections.point_clouds = Some(lidar::write(&world, &drive, &dg, crs, seed, copc, sink)?);
        }
        sections.cadastre = Some(cadastre::write(&world, crs, seed, sink)?);
        let frames = aerial::FrameOptions::of(args);
        let (section, footprints) = aerial::write(&world, &frames, seed, sink)?;
        sections.aerial = Some(section);
        let map = campaign_map_png(&world, &drive, &dg, &footprints, OVERVIEW_WIDTH_PX).context("campaign map")?;
        sink.put("map.png", map)?;
    }
    sink.put("campaign.toml", manifest::manifest(&id, crs, &sections)?.into_bytes())?;
    Ok(summary(&id, &drive, &dg, fixes.len()))
}

/// The IMU errors of a grade and the DG outage growth it gives (`DgConfig::outage_growth`, m per 60 s).
pub(crate) fn imu_grade(grade: Grade) -> (ImuErrors, f64) {
    match grade {
        Grade::Navigation => (ImuErrors::NAVIGATION, 0.15),
        Grade::Consumer => (ImuErrors::CONSUMER, 1.5),
    }
}

/// The route with every street's canyon replaced by the profile's (`mixed`: unchanged).
pub(crate) fn with_profile(route: Route, profile: Profile) -> Route {
    match profile {
        Profile::Open => route.with_canyon(Canyon::OPEN),
        Profile::Urban => route.with_canyon(URBAN_STREET),
        Profile::Canyon => route.with_canyon(DEEP_CANYON),
        Profile::Mixed => route,
    }
}

fn name(preset: Preset) -> &'static str {
    match preset {
        Preset::Tiny => "tiny",
        Preset::District => "district",
        Preset::City => "city",
    }
}

fn summary(id: &str, drive: &Drive, dg: &DgSolution, fixes: usize) -> String {
    let (t0, t1) = drive.trajectory.span();
    let length = drive.kinematics.last().map_or(0.0, |k| k.distance);
    let n = dg.errors.len().max(1) as f64;
    let rms = (dg.errors.iter().map(|e| e.position.x().powi(2) + e.position.y().powi(2)).sum::<f64>() / n).sqrt();
    format!(
        "{id}: {:.0} m in {:.0} s, {} epochs, {} stops, {} DG faults, horizontal DG error RMS {:.3} m, {fixes} GNSS fixes",
        length,
        t1 - t0,
        drive.trajectory.len(),
        drive.stops.len(),
        dg.faults.len(),
        rms
    )
}
