//! `plumbline poles detect`: poles and tree trunks in static LAS/LAZ point clouds (a pole or tree inventory,
//! no trajectory, GPS time or scanner position needed), written as a GeoPackage point layer
//! `detected_poles`: class guess, centre with covariance, diameter at 1.3 m, height, lean; and
//! `covered_cells`, the 10 m cells the clouds hold ground in.
//!
//! `plumbline poles compare`: such a layer against a cadastre — matched (with the distance), in the cloud but
//! not in the cadastre, in the cadastre but not seen (within the covered cells).
//!
//! Each cloud is streamed three times by range reads of 8 MiB (ground, breast-height band, the surroundings
//! of the band's circles), never held or decoded whole. The band and the surroundings go to temporary files
//! by 64 m tile ([`TileSpill`]); circles are fitted and stems followed one tile at a time, so memory holds
//! the ground and one tile's points, not what a large cloud keeps;
//! all clouds given are one scene (tiles of a block). The CRS is `--epsg`, else the one the clouds record
//! (GeoTIFF keys or WKT, all the same), else none — the layer then has no CRS and stderr says so.

use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, Subcommand};
use plumbline_campaign::manifest::{Cadastre, ClassAccuracy, PoleClass};
use plumbline_campaign::{CadastreFeature, Epsg, Location};
use plumbline_poles::las_header::LAS_PREFIX_BYTES;
use plumbline_poles::{
    Candidate, LasCrs, LasError, Stem, StemClass, StemConfig, StemDetector, Tiling, merge_stems, parse_las_header,
    stream_las_xyz_from, surroundings_cells,
};
use plumbline_runtime::cadastre::{CadastreSource, inspect_cadastre, read_cadastre};
use plumbline_runtime::gdal_write::{FieldType, FieldValue, PointFeature, PointLayer, geopackage_in};
use plumbline_runtime::range_reader::{DEFAULT_WINDOW, RangeReader};
use plumbline_runtime::spill::TileSpill;

use crate::exit::invalid;
use crate::io::{Context, file_name};

/// The layer of the cells the clouds cover (centres), which `poles compare` needs to tell a cadastre object
/// the cloud did not see from one outside it.
const COVERAGE_LAYER: &str = "covered_cells";
/// Size of those cells, m.
const COVERAGE_CELL_M: f64 = 10.0;
/// Side of the tiles the band and the surroundings are bucketed in, m: a tile's points are what the
/// detection holds at once.
const TILE_M: f64 = 64.0;
/// A tile holding more points than this (band or surroundings) is split into quarters before it is read,
/// down to tiles of 8 m (see [`TileSpill::visit_tiles`]); a tile's surroundings are read only around its
/// own candidates. What is held at once is then bounded by this budget, or by the surroundings of one 8 m
/// tile's stems where a cloud is denser still (many overlapping strips).
const TILE_POINTS: u64 = 8 << 20;

/// Pole tools.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Find poles and tree trunks in static LAS/LAZ clouds; write them as a GeoPackage layer.
    Detect(DetectArgs),
    /// Compare `poles detect`'s layer with a cadastre: matched, not in the cadastre, not seen.
    Compare(CompareArgs),
}

/// Arguments of `poles compare`.
#[derive(Debug, ClapArgs)]
pub struct CompareArgs {
    /// The GeoPackage `poles detect` wrote (path or URL).
    pub detected: String,
    /// The cadastre GeoPackage (path or URL).
    #[arg(long, value_name = "FILE.gpkg")]
    pub cadastre: String,
    /// The cadastre's point layers to read.
    #[arg(long = "layer", value_name = "NAME", required = true)]
    pub layers: Vec<String>,
    /// The class of every cadastre object (pole, light, sign, tree); or give --class-attribute.
    #[arg(long, value_name = "CLASS", conflicts_with = "class_attribute")]
    pub class: Option<String>,
    /// The cadastre attribute holding each object's class (values pole, light, sign, tree).
    #[arg(long, value_name = "FIELD")]
    pub class_attribute: Option<String>,
    /// A detection and a cadastre object farther apart than this are not the same object, metres.
    #[arg(long, value_name = "M", default_value_t = 1.5)]
    pub gate: f64,
    /// The GeoPackage to write: layers `matched`, `not_in_cadastre`, `not_seen` (path or URL).
    #[arg(long, value_name = "FILE.gpkg")]
    pub out: String,
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
    /// Where the band and surroundings are kept by tile while the clouds are read (the system's temporary
    /// directory by default; about 40 bytes per point kept).
    #[arg(long, value_name = "DIR")]
    pub temp_dir: Option<std::path::PathBuf>,
}

