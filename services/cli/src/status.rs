//! `plumbline status ID`: a campaign's state from the scheduler's job API; `--watch` follows it with progress
//! bars until it is done (exit 0; exit 3 when it was adjusted without its dead-lettered tiles), failed or
//! cancelled (exit 1).

use std::io::IsTerminal as _;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args as ClapArgs;
use plumbline_runtime::progress::{ProgressStyle, reporter};
use plumbline_scheduler::api::CampaignView;
use plumbline_scheduler::messages::CampaignStatus;

use crate::exit;
use crate::io::Context;
use crate::submit::{ServerArgs, api_error};

/// Arguments of `status`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// The campaign id.
    pub id: String,
    #[command(flatten)]
    pub server: ServerArgs,
    /// Follow the campaign until it is done, failed or cancelled.
    #[arg(long)]
    pub watch: bool,
    /// Seconds between polls while watching.
    #[arg(long, default_value_t = 2.0)]
    pub interval_s: f64,
    /// Print the state as JSON instead of text (without --watch).
    #[arg(long)]
    pub json: bool,
}

/// Run `status`.
pub async fn run(_ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let client = args.server.client()?;
    let mut view = client.status(&args.id).await.map_err(api_error)?;
    if !args.watch {
        if args.json {
            println!("{}", serde_json::to_string_pretty(&view)?);
        } else {
            print_view(&view);
        }
        return Ok(ExitCode::SUCCESS);
    }
    let progress = reporter(ProgressStyle::choose(false, false, std::io::stderr().is_terminal()));
    let mut shown: Vec<(u64, u64)> = Vec::new();
    let interval = Duration::from_secs_f64(args.interval_s.clamp(0.2, 3600.0));
    loop {
        for (i, stage) in view.stages.iter().enumerate() {
            if shown.len() <= i {
                progress.begin(&stage.stage, Some(stage.total));
                shown.push((0, 0));
            }
            let (done, failed) = shown[i];
            progress.advance(&stage.stage, stage.done.saturating_sub(done));
            progress.skip(&stage.stage, stage.failed.saturating_sub(failed));
            shown[i] = (done.max(stage.done), failed.max(stage.failed));
        }
        progress.note("tiles", view.campaign.status.as_str());
        if view.campaign.status.is_terminal() {
            view.stages.iter().for_each(|s| progress.end(&s.stage));
            break;
        }
        tokio::time::sleep(interval).await;
        view = client.status(&args.id).await.map_err(api_error)?;
    }
    print_view(&view);
    Ok(match view.campaign.status {
        CampaignStatus::Done if view.campaign.dead_lettered.is_empty() => ExitCode::SUCCESS,
        CampaignStatus::Done => ExitCode::from(exit::PARTIAL),
        _ => ExitCode::FAILURE,
    })
}

fn print_view(view: &CampaignView) {
    let c = &view.campaign;
    println!("campaign {} (agency {}, run {}): {}", c.id.as_str(), c.agency, c.run, c.status.as_str());
    for s in &view.stages {
        println!("  {:<8} {}/{} done, {} failed", s.stage, s.done, s.total, s.failed);
    }
    for d in &c.dead_lettered {
        println!("  dead-lettered tile {}: {}", d.tile, d.error);
    }
    if let Some(e) = &c.error {
        println!("  error: {e}");
    }
    if let Some(r) = &c.report {
        println!("  report: {r}");
    }
}
