//! `plumbline submit MANIFEST`: send a campaign manifest to the scheduler's job API and print its id.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args as ClapArgs;
use plumbline_runtime::Secret;
use plumbline_scheduler::client::{Client, ClientError};

use crate::exit::{OrInvalid, invalid};
use crate::io::{Context, file_name};

/// Arguments of `submit`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// The manifest (TOML, or JSON when it ends in `.json`), by path or URL. Its relative locations resolve
    /// against where the scheduler stores it: `{store}/agencies/<agency>/campaigns/<id>/`.
    pub manifest: String,
    #[command(flatten)]
    pub server: ServerArgs,
}

/// Which scheduler, as which agency.
#[derive(Debug, ClapArgs)]
pub struct ServerArgs {
    /// The scheduler's API, e.g. http://127.0.0.1:8080.
    #[arg(long, env = "PLUMBLINE_SERVER", value_name = "URL")]
    pub server: String,
    /// File holding the agency's bearer token.
    #[arg(long, env = "PLUMBLINE_TOKEN_FILE", value_name = "FILE")]
    pub token_file: PathBuf,
}

impl ServerArgs {
    /// The API client.
    pub fn client(&self) -> anyhow::Result<Client> {
        let path = self.token_file.display();
        let token = std::fs::read_to_string(&self.token_file).or_invalid(&format!("token file {path}"))?;
        let token = token.trim();
        if token.is_empty() {
            return Err(invalid(format!("token file {path}: empty")));
        }
        Ok(Client::new(&self.server, Secret::new(token))?)
    }
}

/// The exit code policy for API errors: the request's fault (4xx but 401) is invalid input.
pub fn api_error(e: ClientError) -> anyhow::Error {
    match e.status() {
        Some(s) if s.is_client_error() && s.as_u16() != 401 => invalid(e.to_string()),
        _ => e.into(),
    }
}

/// Run `submit`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let client = args.server.client()?;
    let bytes = ctx.read(&args.manifest).await?;
    let json = file_name(&args.manifest).to_ascii_lowercase().ends_with(".json");
    let view = client.submit(bytes.to_vec(), json).await.map_err(api_error)?;
    let c = &view.campaign;
    eprintln!(
        "campaign {} run {}: {}, {} tiles, {} panoramas",
        c.id.as_str(),
        c.run,
        c.status.as_str(),
        c.tiles_total,
        c.panoramas
    );
    println!("{}", c.id.as_str());
    Ok(ExitCode::SUCCESS)
}
