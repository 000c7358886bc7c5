//! `plumbline demo`: simulate a campaign with ground truth into a folder and run it — the README's first
//! command. It ends with the before/after table (DG and corrected trajectory against the simulated truth)
//! and where the report is.

use std::io::IsTerminal as _;
use std::process::ExitCode;

use clap::Args as ClapArgs;
use plumbline_runtime::progress::{ProgressStyle, reporter};

use crate::io::Context;
use crate::run::{print_summary, run_campaign};
use crate::simulate::{self, Grade, Preset, Profile};

/// Arguments of `demo`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Which synthetic campaign: `tiny` (~420 m, a minute or two) or `district` (~2 km, much longer).
    #[arg(long, value_enum, default_value_t = Preset::Tiny)]
    pub preset: Preset,
    /// Seed of the synthetic world and drive.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// GNSS environment of the drive.
    #[arg(long, value_enum, default_value_t = Profile::Canyon)]
    pub profile: Profile,
    /// What real cameras add to the images (see `simulate --realism`).
    #[arg(long, value_enum, default_value_t = simulate::RealismArg::Ideal)]
    pub realism: simulate::RealismArg,
    /// Folder for the simulated campaign; the results go to its `results/`.
    #[arg(long, value_name = "DIR", default_value = "demo")]
    pub out: String,
    /// No progress output.
    #[arg(long)]
    pub quiet: bool,
    /// Progress as JSON lines on stderr.
    #[arg(long, conflicts_with = "quiet")]
    pub json: bool,
}

/// Run `demo`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let style = ProgressStyle::choose(args.quiet, args.json, std::io::stderr().is_terminal());
    let progress = reporter(style);
    progress.begin(plumbline_campaign::Stage::Simulate, None);
    let sim = simulate::Args {
        preset: args.preset,
        seed: args.seed,
        out: args.out.clone(),
        profile: args.profile,
        imu: Grade::Navigation,
        navigation_only: false,
        length: None,
        panorama_spacing: None,
        panorama_width: None,
        aerial_gsd: 0.12,
        depth_rate: None,
        aerial_frame_px: None,
        aerial_format: simulate::FrameFormat::Jpeg,
        point_cloud: simulate::PointCloudOutput::None,
        no_depth: false,
        realism: args.realism,
    };
    let manifest = simulate::write(ctx, sim).await?;
    progress.end(plumbline_campaign::Stage::Simulate);
    let outcome = run_campaign(ctx.files(), &manifest, false, 2, progress).await?;
    print_summary(&outcome);
    let truth = format!("{}/truth/road_markings.csv", args.out.trim_end_matches('/'));
    match ctx.read(&truth).await {
        Ok(text) => {
            let text = String::from_utf8_lossy(&text);
            print!("\n{}", crate::lines::demo_table(&truth, &text, &outcome.finished.road_lines)?);
        }
        Err(e) => println!("\nno road-marking truth ({e:#}): no road-line table"),
    }
    Ok(ExitCode::SUCCESS)
}
