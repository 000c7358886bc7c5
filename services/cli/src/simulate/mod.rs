//! `plumbline simulate`: write a synthetic campaign with ground truth — truth and DG trajectories, raw GNSS
//! and IMU, the DG error series and a v1 manifest naming them — under a directory or object-store prefix.
//!
//! Layout under `--out` (paths relative to `campaign.toml`):
//! - `nav/dg.sbet`, `nav/dg.smrmsg`: the DG solution, WGS 84 geographic (SBET + standard deviations);
//! - `nav/dg.csv`: the same in the campaign CRS (the world's, EPSG 25832) with standard deviations;
//! - `nav/gnss.csv`, `nav/imu.csv`: raw GNSS fixes and IMU increments (columns: `plumbline_synth::motion::files`);
//! - `truth/trajectory.csv`: the true trajectory (campaign CRS, σ = 0), the manifest's `reference`;
//! - `truth/dg_errors.csv`: DG − truth per epoch with the environment and fault;
//! - `overview.png`: a map of the drive coloured by the horizontal DG error, standstills in black;
//! - `panoramas/`: equirectangular JPEGs every `--panorama-spacing` metres rendered with the TRUE pose,
//!   `index.csv` and `vehicle_mask.png` (non-zero = vehicle); `truth/images.csv`: true and DG poses then;
//! - `depth/right/`: 16-bit PNG depth images (millimetres) of the side-looking camera, `index.csv`;
//!   `truth/depth_images.csv`;
//! - `cadastre/poles.gpkg` (layers `poles`, `trees`, EPSG 4258) and `truth/poles.csv` (module `cadastre`);
//! - `aerial/`: frames, `exterior_orientation.csv`, orthophoto and terrain GeoTIFFs (module `aerial`);
//! - `map.png`: the world's buildings, streets, poles, aerial footprints and the drive coloured by DG error;
//! - `campaign.toml`: the manifest.
//!
//! The drive follows a route through the procedural world (`plumbline_synth::world`) of the same seed;
//! `--profile` replaces the streets' canyons by one environment, `mixed` keeps the world's own.
//! Files stream to the store as they are made (a bounded channel), so large campaigns need not fit in memory.

mod aerial;
mod cadastre;
mod imagery;
mod manifest;

use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, ValueEnum};
use plumbline_geo::formats::{self, RawTrajectory};
use plumbline_synth::map::campaign_map_png;
use plumbline_synth::motion::dg::{self, DgConfig, DgSolution};
use plumbline_synth::motion::imu::{self, ImuErrors};
use plumbline_synth::motion::routes::{DEEP_CANYON, URBAN_STREET};
use plumbline_synth::motion::{Drive, DriveConfig, files, gnss, overview_png};
use plumbline_synth::route::{Canyon, Route};
use plumbline_synth::world::{self, World, WorldConfig};
use tokio::sync::mpsc;

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
    /// Grade of the IMU: tactical (LN-100 class) or consumer (BMI160 class).
    #[arg(long, value_enum, default_value_t = Grade::Tactical)]
    pub imu: Grade,
    /// Write only the navigation data (trajectories, GNSS, IMU, error series, overview): no images, no cadastre.
    #[arg(long)]
    pub navigation_only: bool,
    /// Length of the drive, metres; default 400 for `tiny`, 2000 for `district` (the route follows the
    /// world's streets and may double back; the world's size is the preset's).
    #[arg(long, value_name = "METRES")]
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
}

/// Campaign sizes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Preset {
    /// ~0.4 km, a few minutes of driving.
    Tiny,
    /// ~2 km.
    District,
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
    /// Tactical grade (paper 003 §2.1).
    Tactical,
    /// Consumer MEMS (paper 002 §3.1.1).
    Consumer,
}

/// Where generated files go: path relative to the campaign prefix, bytes; written by the async side.
#[derive(Debug)]
pub(crate) struct Sink {
    tx: mpsc::Sender<(String, Vec<u8>)>,
}

impl Sink {
    /// Hand a file to the writer (blocks while the queue is full).
    pub(crate) fn put(&self, path: impl Into<String>, bytes: Vec<u8>) -> anyhow::Result<()> {
        self.tx.blocking_send((path.into(), bytes)).map_err(|_| anyhow::anyhow!("the campaign writer stopped"))
    }
}

/// Run `simulate`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let manifest = write(ctx, args).await?;
    println!("{manifest}");
    Ok(ExitCode::SUCCESS)
}

/// Simulate and write the campaign; returns its manifest's path or URL.
pub async fn write(ctx: &Context, args: Args) -> anyhow::Result<String> {
    let prefix = if args.out.ends_with('/') { args.out.clone() } else { format!("{}/", args.out) };
    let (tx, mut rx) = mpsc::channel(WRITE_QUEUE);
    let task = tokio::task::spawn_blocking(move || generate(&args, &Sink { tx }));
    let mut written = 0usize;
    while let Some((path, bytes)) = rx.recv().await {
        ctx.write(&format!("{prefix}{path}"), bytes).await?;
        written += 1;
    }
    let summary = task.await.context("simulation task")??;
    eprintln!("{summary}; {written} files");
    Ok(format!("{prefix}campaign.toml"))
}

/// Simulate the campaign and hand its files to `sink` (CPU and GDAL only; the writing is the caller's).
fn generate(args: &Args, sink: &Sink) -> anyhow::Result<String> {
    let (preset, seed) = (args.preset, args.seed);
    let (world_preset, default_length) = match preset {
        Preset::Tiny => (world::Preset::Tiny, 400.0),
        Preset::District => (world::Preset::District, 2000.0),
    };
    let length = args.length.unwrap_or(default_length);
    if !(length.is_finite() && (50.0..=100_000.0).contains(&length)) {
        return Err(invalid(format!("--length {length}: expected 50–100000 m")));
    }
    let world_config = WorldConfig::new(world_preset, seed);
    let crs = world_config.epsg;
    let world = World::generate(&world_config).context("synthetic world")?;
    let route = with_profile(world.route(seed, length), args.profile);
    let (imu_errors, outage_growth) = match args.imu {
        Grade::Tactical => (ImuErrors::TACTICAL, 0.15),
        Grade::Consumer => (ImuErrors::CONSUMER, 1.5),
    };
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
    sink.put("overview.png", overview_png(&drive, &dg, OVERVIEW_WIDTH_PX).context("overview map")?)?;
    let mut sections = manifest::Sections::default();
    if !args.navigation_only {
        let sizes = imagery::Sizes::of(args)?;
        sections.panoramas = Some(imagery::panoramas(&world, &drive, &drive_config, &dg, &sizes, sink)?);
        sections.depth = Some(imagery::depth(&world, &drive, &dg, &sizes, seed, sink)?);
        sections.cadastre = Some(cadastre::write(&world, crs, seed, sink)?);
        let (section, footprints) = aerial::write(&world, args.aerial_gsd, seed, sink)?;
        sections.aerial = Some(section);
        let map = campaign_map_png(&world, &drive, &dg, &footprints, OVERVIEW_WIDTH_PX).context("campaign map")?;
        sink.put("map.png", map)?;
    }
    sink.put("campaign.toml", manifest::manifest(&id, crs, &sections)?.into_bytes())?;
    Ok(summary(&id, &drive, &dg, fixes.len()))
}

/// The route with every street's canyon replaced by the profile's (`mixed`: unchanged).
fn with_profile(route: Route, profile: Profile) -> Route {
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
