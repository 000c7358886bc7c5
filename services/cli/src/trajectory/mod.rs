//! `plumbline trajectory convert|compare`: CSV ↔ SBET conversion with CRS changes, and the table of
//! Meyer et al. (2023).

use std::process::ExitCode;

use clap::{Args as ClapArgs, Subcommand, ValueEnum};
use plumbline_geo::Trajectory;
use plumbline_geo::formats::{self, AttitudeConvention, Horizontal, RawTrajectory};
use plumbline_geo::metrics;

use crate::exit::{OrInvalid, invalid};
use crate::io::{Context, file_name};

pub(crate) use plumbline_runtime::trajectory::crs;

/// Trajectory subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Convert a trajectory between CSV and SBET (+smrmsg) and between coordinate reference systems.
    Convert(ConvertArgs),
    /// Compare a trajectory with a reference: along-track, cross-track and height differences
    /// (median, 95 %, 99 %, max; Meyer et al. 2023, Tables 3–7) and 2D/3D RMSE.
    Compare(CompareArgs),
}

/// File formats of trajectories.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Header-driven CSV (projected or geographic columns).
    Csv,
    /// Applanix SBET (WGS84 geographic, binary).
    Sbet,
}

impl From<Format> for plumbline_campaign::TrajectoryFormat {
    fn from(f: Format) -> Self {
        match f {
            Format::Csv => Self::Csv,
            Format::Sbet => Self::Sbet,
        }
    }
}

/// Attitude conventions of CSV input.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Convention {
    /// Applanix roll/pitch/heading (also plumbline's own output).
    #[default]
    Applanix,
    /// NovAtel SPAN roll/pitch/azimuth.
    Novatel,
}

/// Where one trajectory comes from.
#[derive(Debug, Clone, ClapArgs)]
pub struct InputArgs {
    /// Format of the input (default: from the extension; `.sbet`/`.out` are SBET, anything else CSV).
    #[arg(long = "from", value_enum)]
    pub format: Option<Format>,
    /// EPSG code of the input's coordinates (projected CSV: required when the CRS changes; geographic CSV:
    /// default 4326; SBET is always 4326).
    #[arg(long = "from-epsg", value_name = "EPSG")]
    pub epsg: Option<u32>,
    /// Applanix smrmsg file with the standard deviations of an SBET input.
    #[arg(long, value_name = "PATH|URL")]
    pub smrmsg: Option<String>,
    /// Attitude convention of a CSV input.
    #[arg(long, value_enum, default_value_t)]
    pub convention: Convention,
}

/// Arguments of `trajectory convert`.
#[derive(Debug, ClapArgs)]
pub struct ConvertArgs {
    /// Input trajectory (path or URL).
    pub input: String,
    /// Output trajectory (path or URL).
    pub output: String,
    #[command(flatten)]
    pub source: InputArgs,
    /// Format of the output (default: from the extension).
    #[arg(long = "to", value_enum)]
    pub to_format: Option<Format>,
    /// EPSG code of the output: a projected CRS for CSV with easting/northing, a geographic one (4326) for CSV
    /// with latitude/longitude. Default: the input's CRS. SBET output is always 4326.
    #[arg(long = "to-epsg", value_name = "EPSG")]
    pub to_epsg: Option<u32>,
    /// Where to write the smrmsg standard deviations of an SBET output (when the input has them).
    #[arg(long = "out-smrmsg", value_name = "PATH|URL")]
    pub out_smrmsg: Option<String>,
}

/// Arguments of `trajectory compare`.
#[derive(Debug, ClapArgs)]
pub struct CompareArgs {
    /// The trajectory to evaluate (path or URL).
    pub estimate: String,
    /// The reference trajectory (path or URL).
    pub reference: String,
    /// Projected CRS the comparison is made in. Projected CSV inputs are taken to be in it unless
    /// `--estimate-epsg`/`--reference-epsg` say otherwise; geographic inputs are projected into it
    /// (default: the UTM zone of the first reference epoch).
    #[arg(long, value_name = "EPSG")]
    pub epsg: Option<u32>,
    /// EPSG code of the estimate's coordinates.
    #[arg(long, value_name = "EPSG")]
    pub estimate_epsg: Option<u32>,
    /// EPSG code of the reference's coordinates.
    #[arg(long, value_name = "EPSG")]
    pub reference_epsg: Option<u32>,
    /// Print the comparison as JSON (statistics only; add --series for the per-epoch differences).
    #[arg(long)]
    pub json: bool,
    /// With --json: include the per-epoch differences.
    #[arg(long, requires = "json")]
    pub series: bool,
}

/// Run a trajectory subcommand.
pub async fn run(ctx: &Context, cmd: Command) -> anyhow::Result<ExitCode> {
    match cmd {
        Command::Convert(args) => convert(ctx, args).await,
        Command::Compare(args) => compare(ctx, args).await,
    }
}

/// A parsed input: the raw records and the EPSG code of their coordinates (when known).
struct Loaded {
    raw: RawTrajectory,
    epsg: Option<u32>,
    name: String,
}

fn format_of(url: &str, explicit: Option<Format>) -> Format {
    explicit.unwrap_or_else(|| {
        let lower = url.to_ascii_lowercase();
        if lower.ends_with(".sbet") || lower.ends_with(".out") { Format::Sbet } else { Format::Csv }
    })
}

