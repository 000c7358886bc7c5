//! `plumbline status ID`: a campaign's state from the scheduler's job API; `--watch` follows it with progress
//! bars until it is done (exit 0; exit 3 when it was adjusted without its dead-lettered tiles), failed or
//! cancelled (exit 1). While watching, transient errors (no answer, 429, 5xx: a scheduler restart, its NATS or
//! store briefly away) are logged and polled through for up to `--patience-s`; only a final state, an answer
//! that is the request's fault (401, 404) or an outage longer than the patience ends the watch otherwise.

use std::io::IsTerminal as _;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Args as ClapArgs;
use plumbline_campaign::Stage;
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
    /// While watching: seconds of consecutive transient errors (no answer, 429, 5xx) to poll through before
    /// giving up.
    #[arg(long, default_value_t = 1800.0)]
    pub patience_s: f64,
    /// Print the state as JSON instead of text (without --watch).
    #[arg(long)]
    pub json: bool,
}

/// Run `status`.
pub async fn run(_ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let client = args.server.client()?;
    let interval = Duration::from_secs_f64(args.interval_s.clamp(0.2, 3600.0));
    let patience = Duration::from_secs_f64(args.patience_s.clamp(0.0, 7.0 * 86_400.0));
    let poll = || async {
        let mut failing_since: Option<Instant> = None;
        loop {
            match client.status(&args.id).await {
                Ok(view) => {
                    if failing_since.is_some() {
                        tracing::info!(campaign = args.id, "the job API answers again");
                    }
                    return Ok(view);
                }
                Err(e) if args.watch && e.is_transient() => {
                    let since = *failing_since.get_or_insert_with(Instant::now);
                    if since.elapsed() >= patience {
                        let waited = since.elapsed().as_secs();
                        return Err(api_error(e).context(format!("the job API has not answered for {waited} s")));
                    }
                    tracing::warn!(campaign = args.id, error = %e, "job API unavailable; still watching");
                    tokio::time::sleep(interval).await;
                }
                Err(e) => return Err(api_error(e)),
            }
        }
    };
    let mut view = poll().await?;
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
    loop {
        for (i, stage) in view.stages.iter().enumerate() {
            let Some(name) = api_stage(&stage.stage) else { continue };
            if shown.len() <= i {
                progress.begin(name, Some(stage.total));
                shown.resize(i + 1, (0, 0));
            }
            let (done, failed) = shown[i];
            progress.advance(name, stage.done.saturating_sub(done));
            progress.skip(name, stage.failed.saturating_sub(failed));
            shown[i] = (done.max(stage.done), failed.max(stage.failed));
        }
        progress.note(Stage::Tiles, view.campaign.status.as_str());
        if view.campaign.status.is_terminal() {
            view.stages.iter().filter_map(|s| api_stage(&s.stage)).for_each(|s| progress.end(s));
            break;
        }
        tokio::time::sleep(interval).await;
        view = poll().await?;
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

/// A stage of the job API's status (`plan`, `tiles`, `adjust`) as a progress stage; `None` for a stage this
/// client does not know (a newer server).
fn api_stage(name: &str) -> Option<Stage> {
    match name {
        "adjust" => Some(Stage::Adjustment),
        other => other.parse().ok(),
    }
}
