//! `plumbline navigate`: loosely coupled GNSS/INS fusion of raw fixes and IMU increments (the files
//! `plumbline simulate` writes as `nav/gnss.csv` and `nav/imu.csv`): coarse alignment, the Kalman filter
//! acting on its innovation tests, the RTS smoother, and the flagged epochs with the sensor they blame.
//!
//! Layout under `--out`: `trajectory.csv` (smoothed, in the fixes' projected CRS, with σ), `flags.csv`
//! (every rejection of the four innovation tests), `summary.json` (what the filter did with the fixes).

mod files;
mod output;

use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, ValueEnum};
use plumbline_geo::Vec3;
use plumbline_navigation::{
    Adaptation, AlignmentConfig, ImuModel, IntegrityConfig, NavConfig, STANDARD_GRAVITY, align, filter,
    filter_adaptive, smooth, test_innovations, to_trajectory,
};
use plumbline_synth::motion::imu::ImuErrors;

use crate::adjust::triple;
use crate::exit::OrInvalid;
use crate::io::{Context, file_name};

/// IMU grades (the error model the filter assumes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Grade {
    /// Tactical grade (LN-100 class, paper 003 §2.1).
    Tactical,
    /// Consumer MEMS (BMI160 class, paper 002 §3.1.1).
    Consumer,
}

/// Arguments of `navigate`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// GNSS antenna fixes (CSV: time_s, easting_m, northing_m, height_m, std_east_m, std_north_m, std_height_m).
    #[arg(long, value_name = "PATH|URL")]
    pub gnss: String,
    /// IMU increments (CSV: time_s, dt_s, dtheta_{x,y,z}_rad, dv_{x,y,z}_mps; body x forward, y right, z down).
    #[arg(long, value_name = "PATH|URL")]
    pub imu: String,
    /// GNSS antenna in the body frame (x forward, y right, z down), metres: X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = triple, default_value = "0,0,0")]
    pub lever_arm: [f64; 3],
    /// Error model of the IMU.
    #[arg(long = "imu-grade", value_enum, default_value_t = Grade::Tactical)]
    pub grade: Grade,
    /// Significance level of the innovation tests.
    #[arg(long, default_value_t = 0.001)]
    pub alpha: f64,
    /// Fixes in the moving window of the global tests.
    #[arg(long, default_value_t = 25)]
    pub window: usize,
    /// Use every fix as it comes (do not exclude rejected fixes or re-open the covariance).
    #[arg(long)]
    pub no_adapt: bool,
    /// Directory or object-store prefix for the results.
    #[arg(long, value_name = "DIR|URL")]
    pub out: String,
}

/// The filter's model of an IMU grade: on a level vehicle the vertical accelerometer's scale-factor error
/// times g acts as a bias, so it joins the turn-on bias.
fn model_of(grade: Grade) -> ImuModel {
    let e = match grade {
        Grade::Tactical => ImuErrors::TACTICAL,
        Grade::Consumer => ImuErrors::CONSUMER,
    };
    ImuModel {
        gyro_bias: e.gyro_bias,
        gyro_bias_instability: e.gyro_bias_instability,
        gyro_random_walk: e.gyro_random_walk,
        accel_bias: e.accel_bias.hypot(e.accel_scale_factor * STANDARD_GRAVITY),
        accel_bias_instability: e.accel_bias_instability,
        accel_random_walk: e.accel_random_walk,
        bias_correlation_time: e.bias_correlation_time,
    }
}

/// Skipped fixes named one by one on stderr (all of them are in `summary.json`).
const SKIPPED_LISTED: usize = 10;

/// Run `navigate`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let adaptation = Adaptation { alpha: args.alpha, window: args.window, ..Adaptation::default() };
    adaptation.check().or_invalid("--alpha/--window")?;
    let gnss = files::gnss(&ctx.read(&args.gnss).await?, file_name(&args.gnss))?;
    let imu = files::imu(&ctx.read(&args.imu).await?, file_name(&args.imu))?;
    let imu_name = file_name(&args.imu).to_owned();
    let lever = Vec3::new(args.lever_arm[0], args.lever_arm[1], args.lever_arm[2]);
    let config = NavConfig { imu: model_of(args.grade), lever_arm: lever, gravity: STANDARD_GRAVITY };
    let adapt = !args.no_adapt;
    let (forward, trajectory, flags, initial) = tokio::task::spawn_blocking(move || -> anyhow::Result<_> {
        let initial = align(&imu, &gnss, &lever, &AlignmentConfig::default()).or_invalid("coarse alignment")?;
        let forward = if adapt {
            filter_adaptive(&imu, &gnss, &initial, &config, &adaptation)
        } else {
            filter(&imu, &gnss, &initial, &config)
        }
        .map_err(|e| files::name_sample(e, &imu_name))?;
        let smoothed = smooth(&forward).context("RTS smoother")?;
        let trajectory = to_trajectory(&smoothed).context("smoothed trajectory")?;
        let tests = IntegrityConfig { alpha: adaptation.alpha, window: adaptation.window };
        let flags = test_innovations(&forward.innovations, &tests).context("innovation tests")?;
        Ok((forward, trajectory, flags, initial))
    })
    .await
    .context("navigation task")??;
    let prefix = if args.out.ends_with('/') { args.out.clone() } else { format!("{}/", args.out) };
    ctx.write(&format!("{prefix}trajectory.csv"), output::trajectory_csv(&trajectory)).await?;
    ctx.write(&format!("{prefix}flags.csv"), output::flags_csv(&flags)).await?;
    let summary = output::summary(&forward, &flags, &initial, adapt);
    ctx.write(&format!("{prefix}summary.json"), serde_json::to_vec_pretty(&summary)?).await?;
    eprintln!(
        "navigated {} IMU epochs with {} fixes: {} flags, {} fixes skipped",
        forward.len(),
        forward.innovations.len(),
        flags.len(),
        forward.skipped.len()
    );
    let gnss_name = file_name(&args.gnss);
    for s in forward.skipped.iter().take(SKIPPED_LISTED) {
        // Fix indices are 0-based data rows: the file's line is two further on (1-based, after the header).
        eprintln!("warning: {gnss_name} line {}: fix skipped: {}", s.fix + 2, s.reason);
    }
    if forward.skipped.len() > SKIPPED_LISTED {
        eprintln!("warning: {gnss_name}: {} more fixes skipped (summary.json)", forward.skipped.len() - SKIPPED_LISTED);
    }
    println!("{prefix}summary.json");
    Ok(ExitCode::SUCCESS)
}
