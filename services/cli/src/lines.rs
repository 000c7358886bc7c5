//! `plumbline lines export|compare`: the road lines of a run's `observations.gpkg` as a GeoPackage or
//! GeoJSON file, and the lines of a run against a marking layer (`id,kind,width_m,wkt` CSV, as
//! `plumbline simulate` writes its truth): recovered and correct length, vertex accuracy.

use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, Subcommand, ValueEnum};
use plumbline_lines::{ElementScore, EvaluateConfig, LineKind, LineScore, Piece, within_reach};
use plumbline_runtime::gdal_write::{FieldValue, LineLayer, geopackage_with_lines};
use plumbline_runtime::line_io::{LineReadError, geojson_lines, read_line_layer, read_points};

use crate::exit::invalid;
use crate::io::Context;

/// How far from the panoramas paint counts as within the drive's reach: the registration keeps strokes within
/// this distance of the camera.
const REACH_M: f64 = 10.0;

/// Road-line tools.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Write the road lines of a run's observations.gpkg as a GeoPackage or GeoJSON (RFC 7946, WGS 84).
    Export(ExportArgs),
    /// Compare the road lines of a run with a marking layer (CSV `id,kind,width_m,wkt`, WKT LINESTRINGs in
    /// the campaign CRS): length recovered, length correct, vertices within the accuracy, for the lines
    /// placed with the corrected and with the DG trajectory.
    Compare(CompareArgs),
}

/// Output formats of `lines export`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// A GeoPackage with one line layer, in the campaign CRS.
    Gpkg,
    /// GeoJSON after RFC 7946: longitude/latitude on WGS 84.
    Geojson,
}

/// Arguments of `lines export`.
#[derive(Debug, ClapArgs)]
pub struct ExportArgs {
    /// The run's observations.gpkg, by path or URL.
    pub observations: String,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Geojson)]
    pub format: Format,
    /// The lines placed with the DG trajectory (`road_lines_dg`) instead of the corrected ones.
    #[arg(long)]
    pub dg: bool,
    /// Where to write, by path or URL.
    #[arg(long, value_name = "FILE|URL")]
    pub out: String,
}

/// Arguments of `lines compare`.
#[derive(Debug, ClapArgs)]
pub struct CompareArgs {
    /// The run's observations.gpkg, by path or URL.
    pub observations: String,
    /// The marking layer (CSV: `id,kind,width_m,wkt`).
    pub reference: String,
    /// A line within this distance of a marking is that marking, metres.
    #[arg(long, default_value_t = EvaluateConfig::default().match_m)]
    pub match_m: f64,
    /// A vertex within this distance of its marking is accurate, metres.
    #[arg(long, default_value_t = EvaluateConfig::default().accuracy_m)]
    pub accuracy_m: f64,
    /// Only markings within this distance of a panorama (layer `panoramas`) count, metres.
    #[arg(long, default_value_t = REACH_M)]
    pub reach_m: f64,
    /// Print JSON instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Run a `lines` command.
pub async fn run(ctx: &Context, command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Export(args) => export(ctx, args).await,
        Command::Compare(args) => compare(ctx, args).await,
    }
}

async fn read_layer(ctx: &Context, file: &str, layer: &str) -> anyhow::Result<plumbline_runtime::line_io::ReadLines> {
    let bytes = ctx.read(file).await?.to_vec();
    let (file, layer) = (file.to_owned(), layer.to_owned());
    let read = tokio::task::spawn_blocking(move || read_line_layer(&file, bytes, &layer))
        .await
        .context("the reading task failed")?;
    read.map_err(|e| match e {
        LineReadError::Open { .. } | LineReadError::NoLayer { .. } | LineReadError::Feature { .. } => {
            invalid(e.to_string())
        }
    })
}

