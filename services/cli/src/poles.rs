//! `plumbline poles detect`: poles and tree trunks in static LAS/LAZ point clouds (a pole or tree inventory,
//! no trajectory, GPS time or scanner position needed), written as a GeoPackage point layer
//! `detected_poles`: class guess, centre with covariance, diameter at 1.3 m, height, lean.
//!
//! Each cloud is streamed twice from its bytes (ground, then the points above it), never decoded whole;
//! all clouds given are one scene (tiles of a block). The CRS is `--epsg`, else the one the clouds record
//! (GeoTIFF keys or WKT, all the same), else none — the layer then has no CRS and stderr says so.

use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, Subcommand};
use plumbline_poles::{LasCrs, LasError, Stem, StemClass, StemConfig, StemDetector, parse_las_header, stream_las_xyz};
use plumbline_runtime::gdal_write::{FieldType, FieldValue, PointFeature, PointLayer, geopackage_in};

use crate::exit::invalid;
use crate::io::{Context, file_name};

/// Pole tools.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Find poles and tree trunks in static LAS/LAZ clouds; write them as a GeoPackage layer.
    Detect(DetectArgs),
}

/// Arguments of `poles detect`.
#[derive(Debug, ClapArgs)]
pub struct DetectArgs {
    /// LAS or LAZ files (paths or URLs), one scene.
    #[arg(required = true, value_name = "CLOUD")]
    pub clouds: Vec<String>,
    /// EPSG code of the clouds' coordinates (overrides what they record).
    #[arg(long, value_name = "CODE")]
    pub epsg: Option<u32>,
    /// The GeoPackage to write (path or URL).
    #[arg(long, value_name = "FILE.gpkg")]
    pub out: String,
    /// A stem must reach at least this high above ground, metres.
    #[arg(long, value_name = "M", default_value_t = StemConfig::default().min_top_m)]
    pub min_height: f64,
}

/// Run a `poles` command.
pub async fn run(ctx: &Context, command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Detect(args) => detect(ctx, args).await,
    }
}

/// A cloud's error as a user error (exit 2): it names the file and the record or field.
fn bad_cloud(e: LasError) -> anyhow::Error {
    invalid(e.to_string())
}