/// Run a `poles` command.
pub async fn run(ctx: &Context, command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Detect(args) => detect(ctx, args).await,
        Command::Compare(args) => compare(ctx, args).await,
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
    // Metres per unit of each cloud's heights (its WKT's vertical CRS; 1 without one).
    let mut height_units: Vec<f64> = Vec::new();
    for url in &args.clouds {
        let (prefix, _) = ctx.files().read_prefix(url, LAS_PREFIX_BYTES as u64).await?;
        let header =
            parse_las_header(file_name(url), &prefix, None).map_err(|e| invalid(format!("point cloud {e}")))?;
        let epsg = header.crs.epsg(plumbline_runtime::epsg_of_wkt);
        eprintln!(
            "{}: LAS {}.{}, point format {}{}, {} points, CRS {}",
            file_name(url),
            header.version.0,
            header.version.1,
            header.point_format,
            if header.compressed { " (LAZ)" } else { "" },
            header.point_count,
            match (epsg, &header.crs) {
                (Some(c), _) => format!("EPSG:{c}"),
                (None, LasCrs::Missing) => "not recorded".to_owned(),
                (None, LasCrs::NotRead) => "not read (it may lie past the VLRs, in an extended VLR)".to_owned(),
                (None, _) => "recorded without an EPSG code".to_owned(),
            }
        );
        recorded.push((url.clone(), epsg));
        let height_unit = header
            .crs
            .height_unit(plumbline_runtime::vertical_unit_of_wkt)
            .map_err(|e| invalid(format!("point cloud {}: {e}", file_name(url))))?;
        if let Some((name, m)) = &height_unit
            && *m != 1.0
        {
            eprintln!("{}: heights in {name} ({m} m), converted to metres", file_name(url));
        }
        height_units.push(height_unit.map_or(1.0, |u| u.1));
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
    // Metres per unit of the coordinates: the detector measures in metres, the layers keep the CRS's units.
    let unit = match epsg {
        Some(code) if !plumbline_runtime::is_projected(code).unwrap_or(true) => {
            return Err(invalid(format!(
                "EPSG:{code} is geographic (degrees): stems are measured in metres; give the clouds in a projected \
                 CRS"
            )));
        }
        Some(code) => plumbline_runtime::linear_unit_m(code).unwrap_or(1.0),
        None => 1.0,
    };
    if unit != 1.0 {
        eprintln!("coordinates in units of {unit} m: measured in metres, the layers written in the CRS's units");
    }
    let tiling = Tiling::new(TILE_M, &config);
    let temp = args.temp_dir.as_deref();
    if let Some(dir) = temp.filter(|d| !d.is_dir()) {
        return Err(invalid(format!("--temp-dir {}: not a directory", dir.display())));
    }
    let spill_error = |e: std::io::Error| anyhow::anyhow!("the detection's temporary tile files: {e}");
    let mut state = Detection {
        detector: StemDetector::new(config),
        band: TileSpill::new(temp, tiling).map_err(spill_error)?,
        kept: TileSpill::new(temp, tiling).map_err(spill_error)?,
    };
    let mut total = 0u64;
    for (pass, what) in ["ground", "1.2–1.4 m band", "surroundings of the band's circles"].into_iter().enumerate() {
        let started = std::time::Instant::now();
        for (url, &height_unit) in args.clouds.iter().zip(&height_units) {
            let reader = RangeReader::open(ctx.files(), url, DEFAULT_WINDOW).await?;
            let name = file_name(url).to_owned();
            let scale = [unit, unit, height_unit];
            let (returned, read) = tokio::task::spawn_blocking(move || {
                let len = reader.size();
                let mut metric: Vec<[f64; 3]> = Vec::new();
                let Detection { detector, band, kept } = &mut state;
                let read = stream_las_xyz_from(&name, reader, len, |batch| {
                    let batch = if scale == [1.0; 3] {
                        batch
                    } else {
                        metric.clear();
                        metric.extend(batch.iter().map(|p| [p[0] * scale[0], p[1] * scale[1], p[2] * scale[2]]));
                        &metric
                    };
                    match pass {
                        0 => detector.ground(batch),
                        1 => detector.band_of(batch, |p| band.push(p)),
                        _ => detector.surroundings_of(batch, |p| kept.push(p)),
                    }
                });
                (state, read)
            })
            .await
            .context("the point-reading task failed")?;
            state = returned;
            let (_, points) = read.map_err(bad_cloud)?;
            if pass == 0 {
                total += points;
            }
        }
        state.band.check().map_err(spill_error)?;
        state.kept.check().map_err(spill_error)?;
        if pass == 1 {
            state = tokio::task::spawn_blocking(move || tile_candidates(state))
                .await
                .context("the circle-fitting task failed")?
                .map_err(spill_error)?;
        }
        eprintln!(
            "pass {}/3 ({what}): {total} points in {:.0} s{}",
            pass + 1,
            started.elapsed().as_secs_f64(),
            match pass {
                0 => String::new(),
                1 => format!(
                    ", {} in the band, {} candidate circles",
                    state.band.pushed(),
                    state.detector.candidates().len()
                ),
                _ => format!(", {} kept around the circles", state.kept.pushed()),
            }
        );
    }
    if total == 0 {
        eprintln!("warning: the clouds hold no points: nothing to detect");
    }
    let (band, kept) = (state.band.pushed(), state.kept.pushed());
    let spilled = state.band.written() + state.kept.written();
    let (stems, detector_cells) = tokio::task::spawn_blocking(move || tile_stems(state))
        .await
        .context("the detection task failed")?
        .map_err(spill_error)?;
    let count = |c: StemClass| stems.iter().filter(|s| s.class == c).count();
    eprintln!(
        "{total} points read ({band} in the 1.2–1.4 m band, {kept} around its circles kept, {:.0} MB of tile \
         files); {} stems: {} poles, {} trunks, {} unclassified",
        spilled as f64 / 1e6,
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
    let covered = PointLayer {
        name: COVERAGE_LAYER.to_owned(),
        fields: columns(&[("cell_m", FieldType::Real)]),
        features: detector_cells
            .iter()
            .map(|c| PointFeature { x: c[0] / unit, y: c[1] / unit, values: vec![FieldValue::Real(COVERAGE_CELL_M)] })
            .collect(),
    };
    let layers = [layer_of(&stems, unit), covered];
    let bytes = tokio::task::spawn_blocking(move || geopackage_in(&layers, epsg))
        .await
        .context("the GeoPackage task failed")??;
    ctx.write(&args.out, bytes).await?;
    println!("{}", args.out);
    Ok(ExitCode::SUCCESS)
}

/// What `poles detect` carries through its passes: the detector (the ground, the candidates) and the band and
/// surroundings bucketed by tile on disk.
struct Detection {
    detector: StemDetector,
    band: TileSpill<2>,
    kept: TileSpill<3>,
}

/// The candidates of every tile, fitted from its band points alone, each kept by the tile holding its
/// centre. The band's files are then dropped.
fn tile_candidates(mut state: Detection) -> std::io::Result<Detection> {
    let mut found = Vec::new();
    let detector = &state.detector;
    state.band.visit_tiles(TILE_POINTS, &|_, _| true, &mut |tiling, tile, band| {
        let band = band.read()?;
        found.extend(detector.candidates_in(&band).into_iter().filter(|c| tiling.tile_of(c.centre()) == tile));
        Ok(())
    })?;
    state.detector.add_candidates(found);
    state.band.clear()?;
    Ok(state)
}

/// The stems of every tile's candidates, followed in the surroundings of those candidates alone (a tile
/// without candidates is not read), merged; and the covered cells.
fn tile_stems(mut state: Detection) -> std::io::Result<(Vec<Stem>, Vec<[f64; 2]>)> {
    let candidates = state.detector.candidates().to_vec();
    let owned = |tiling: &Tiling, tile: (i64, i64)| -> Vec<Candidate> {
        candidates.iter().copied().filter(|c| tiling.tile_of(c.centre()) == tile).collect()
    };
    let mut stems = Vec::new();
    let detector = &state.detector;
    let wanted = |tiling: &Tiling, tile: (i64, i64)| candidates.iter().any(|c| tiling.tile_of(c.centre()) == tile);
    state.kept.visit_tiles(TILE_POINTS, &wanted, &mut |tiling, tile, kept| {
        let mine = owned(tiling, tile);
        let cells = surroundings_cells(&mine);
        let kept = kept.read_where(|p| cells.contains(&(p[0].floor() as i64, p[1].floor() as i64)))?;
        stems.extend(detector.stems_in(&mine, &kept));
        Ok(())
    })?;
    let config = state.detector.config();
    Ok((merge_stems(stems, &config), state.detector.covered_cells(COVERAGE_CELL_M)))
}

/// A layer's attribute columns from their names and types.
fn columns(fields: &[(&str, FieldType)]) -> Vec<(String, FieldType)> {
    fields.iter().map(|(n, t)| ((*n).to_owned(), *t)).collect()
}

/// The `detected_poles` layer, its points in units of `unit` metres (the CRS's), its attributes in metres.
fn layer_of(stems: &[Stem], unit: f64) -> PointLayer {
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
        ("fit", FieldType::Text),
    ];
    let features = stems
        .iter()
        .map(|s| PointFeature {
            x: s.centre[0] / unit,
            y: s.centre[1] / unit,
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
                FieldValue::Text(s.fit.name().to_owned()),
            ],
        })
        .collect();
    PointLayer { name: "detected_poles".to_owned(), fields: columns(&fields), features }
}