async fn export(ctx: &Context, args: ExportArgs) -> anyhow::Result<ExitCode> {
    let name = if args.dg { plumbline_adjuster::LINE_LAYERS[1] } else { plumbline_adjuster::LINE_LAYERS[0] };
    let read = read_layer(ctx, &args.observations, name).await?;
    if read.layer.features.is_empty() {
        eprintln!("WARNING {}: layer {name} holds no lines; writing an empty file", args.observations);
    }
    let n = read.layer.features.len();
    let bytes = tokio::task::spawn_blocking(move || match (args.format, read.epsg) {
        (Format::Gpkg, epsg) => geopackage_with_lines(&[], &[read.layer], epsg),
        (Format::Geojson, Some(epsg)) => geojson_lines(&read.layer, epsg),
        (Format::Geojson, None) => Err(plumbline_runtime::gdal_write::GdalWriteError::Invalid {
            item: format!("layer {name}"),
            field: "crs",
            problem: "has no EPSG code, so it cannot be reprojected to WGS 84 for GeoJSON".into(),
        }),
    })
    .await
    .context("the encoding task failed")??;
    ctx.write(&args.out, bytes).await?;
    println!("{n} line(s) of {name} written to {}", args.out);
    Ok(ExitCode::SUCCESS)
}

async fn compare(ctx: &Context, args: CompareArgs) -> anyhow::Result<ExitCode> {
    let config = EvaluateConfig { match_m: args.match_m, accuracy_m: args.accuracy_m };
    if !(config.match_m > 0.0 && config.accuracy_m > 0.0) {
        return Err(invalid("--match-m and --accuracy-m must be positive"));
    }
    let text = ctx.read(&args.reference).await?;
    let text = std::str::from_utf8(&text).map_err(|e| invalid(format!("{}: not UTF-8: {e}", args.reference)))?;
    let truth = plumbline_lines::parse_markings_csv(text).map_err(|e| invalid(format!("{}: {e}", args.reference)))?;
    if truth.is_empty() {
        return Err(invalid(format!("{}: no markings in the reference", args.reference)));
    }
    let bytes = ctx.read(&args.observations).await?.to_vec();
    let file = args.observations.clone();
    let centres = tokio::task::spawn_blocking(move || read_points(&file, bytes, "panoramas"))
        .await
        .context("the reading task failed")?
        .map_err(|e| invalid(e.to_string()))?;
    let truth = within_reach(&truth, &centres, args.reach_m);
    if truth.is_empty() {
        eprintln!("WARNING {}: no marking lies within {} m of a panorama", args.reference, args.reach_m);
    }
    let mut scores = Vec::new();
    let mut kinds = Vec::new();
    let mut elements = Vec::new();
    for name in plumbline_adjuster::LINE_LAYERS {
        let read = read_layer(ctx, &args.observations, name).await?;
        let pieces = pieces_of(&read.layer);
        scores.push((name, plumbline_lines::evaluate(&pieces, &truth, &config)));
        let markings = plumbline_lines::per_element(&pieces, &truth, &config);
        kinds.push(by_kind(&markings));
        elements.push(markings);
    }
    if args.json {
        let json: serde_json::Map<String, serde_json::Value> = scores
            .iter()
            .zip(&kinds)
            .zip(&elements)
            .map(|(((n, s), k), e)| {
                let mut v = serde_json::to_value(s).unwrap_or_default();
                v["by_kind"] = serde_json::to_value(k).unwrap_or_default();
                v["markings"] = serde_json::to_value(e).unwrap_or_default();
                ((*n).to_owned(), v)
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&json)?);
    } else {
        print!("{}", table(&args.reference, &scores[1].1, &scores[0].1, &config));
        print!("{}", kind_table(&kinds[1], &kinds[0]));
        print!("{}", markings_table(&elements[1], &elements[0], true));
    }
    Ok(ExitCode::SUCCESS)
}

/// Markings not found listed by name on the terminal (`--json` lists every marking).
const LISTED: usize = 12;

