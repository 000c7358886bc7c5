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
//! - `campaign.toml`: the manifest.
//!
//! The drive follows a route through the procedural world (`plumbline_synth::world`) of the same seed;
//! `--profile` replaces the streets' canyons by one environment, `mixed` keeps the world's own. Panoramas,
//! depth images, aerial images and cadastres are not written yet.

use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, ValueEnum};
use plumbline_campaign::Manifest;
use plumbline_geo::formats::{self, RawTrajectory};
use plumbline_synth::motion::dg::{self, DgConfig, DgSolution};
use plumbline_synth::motion::imu::{self, ImuErrors};
use plumbline_synth::motion::routes::{DEEP_CANYON, URBAN_STREET};
use plumbline_synth::motion::{Drive, DriveConfig, files, gnss, overview_png};
use plumbline_synth::route::{Canyon, Route};
use plumbline_synth::world::{self, World, WorldConfig};

use crate::exit::{OrInvalid, invalid};
use crate::io::Context;
use crate::trajectory::crs;

/// Width of the overview map, pixels.
const OVERVIEW_WIDTH_PX: u32 = 1600;

/// Arguments of `simulate`.
#[derive(Debug, ClapArgs)]
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

/// The files of a campaign: path relative to the prefix, bytes.
type Files = Vec<(&'static str, Vec<u8>)>;

/// Run `simulate`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let seed = args.seed;
    let (preset, profile, grade) = (args.preset, args.profile, args.imu);
    let (files, summary) = tokio::task::spawn_blocking(move || generate(preset, profile, grade, seed))
        .await
        .context("simulation task")??;
    let prefix = if args.out.ends_with('/') { args.out.clone() } else { format!("{}/", args.out) };
    for (path, bytes) in files {
        ctx.write(&format!("{prefix}{path}"), bytes).await?;
    }
    eprintln!("{summary}");
    println!("{prefix}campaign.toml");
    Ok(ExitCode::SUCCESS)
}

/// Simulate the campaign and encode its files (CPU only; no I/O).
fn generate(preset: Preset, profile: Profile, grade: Grade, seed: u64) -> anyhow::Result<(Files, String)> {
    let (world_preset, length) = match preset {
        Preset::Tiny => (world::Preset::Tiny, 400.0),
        Preset::District => (world::Preset::District, 2000.0),
    };
    let world_config = WorldConfig::new(world_preset, seed);
    let crs = world_config.epsg;
    let world = World::generate(&world_config).context("synthetic world")?;
    let route = with_profile(world.route(seed, length), profile);
    let (imu_errors, outage_growth) = match grade {
        Grade::Tactical => (ImuErrors::TACTICAL, 0.15),
        Grade::Consumer => (ImuErrors::CONSUMER, 1.5),
    };
    let drive = Drive::simulate(&route, &DriveConfig::default(), seed).or_invalid("simulated drive")?;
    let dg_config = DgConfig { outage_growth, ..DgConfig::default() };
    let dg = dg::simulate(&drive, &dg_config, seed).or_invalid("DG error process")?;
    let fixes = gnss::simulate(&drive, &dg, &dg_config, &gnss::GnssConfig::default(), seed).or_invalid("GNSS")?;
    let imu_data = imu::simulate(&drive, &imu_errors, seed).or_invalid("IMU")?;
    let geographic = crs::express(&dg.trajectory, crs, 4326).context("DG trajectory to WGS 84")?;
    let sbet = formats::raw_to_sbet(&geographic).context("DG trajectory as SBET")?;
    let id = format!("synth-{}-{seed}", name(preset));
    let files = vec![
        ("nav/dg.sbet", formats::write_sbet(&sbet)),
        ("nav/dg.smrmsg", formats::write_smrmsg(&formats::raw_to_smrmsg(&geographic))),
        ("nav/dg.csv", formats::write_csv(&RawTrajectory::from_map_projected(dg.trajectory.records()))),
        ("nav/gnss.csv", files::gnss_csv(&fixes)),
        ("nav/imu.csv", files::imu_csv(&imu_data)),
        ("truth/trajectory.csv", formats::write_csv(&RawTrajectory::from_map_projected(drive.trajectory.records()))),
        ("truth/dg_errors.csv", files::dg_errors_csv(&dg.errors)),
        ("overview.png", overview_png(&drive, &dg, OVERVIEW_WIDTH_PX).context("overview map")?),
        ("campaign.toml", manifest(&id, crs)?.into_bytes()),
    ];
    Ok((files, summary(&id, &drive, &dg, fixes.len())))
}

/// The route with every street's canyon replaced by the profile's (`mixed`: unchanged).
fn with_profile(mut route: Route, profile: Profile) -> Route {
    let canyon = match profile {
        Profile::Open => Canyon::OPEN,
        Profile::Urban => URBAN_STREET,
        Profile::Canyon => DEEP_CANYON,
        Profile::Mixed => return route,
    };
    for w in &mut route.waypoints {
        w.canyon = canyon;
    }
    route
}

fn name(preset: Preset) -> &'static str {
    match preset {
        Preset::Tiny => "tiny",
        Preset::District => "district",
    }
}

/// The v1 manifest, checked before it is written.
fn manifest(id: &str, crs: u32) -> anyhow::Result<String> {
    let text = format!(
        "# A synthetic campaign written by `plumbline simulate`; paths are relative to this file.\n\
         version = \"1\"\n\
         crs = {crs}\n\
         output = \"results/\"\n\n\
         [campaign]\n\
         id = \"{id}\"\n\
         name = \"Synthetic campaign {id}\"\n\n\
         [[trajectory]]\n\
         format = \"sbet\"\n\
         url = \"nav/dg.sbet\"\n\
         smrmsg = \"nav/dg.smrmsg\"\n\
         gnss = \"nav/gnss.csv\"\n\
         imu = \"nav/imu.csv\"\n\
         reference = \"truth/trajectory.csv\"\n"
    );
    let parsed = Manifest::from_toml_str(&text).map_err(|e| invalid(format!("generated manifest: {e}")))?;
    if let Err(problems) = parsed.validate() {
        let list: Vec<String> = problems.iter().map(ToString::to_string).collect();
        return Err(invalid(format!("generated manifest: {}", list.join("; "))));
    }
    Ok(text)
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