async fn detect(ctx: &Context, args: DetectArgs) -> anyhow::Result<ExitCode> {
    let config = StemConfig { min_top_m: args.min_height, ..StemConfig::default() };
    config.check().map_err(|e| invalid(format!("--min-height: {e}")))?;
    // The CRS each cloud records, from its header.
    let mut recorded: Vec<(String, Option<u32>)> = Vec::new();
    for url in &args.clouds {
        let bytes = ctx.read(url).await?;
        let header = parse_las_header(file_name(url), &bytes, None).map_err(|e| invalid(format!("point cloud {e}")))?;
        let epsg = match &header.crs {
            LasCrs::GeoKeys { epsg } => *epsg,
            LasCrs::Wkt(wkt) => plumbline_runtime::epsg_of_wkt(wkt),
            LasCrs::Missing | LasCrs::NotRead => None,
        };
        eprintln!(
            "{}: LAS {}.{}, point format {}{}, {} points, CRS {}",
            file_name(url),
            header.version.0,
            header.version.1,
            header.point_format,
            if header.compressed { " (LAZ)" } else { "" },
            header.point_count,
            epsg.map_or_else(|| "not recorded".to_owned(), |c| format!("EPSG:{c}"))
        );
        recorded.push((url.clone(), epsg));
    }
    let epsg = match args.epsg {
        Some(code) => Some(code),
        None => {
            let codes: Vec<u32> = recorded.iter().filter_map(|(_, c)| *c).collect();
            if let Some(first) = codes.first()
                && let Some((url, other)) = recorded.iter().find(|(_, c)| c.is_some_and(|c| c != *first))
            {
                return Err(invalid(format!(
                    "{} records EPSG:{} where another cloud records EPSG:{first}: one scene needs one CRS (give \
                     --epsg if the records are wrong)",
                    file_name(url),
                    other.unwrap_or_default()
                )));
            }
            codes.first().copied()
        }
    };
    if epsg.is_none() {
        eprintln!("warning: no cloud records a CRS and no --epsg was given: the layer is written without a CRS");
    }
    let mut detector = StemDetector::new(config);
    let mut total = 0u64;
    for pass in 0..2 {
        for url in &args.clouds {
            let bytes = ctx.read(url).await?;
            let name = file_name(url).to_owned();
            let (returned, read) = tokio::task::spawn_blocking(move || {
                let read = stream_las_xyz(&name, bytes, |batch| {
                    if pass == 0 { detector.ground(batch) } else { detector.collect(batch) }
                });
                (detector, read)
            })
            .await
            .context("the point-reading task failed")?;
            detector = returned;
            let (_, points) = read.map_err(bad_cloud)?;
            if pass == 0 {
                total += points;
            }
        }
    }
    if total == 0 {
        eprintln!("warning: the clouds hold no points: nothing to detect");
    }
    let kept = detector.kept();
    let stems = tokio::task::spawn_blocking(move || detector.finish()).await.context("the detection task failed")?;
    let count = |c: StemClass| stems.iter().filter(|s| s.class == c).count();
    eprintln!(
        "{total} points read, {kept} above ground kept; {} stems: {} poles, {} trunks, {} unclassified",
        stems.len(),
        count(StemClass::Pole),
        count(StemClass::Trunk),
        count(StemClass::Unknown)
    );
    if stems.is_empty() && total > 0 {
        eprintln!(
            "warning: no pole or trunk found in {} points: no stem of {}–{} m diameter rises from under {} m to {} m \
             above the ground (is the cloud a ground-only or a classified subset?)",
            total, config.min_diameter_m, config.max_diameter_m, config.max_base_m, config.min_top_m
        );
    }
    let layer = layer_of(&stems);
    let bytes = tokio::task::spawn_blocking(move || geopackage_in(&[layer], epsg))
        .await
        .context("the GeoPackage task failed")??;
    ctx.write(&args.out, bytes).await?;
    println!("{}", args.out);
    Ok(ExitCode::SUCCESS)
}

/// The `detected_poles` layer.
fn layer_of(stems: &[Stem]) -> PointLayer {
    let fields = [
        ("class", FieldType::Text),
        ("diameter_m", FieldType::Real),
        ("diameter_sigma_m", FieldType::Real),
        ("height_m", FieldType::Real),
        ("base_m", FieldType::Real),
        ("ground_m", FieldType::Real),
        ("lean", FieldType::Real),
        ("lean_azimuth_deg", FieldType::Real),
        ("sigma_east_m", FieldType::Real),
        ("sigma_north_m", FieldType::Real),
        ("cov_east_north_m2", FieldType::Real),
        ("points", FieldType::Integer),
        ("arc_deg", FieldType::Real),
        ("rms_m", FieldType::Real),
    ];
    let features = stems
        .iter()
        .map(|s| PointFeature {
            x: s.centre[0],
            y: s.centre[1],
            values: vec![
                FieldValue::Text(s.class.name().to_owned()),
                FieldValue::Real(s.diameter_m),
                FieldValue::Real(s.diameter_sigma_m),
                FieldValue::Real(s.extent_m[1]),
                FieldValue::Real(s.extent_m[0]),
                FieldValue::Real(s.ground_m),
                FieldValue::Real(s.lean),
                FieldValue::Real(s.lean_azimuth_deg),
                FieldValue::Real(s.covariance[0][0].max(0.0).sqrt()),
                FieldValue::Real(s.covariance[1][1].max(0.0).sqrt()),
                FieldValue::Real(s.covariance[0][1]),
                FieldValue::Integer(i64::try_from(s.points).unwrap_or(i64::MAX)),
                FieldValue::Real(s.arc_deg),
                FieldValue::Real(s.rms_m),
            ],
        })
        .collect();
    PointLayer {
        name: "detected_poles".to_owned(),
        fields: fields.iter().map(|(n, t)| ((*n).to_owned(), *t)).collect(),
        features,
    }
}
