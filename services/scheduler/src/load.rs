//! Loading a campaign: the manifest (parsed, validated, its CRS checked against PROJ), the DG trajectory
//! in the campaign CRS, the optional reference trajectory, the image indexes and aerial orientations, and
//! the tile plan.

use plumbline_campaign::manifest::{CsvTrajectory, SbetTrajectory, TrajectorySource};
use plumbline_campaign::plan::plan_campaign;
use plumbline_campaign::tables::{ExteriorRow, IndexRow, Table, read_exterior, read_index};
use plumbline_campaign::{Campaign, Location, Manifest, Problem, SkipReason, SkippedInput, Stage};
use plumbline_campaign::{LoadedTrajectory, TrajectoryFormat};
use plumbline_geo::formats::AttitudeConvention;
use plumbline_geo::tiling::TilingParams;
use plumbline_runtime::errors::{OrInvalid, invalid};
use plumbline_runtime::trajectory::{TrajectoryInput, load_trajectory};
use plumbline_runtime::{Files, file_name};

/// The absolute URL a manifest's relative locations resolve against (plain paths become `file://` URLs).
pub fn manifest_base(manifest_url: &str) -> String {
    if manifest_url.contains("://") {
        return manifest_url.to_owned();
    }
    let absolute = std::path::absolute(manifest_url).unwrap_or_else(|_| manifest_url.into());
    format!("file://{}", absolute.display())
}

/// Parse a manifest's bytes: JSON when `name` ends in `.json`, TOML otherwise; errors are invalid input
/// naming the file.
pub fn parse_manifest(name: &str, bytes: &[u8]) -> plumbline_runtime::Result<Manifest> {
    let text = std::str::from_utf8(bytes).or_invalid(&format!("{name}: not UTF-8 text"))?;
    if name.to_ascii_lowercase().ends_with(".json") {
        Manifest::from_json_str(text)
    } else {
        Manifest::from_toml_str(text)
    }
    .or_invalid(name)
}

/// Read, validate and plan the campaign `manifest_url` names. Every problem that makes the campaign
/// unusable as a whole is an invalid-input error; single bad rows are skipped and listed.
pub async fn load_campaign(files: &Files, manifest_url: &str) -> plumbline_runtime::Result<Campaign> {
    let name = file_name(manifest_url).to_owned();
    let manifest = parse_manifest(&name, &files.read(manifest_url).await?)?;
    if let Err(problems) = manifest.validate() {
        let list: Vec<String> = problems.iter().map(Problem::to_string).collect();
        return Err(invalid(format!("{name}: {} problem(s):\n  {}", list.len(), list.join("\n  "))));
    }
    let manifest = manifest.into_latest();
    let epsg = manifest.crs.0;
    match plumbline_runtime::is_projected(epsg) {
        Ok(true) => {}
        Ok(false) => return Err(invalid(format!("{name}: crs: EPSG:{epsg} is not a projected CRS (metres)"))),
        Err(e) => return Err(invalid(format!("{name}: crs: {e}"))),
    }
    let base = manifest_base(manifest_url);
    let resolve = |l: &Location| plumbline_campaign::resolve(&base, l.as_str()).or_invalid(&name);
    let mut output = resolve(&manifest.output)?;
    if !output.ends_with('/') {
        output.push('/');
    }
    let mut skipped = Vec::new();

    let [source] = manifest.trajectory.as_slice() else {
        return Err(invalid(format!(
            "{name}: trajectory: {} sources; one campaign run takes exactly one trajectory (split multi-day \
             campaigns into one manifest per drive)",
            manifest.trajectory.len()
        )));
    };
    let trajectory = load_trajectory(files, &trajectory_input(source, &resolve)?, Some(epsg)).await?;
    enough_records(&trajectory).map_err(invalid)?;
    tracing::info!(file = %trajectory.name, records = trajectory.trajectory.len(), "trajectory loaded");
    let reference = match source.reference() {
        Some(location) => {
            let url = resolve(location)?;
            let input = TrajectoryInput {
                url: url.clone(),
                format: TrajectoryFormat::of(&url),
                smrmsg: None,
                attitude: AttitudeConvention::Applanix,
                epsg: None,
            };
            match load_trajectory(files, &input, Some(epsg)).await {
                Ok(r) => Some(r.trajectory),
                Err(e) => {
                    tracing::warn!(file = %url, error = %e, "reference trajectory skipped");
                    let detail = format!("reference trajectory {url}: {e:#}");
                    skipped.push(SkippedInput::new(Stage::Load, url.clone(), SkipReason::Reference, detail));
                    None
                }
            }
        }
        None => None,
    };

    let Some(panoramas) = &manifest.panoramas else {
        return Err(invalid(format!(
            "{name}: panoramas: missing; `run` tiles the campaign by its panoramas (a depth-only campaign is \
             not supported yet)"
        )));
    };
    let pano_rows = index(files, &resolve(&panoramas.index)?, Stage::Load, &mut skipped).await?;
    if pano_rows.is_empty() {
        return Err(invalid(format!("{}: no usable panorama rows", resolve(&panoramas.index)?)));
    }
    let mut depth_rows = Vec::new();
    for camera in &manifest.depth {
        depth_rows.push(index(files, &resolve(&camera.index)?, Stage::Load, &mut skipped).await?);
    }
    let aerial_frames = match manifest.aerial.as_ref().and_then(|a| a.frames.as_ref()) {
        Some(block) => {
            let url = resolve(&block.index)?;
            let bytes = files.read(&url).await?;
            let table: Table<ExteriorRow> = read_exterior(&url, &bytes).or_invalid("")?;
            skipped.extend(table.skipped.iter().map(|p| SkippedInput::row(Stage::Load, p)));
            table.rows
        }
        None => Vec::new(),
    };

    let params = TilingParams::new(manifest.tiling.tile_size_m, manifest.tiling.overlap_m);
    let (plan, trajectory) = tokio::task::spawn_blocking(move || {
        let plan = plan_campaign(&pano_rows, &depth_rows, &trajectory.trajectory, &params);
        (plan, trajectory)
    })
    .await
    .map_err(|e| plumbline_runtime::Error::internal(format!("{name}: the planning task failed: {e}")))?;
    let plan = plan.or_invalid(&name)?;
    for u in &plan.unplanned {
        let detail = format!("{} image {}: {}", u.source, u.image_id, u.reason);
        let item = format!("{} {}", u.source, u.image_id);
        skipped.push(SkippedInput::new(Stage::Plan, item, SkipReason::OutsideTrajectory, detail));
    }
    if plan.panoramas.is_empty() {
        return Err(invalid(format!("{name}: no panorama lies within the trajectory's time span")));
    }
    Ok(Campaign { base, manifest: manifest.clone(), output, trajectory, reference, aerial_frames, plan, skipped })
}