async fn load(ctx: &Context, url: &str, args: &InputArgs) -> anyhow::Result<Loaded> {
    let name = file_name(url).to_owned();
    let bytes = ctx.read(url).await?;
    let raw = match format_of(url, args.format) {
        Format::Csv => {
            let convention = match args.convention {
                Convention::Applanix => AttitudeConvention::Applanix,
                Convention::Novatel => AttitudeConvention::Novatel,
            };
            let parsed = formats::parse_csv(&bytes, &name, convention).or_invalid("")?;
            for w in &parsed.warnings {
                tracing::warn!(file = %name, warning = %w, "csv input");
            }
            parsed.trajectory
        }
        Format::Sbet => {
            if args.epsg.is_some_and(|e| e != 4326) {
                return Err(invalid(format!(
                    "{name}: SBET coordinates are always WGS84 (EPSG 4326); drop --from-epsg"
                )));
            }
            let records = formats::parse_sbet(&bytes, &name).or_invalid("")?;
            let std = match &args.smrmsg {
                Some(u) => Some(formats::parse_smrmsg(&ctx.read(u).await?, file_name(u)).or_invalid("")?),
                None => None,
            };
            formats::sbet_to_raw(&records, std.as_deref())
        }
    };
    let epsg = match raw.horizontal {
        Horizontal::Geographic => Some(args.epsg.unwrap_or(4326)),
        Horizontal::Projected => args.epsg,
    };
    Ok(Loaded { raw, epsg, name })
}

/// Into the projected CRS `work` (or as it is when `None`), validated; errors are invalid input naming the file.
fn to_map(loaded: Loaded, work: Option<u32>) -> anyhow::Result<Trajectory> {
    crs::into_projected(loaded.raw, loaded.epsg, work).or_invalid(&loaded.name)
}

/// The projected CRS to validate and work in: `preferred` when projected, else a projected input's, else
/// the UTM zone of the first geographic input.
fn work_crs(preferred: Option<u32>, inputs: &[&Loaded]) -> anyhow::Result<Option<u32>> {
    if let Some(e) = preferred
        && crs::is_projected(e).or_invalid("")?
    {
        return Ok(Some(e));
    }
    if let Some(l) = inputs.iter().find(|l| l.raw.horizontal == Horizontal::Projected) {
        return Ok(l.epsg);
    }
    match inputs.first() {
        Some(l) => Ok(Some(crs::utm_zone_of(&l.raw).or_invalid(&l.name)?)),
        None => Ok(None),
    }
}

async fn convert(ctx: &Context, args: ConvertArgs) -> anyhow::Result<ExitCode> {
    let loaded = load(ctx, &args.input, &args.source).await?;
    let to_format = format_of(&args.output, args.to_format);
    let out_epsg = match to_format {
        Format::Sbet if args.to_epsg.is_some_and(|e| e != 4326) => {
            return Err(invalid("SBET output is always WGS84 (EPSG 4326); drop --to-epsg or write CSV"));
        }
        Format::Sbet => Some(4326),
        Format::Csv => args.to_epsg.or(loaded.epsg),
    };
    if loaded.raw.horizontal == Horizontal::Projected && loaded.epsg.is_none() && out_epsg.is_some() {
        return Err(invalid(format!(
            "{}: projected coordinates of unknown CRS; give it with --from-epsg to convert them to EPSG:{}",
            loaded.name,
            out_epsg.unwrap_or_default()
        )));
    }
    let work = work_crs(out_epsg, &[&loaded])?;
    let n_in = loaded.raw.records.len();
    let trajectory = to_map(loaded, work)?;
    let raw_out = match (out_epsg, work) {
        (Some(out), Some(work)) => crs::express(&trajectory, work, out).or_invalid("--to-epsg")?,
        _ => RawTrajectory::from_map_projected(trajectory.records()),
    };
    write(ctx, &args, to_format, &raw_out).await?;
    eprintln!("converted {n_in} records: {} -> {}", args.input, args.output);
    Ok(ExitCode::SUCCESS)
}

async fn write(ctx: &Context, args: &ConvertArgs, format: Format, raw: &RawTrajectory) -> anyhow::Result<()> {
    match format {
        Format::Csv => ctx.write(&args.output, formats::write_csv(raw)).await,
        Format::Sbet => {
            let records = formats::raw_to_sbet(raw).or_invalid("output")?;
            ctx.write(&args.output, formats::write_sbet(&records)).await?;
            if let Some(u) = &args.out_smrmsg {
                ctx.write(u, formats::write_smrmsg(&formats::raw_to_smrmsg(raw))).await?;
            }
            Ok(())
        }
    }
}

async fn compare(ctx: &Context, args: CompareArgs) -> anyhow::Result<ExitCode> {
    let input = |epsg| InputArgs { format: None, epsg, smrmsg: None, convention: Convention::Applanix };
    let mut estimate = load(ctx, &args.estimate, &input(args.estimate_epsg)).await?;
    let mut reference = load(ctx, &args.reference, &input(args.reference_epsg)).await?;
    let work = work_crs(args.epsg, &[&reference, &estimate])?;
    // Projected inputs with no CRS of their own are taken to be in the comparison CRS.
    for l in [&mut estimate, &mut reference] {
        if l.raw.horizontal == Horizontal::Projected && l.epsg.is_none() {
            l.epsg = work;
        }
    }
    let estimate = to_map(estimate, work)?;
    let reference = to_map(reference, work)?;
    let comparison = metrics::compare(&estimate, &reference).or_invalid("compare")?;
    if args.json {
        let mut value = serde_json::to_value(&comparison)?;
        if !args.series
            && let Some(obj) = value.as_object_mut()
        {
            obj.remove("differences");
        }
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print!("{}", comparison.table());
    }
    Ok(ExitCode::SUCCESS)
}