/// A class name as the manifest spells it.
fn pole_class(name: &str) -> anyhow::Result<PoleClass> {
    serde_json::from_value(serde_json::Value::String(name.to_owned()))
        .map_err(|_| invalid(format!("--class {name}: expected pole, light, sign or tree")))
}

/// The objects of `layer` in `file`'s bytes: every feature as one class (`class_values` empty) or classed
/// by `attribute` through `values`.
fn read_points(name: &str, bytes: &[u8], spec: &Cadastre, epsg: Epsg) -> anyhow::Result<Vec<CadastreFeature>> {
    let read = read_cadastre(CadastreSource::Bytes { name, bytes }, spec, epsg, None)
        .map_err(|e| if e.is_file_problem() { invalid(e.to_string()) } else { anyhow::Error::from(e) })?;
    for d in read.diagnostics.iter().take(10) {
        eprintln!("warning: {name}: {d:?}");
    }
    Ok(read.features)
}

async fn compare(ctx: &Context, args: CompareArgs) -> anyhow::Result<ExitCode> {
    if !(args.gate.is_finite() && args.gate > 0.0) {
        return Err(invalid(format!("--gate {}: expected a distance > 0 m", args.gate)));
    }
    if args.class.is_none() && args.class_attribute.is_none() {
        return Err(invalid("give --class or --class-attribute for the cadastre's objects"));
    }
    let class = args.class.as_deref().map(pole_class).transpose()?;
    let detected_bytes = ctx.read(&args.detected).await?;
    let cadastre_bytes = ctx.read(&args.cadastre).await?;
    let (detected_name, cadastre_name) = (file_name(&args.detected).to_owned(), file_name(&args.cadastre).to_owned());
    let gate = args.gate;
    let (layers, class_attribute) = (args.layers.clone(), args.class_attribute.clone());
    let report = tokio::task::spawn_blocking(move || -> anyhow::Result<Comparison> {
        let inspection =
            inspect_cadastre(CadastreSource::Bytes { name: &detected_name, bytes: &detected_bytes }, None)
                .map_err(|e| invalid(e.to_string()))?;
        let layer = |name: &str| inspection.layers.iter().find(|l| l.name == name);
        let Some(stems) = layer("detected_poles") else {
            return Err(invalid(format!("{detected_name} has no layer `detected_poles`: is it what `poles detect` wrote?")));
        };
        let Some(code) = stems.crs.epsg else {
            return Err(invalid(format!(
                "{detected_name}: layer `detected_poles` has no CRS (its clouds recorded none); run `poles detect` with \
                 --epsg"
            )));
        };
        let epsg = Epsg(code);
        let own = |layer: &str, class_attribute: Option<String>| Cadastre {
            url: Location(detected_name.clone()),
            layers: vec![layer.to_owned()],
            class_attribute,
            class_values: [("pole", PoleClass::Pole), ("trunk", PoleClass::Tree), ("unknown", PoleClass::Pole)]
                .into_iter()
                .map(|(k, v)| (k.to_owned(), v))
                .collect(),
            class: None,
            accuracy: ClassAccuracy::default(),
            diameter_attribute: Some("diameter_m".to_owned()),
            epsg: None,
        };
        let detections = read_points(&detected_name, &detected_bytes, &own("detected_poles", Some("class".to_owned())), epsg)?;
        let cells = if layer(COVERAGE_LAYER).is_some() {
            let spec = Cadastre { class: Some(PoleClass::Pole), class_values: Default::default(), diameter_attribute: None, ..own(COVERAGE_LAYER, None) };
            read_points(&detected_name, &detected_bytes, &spec, epsg)?
        } else {
            eprintln!("warning: {detected_name} has no `{COVERAGE_LAYER}` layer: every cadastre object not matched is listed as not seen");
            Vec::new()
        };
        let spec = Cadastre {
            url: Location(cadastre_name.clone()),
            layers,
            class_attribute,
            class_values: Default::default(),
            class,
            accuracy: ClassAccuracy::default(),
            diameter_attribute: None,
            epsg: None,
        };
        let cadastre = read_points(&cadastre_name, &cadastre_bytes, &spec, epsg)?;
        Ok(compare_sets(&detections, &cadastre, &cells, gate, epsg))
    })
    .await
    .context("the comparison task failed")??;
    let distances: Vec<f64> = report.matched.iter().map(|(_, _, d)| *d).collect();
    eprintln!(
        "{} detections, {} cadastre objects in the covered cells ({} outside): {} matched (distance median {:.3} m, max \
         {:.3} m), {} in the cloud but not in the cadastre, {} in the cadastre but not seen",
        report.detections,
        report.in_coverage,
        report.outside,
        report.matched.len(),
        median(&distances),
        distances.iter().copied().fold(0.0, f64::max),
        report.not_in_cadastre.len(),
        report.not_seen.len()
    );
    let layers = report.layers();
    let epsg = report.epsg.0;
    let bytes = tokio::task::spawn_blocking(move || geopackage_in(&layers, Some(epsg)))
        .await
        .context("the GeoPackage task failed")??;
    ctx.write(&args.out, bytes).await?;
    println!("{}", args.out);
    Ok(ExitCode::SUCCESS)
}