/// Per marking of the reference: how many were found, the deviation from their lines of those both the DG
/// and the corrected lines found (each marking's median), and (`list_missed`) the markings the corrected
/// lines missed.
fn markings_table(dg: &[ElementScore], corrected: &[ElementScore], list_missed: bool) -> String {
    let found = |e: &[ElementScore]| e.iter().filter(|m| m.is_found()).count();
    // Over the markings both found (the two lists follow the reference's order): like with like.
    let both: Vec<bool> = dg.iter().zip(corrected).map(|(d, c)| d.id == c.id && d.is_found() && c.is_found()).collect();
    let deviation = |e: &[ElementScore], q: f64| {
        let mut medians: Vec<f64> =
            e.iter().zip(&both).filter(|(_, b)| **b).filter_map(|(m, _)| m.deviation_median_m).collect();
        plumbline_geo::metrics::quantile(&mut medians, q).map_or_else(|| "–".to_owned(), |d| format!("{d:.3} m"))
    };
    let label = format!("  markings found (of {})", corrected.len());
    let mut s = format!("{label:<34} {:>10} {:>10}\n", found(dg), found(corrected));
    let n = both.iter().filter(|b| **b).count();
    let rows =
        [(format!("  deviation median, {n} both found"), 0.5), ("  deviation 95 %, both found".to_owned(), 0.95)];
    for (label, q) in rows {
        s += &format!("{label:<34} {:>10} {:>10}\n", deviation(dg, q), deviation(corrected, q));
    }
    let missed: Vec<&ElementScore> = corrected.iter().filter(|m| !m.is_found()).collect();
    if list_missed && !missed.is_empty() {
        let names: Vec<String> =
            missed.iter().take(LISTED).map(|m| format!("{} ({}, {:.1} m)", m.id, m.kind, m.length_m)).collect();
        let more = missed.len().saturating_sub(LISTED);
        let tail = if more > 0 { format!(" and {more} more (--json lists every marking)") } else { String::new() };
        s += &format!("not found by the corrected lines: {}{tail}\n", names.join(", "));
    }
    s
}

/// Per kind of the reference's markings: their length and the share of it recovered.
#[derive(Clone, Debug, serde::Serialize)]
pub struct KindRecall {
    pub kind: &'static str,
    pub truth_length_m: f64,
    pub recovered_length_m: f64,
}

/// The recall per kind of the reference's markings, summed from their per-marking scores (kinds with no
/// marking length left out). A piece near a marking of another kind counts for that marking too: this is
/// recall, not classification.
fn by_kind(markings: &[ElementScore]) -> Vec<KindRecall> {
    LineKind::ALL
        .iter()
        .filter_map(|kind| {
            let of_kind = markings.iter().filter(|m| m.kind == kind.as_str());
            let (truth_length_m, recovered_length_m) =
                of_kind.fold((0.0, 0.0), |(t, r), m| (t + m.length_m, r + m.recovered_length_m));
            (truth_length_m > 0.0).then_some(KindRecall { kind: kind.as_str(), truth_length_m, recovered_length_m })
        })
        .collect()
}

/// The per-kind recall rows: DG beside corrected.
fn kind_table(dg: &[KindRecall], corrected: &[KindRecall]) -> String {
    let pct = |k: &KindRecall| {
        if k.truth_length_m > 0.0 {
            format!("{:.1} %", 100.0 * k.recovered_length_m / k.truth_length_m)
        } else {
            "–".into()
        }
    };
    let mut s = String::new();
    for (d, c) in dg.iter().zip(corrected) {
        let label = format!("  recovered, {} ({:.0} m)", c.kind, c.truth_length_m);
        s += &format!("{label:<34} {:>10} {:>10}\n", pct(d), pct(c));
    }
    s
}