/// A DG trajectory spans time: one record cannot place any image.
pub(crate) fn enough_records(loaded: &LoadedTrajectory) -> Result<(), String> {
    match loaded.trajectory.len() {
        0 | 1 => Err(format!(
            "{}: {} record(s); a trajectory needs at least two to place images in time",
            loaded.name,
            loaded.trajectory.len()
        )),
        _ => Ok(()),
    }
}

/// The DG trajectory's input description, locations resolved.
pub(crate) fn trajectory_input(
    source: &TrajectorySource,
    resolve: &impl Fn(&Location) -> plumbline_runtime::Result<String>,
) -> plumbline_runtime::Result<TrajectoryInput> {
    Ok(match source {
        TrajectorySource::Csv(CsvTrajectory { url, epsg, attitude, .. }) => TrajectoryInput {
            url: resolve(url)?,
            format: TrajectoryFormat::Csv,
            smrmsg: None,
            attitude: match attitude {
                plumbline_campaign::manifest::AttitudeConvention::Applanix => AttitudeConvention::Applanix,
                plumbline_campaign::manifest::AttitudeConvention::Novatel => AttitudeConvention::Novatel,
            },
            epsg: epsg.map(|e| e.0),
        },
        TrajectorySource::Sbet(SbetTrajectory { url, smrmsg, .. }) => TrajectoryInput {
            url: resolve(url)?,
            format: TrajectoryFormat::Sbet,
            smrmsg: smrmsg.as_ref().map(resolve).transpose()?,
            attitude: AttitudeConvention::Applanix,
            epsg: None,
        },
    })
}

/// Read an image index; bad rows are skipped and listed, an unreadable table is invalid input.
async fn index(
    files: &Files,
    url: &str,
    stage: Stage,
    skipped: &mut Vec<SkippedInput>,
) -> plumbline_runtime::Result<Vec<IndexRow>> {
    let bytes = files.read(url).await?;
    let table = read_index(url, &bytes).or_invalid("")?;
    skipped.extend(table.skipped.iter().map(|p| SkippedInput::row(stage, p)));
    Ok(table.rows)
}