fn median(v: &[f64]) -> f64 {
    plumbline_geo::metrics::median(&mut v.to_vec()).unwrap_or(f64::NAN)
}

/// The outcome of a comparison.
struct Comparison {
    epsg: Epsg,
    detections: usize,
    in_coverage: usize,
    outside: usize,
    /// (detection, cadastre object, distance m).
    matched: Vec<(CadastreFeature, CadastreFeature, f64)>,
    not_in_cadastre: Vec<CadastreFeature>,
    not_seen: Vec<CadastreFeature>,
}

/// One-to-one pairs nearest first within `gate`; cadastre objects outside the covered `cells` (10 m cell
/// centres; none: all count as covered) are neither matched nor missed.
fn compare_sets(
    detections: &[CadastreFeature],
    cadastre: &[CadastreFeature],
    cells: &[CadastreFeature],
    gate: f64,
    epsg: Epsg,
) -> Comparison {
    let half = COVERAGE_CELL_M / 2.0;
    let covered = |o: &CadastreFeature| {
        cells.is_empty()
            || cells.iter().any(|c| (c.easting - o.easting).abs() <= half && (c.northing - o.northing).abs() <= half)
    };
    let (inside, outside): (Vec<&CadastreFeature>, Vec<&CadastreFeature>) = cadastre.iter().partition(|o| covered(o));
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, d) in detections.iter().enumerate() {
        for (j, o) in inside.iter().enumerate() {
            let dist = (d.easting - o.easting).hypot(d.northing - o.northing);
            if dist <= gate {
                pairs.push((dist, i, j));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (mut used_d, mut used_c) = (vec![false; detections.len()], vec![false; inside.len()]);
    let mut matched = Vec::new();
    for (dist, i, j) in pairs {
        if !used_d[i] && !used_c[j] {
            used_d[i] = true;
            used_c[j] = true;
            matched.push((detections[i], *inside[j], dist));
        }
    }
    Comparison {
        epsg,
        detections: detections.len(),
        in_coverage: inside.len(),
        outside: outside.len(),
        matched,
        not_in_cadastre: detections.iter().zip(&used_d).filter(|(_, u)| !**u).map(|(d, _)| *d).collect(),
        not_seen: inside.iter().zip(&used_c).filter(|(_, u)| !**u).map(|(o, _)| **o).collect(),
    }
}

fn class_name(c: PoleClass) -> String {
    serde_json::to_value(c).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_default()
}

impl Comparison {
    fn layers(&self) -> Vec<PointLayer> {
        let id = |o: &CadastreFeature| FieldValue::Integer(i64::try_from(o.id.fid).unwrap_or(i64::MAX));
        let matched = PointLayer {
            name: "matched".to_owned(),
            fields: columns(&[
                ("detected_fid", FieldType::Integer),
                ("cadastre_fid", FieldType::Integer),
                ("cadastre_layer", FieldType::Integer),
                ("cadastre_class", FieldType::Text),
                ("distance_m", FieldType::Real),
                ("d_east_m", FieldType::Real),
                ("d_north_m", FieldType::Real),
                ("diameter_m", FieldType::Real),
            ]),
            features: self
                .matched
                .iter()
                .map(|(d, o, dist)| PointFeature {
                    x: d.easting,
                    y: d.northing,
                    values: vec![
                        id(d),
                        id(o),
                        FieldValue::Integer(i64::from(o.id.layer)),
                        FieldValue::Text(class_name(o.class)),
                        FieldValue::Real(*dist),
                        FieldValue::Real(d.easting - o.easting),
                        FieldValue::Real(d.northing - o.northing),
                        FieldValue::Real(d.diameter_m.unwrap_or(f64::NAN)),
                    ],
                })
                .collect(),
        };
        let list = |name: &str, objects: &[CadastreFeature], fid: &str| PointLayer {
            name: name.to_owned(),
            fields: columns(&[(fid, FieldType::Integer), ("class", FieldType::Text)]),
            features: objects
                .iter()
                .map(|o| PointFeature {
                    x: o.easting,
                    y: o.northing,
                    values: vec![id(o), FieldValue::Text(class_name(o.class))],
                })
                .collect(),
        };
        vec![
            matched,
            list("not_in_cadastre", &self.not_in_cadastre, "detected_fid"),
            list("not_seen", &self.not_seen, "cadastre_fid"),
        ]
    }
}