/// The lines of a layer as pieces for [`plumbline_lines::evaluate`]: a dashed line's dashes are its
/// vertex runs between gaps longer than the `dash_m` attribute allows; every other line is one piece.
fn pieces_of(layer: &LineLayer) -> Vec<Piece> {
    let field = |name: &str| layer.fields.iter().position(|(n, _)| n == name);
    let (kind, gap) = (field("kind"), field("gap_m"));
    let mut pieces = Vec::new();
    for f in &layer.features {
        let dashed = kind.and_then(|k| f.values.get(k)).is_some_and(|v| *v == FieldValue::Text("dashed".into()));
        let gap_m = gap.and_then(|k| match f.values.get(k) {
            Some(FieldValue::Real(g)) if g.is_finite() => Some(*g),
            _ => None,
        });
        let mut run: Vec<[f64; 2]> = Vec::new();
        for p in &f.points {
            if let (true, Some(g), Some(last)) = (dashed, gap_m, run.last())
                && (p[0] - last[0]).hypot(p[1] - last[1]) > 0.5 * g
            {
                pieces.push(piece(std::mem::take(&mut run)));
            }
            run.push(*p);
        }
        pieces.push(piece(run));
    }
    pieces.retain(|p| p.vertices.len() >= 2);
    pieces
}

fn piece(vertices: Vec<[f64; 2]>) -> Piece {
    let n = vertices.len();
    Piece { vertices, sigma_m: vec![0.0; n], width_m: 0.0, observations: 1, panoramas: 1, closed: [true, true] }
}

/// The comparison table: DG beside corrected.
pub fn table(reference: &str, dg: &LineScore, corrected: &LineScore, config: &EvaluateConfig) -> String {
    let pct = |x: f64| if x.is_finite() { format!("{:.1} %", 100.0 * x) } else { "–".into() };
    let m = |x: f64| if x.is_finite() { format!("{x:.3} m") } else { "–".into() };
    let mut s = format!(
        "road markings against {reference} ({:.0} m painted within reach of the drive; a line within {:.2} m is the marking)\n",
        corrected.truth_length_m, config.match_m
    );
    s += &format!("{:<34} {:>10} {:>10}\n", "", "DG", "corrected");
    s += &format!(
        "{:<34} {:>10} {:>10}\n",
        "length recovered",
        pct(dg.recovered_share()),
        pct(corrected.recovered_share())
    );
    s += &format!(
        "{:<34} {:>10} {:>10}\n",
        "extracted length correct",
        pct(dg.correct_share()),
        pct(corrected.correct_share())
    );
    let within = format!("vertices within {:.2} m", config.accuracy_m);
    s += &format!("{within:<34} {:>10} {:>10}\n", pct(dg.within_share()), pct(corrected.within_share()));
    s += &format!(
        "{:<34} {:>10} {:>10}\n",
        "vertex error, 95 %",
        m(dg.vertex_error_q95_m),
        m(corrected.vertex_error_q95_m)
    );
    s
}

/// The road-marking rows of `demo`: the run's lines (in memory) against the simulator's truth within
/// reach of the drive.
pub fn demo_table(reference: &str, text: &str, lines: &plumbline_adjuster::RoadLines) -> anyhow::Result<String> {
    let truth = plumbline_lines::parse_markings_csv(text).map_err(|e| invalid(format!("{reference}: {e}")))?;
    let truth = within_reach(&truth, &lines.centres, REACH_M);
    let config = EvaluateConfig::default();
    let corrected = plumbline_lines::evaluate(&lines.corrected.pieces, &truth, &config);
    let dg = plumbline_lines::evaluate(&lines.dg.pieces, &truth, &config);
    let dg_markings = plumbline_lines::per_element(&lines.dg.pieces, &truth, &config);
    let corrected_markings = plumbline_lines::per_element(&lines.corrected.pieces, &truth, &config);
    let kinds = kind_table(&by_kind(&dg_markings), &by_kind(&corrected_markings));
    let markings = markings_table(&dg_markings, &corrected_markings, false);
    Ok(table(reference, &dg, &corrected, &config) + &kinds + &markings)
}
