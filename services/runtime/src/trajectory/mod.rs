//! Trajectory files in and out: CSV or SBET (+ smrmsg) read into a projected campaign CRS, and a corrected
//! trajectory written back the way its input came (format and CRS).

pub mod crs;

use plumbline_geo::Trajectory;
use plumbline_geo::formats::{self, AttitudeConvention, Horizontal, RawTrajectory};

use plumbline_campaign::{LoadedTrajectory, TrajectoryFormat};

use crate::errors::{OrInvalid, invalid};
use crate::files::{Files, file_name};

/// Where a trajectory comes from.
#[derive(Clone, Debug)]
pub struct TrajectoryInput {
    /// The file, by path or URL.
    pub url: String,
    /// Its format.
    pub format: TrajectoryFormat,
    /// The smrmsg file of an SBET.
    pub smrmsg: Option<String>,
    /// Attitude convention of a CSV.
    pub attitude: AttitudeConvention,
    /// EPSG code of a CSV's coordinates (None: projected in `target`, or geographic WGS 84).
    pub epsg: Option<u32>,
}

/// Read `input` and bring it into the projected CRS `target`; every defect is invalid input naming the
/// file, record and field. A projected CSV without its own EPSG code is taken to be in `target` already.
/// Parsing and the CRS conversion run on a blocking thread (a campaign's trajectory has millions of records).
pub async fn load_trajectory(
    files: &Files,
    input: &TrajectoryInput,
    target: Option<u32>,
) -> crate::Result<LoadedTrajectory> {
    let bytes = files.read(&input.url).await?;
    let smrmsg = match (input.format, &input.smrmsg) {
        (TrajectoryFormat::Sbet, Some(u)) => Some((file_name(u).to_owned(), files.read(u).await?)),
        _ => None,
    };
    let input = input.clone();
    let name = file_name(&input.url).to_owned();
    tokio::task::spawn_blocking(move || decode(&input, &bytes, smrmsg, target))
        .await
        .map_err(|e| crate::Error::internal(format!("{name}: the decoding task failed: {e}")))?
}

/// Parse a trajectory file's bytes (and its smrmsg's, for an SBET) and bring it into `target`.
fn decode(
    input: &TrajectoryInput,
    bytes: &[u8],
    smrmsg: Option<(String, impl AsRef<[u8]>)>,
    target: Option<u32>,
) -> crate::Result<LoadedTrajectory> {
    let name = file_name(&input.url).to_owned();
    let raw: RawTrajectory = match input.format {
        TrajectoryFormat::Csv => {
            let parsed = formats::parse_csv(bytes, &name, input.attitude).or_invalid("")?;
            for w in &parsed.warnings {
                tracing::warn!(file = %name, warning = %w, "csv input");
            }
            parsed.trajectory
        }
        TrajectoryFormat::Sbet => {
            let records = formats::parse_sbet(bytes, &name).or_invalid("")?;
            let std = match smrmsg {
                Some((file, data)) => Some(formats::parse_smrmsg(data.as_ref(), &file).or_invalid("")?),
                None => None,
            };
            formats::sbet_to_raw(&records, std.as_deref())
        }
    };
    let horizontal = raw.horizontal;
    let source = match horizontal {
        Horizontal::Projected => input.epsg.or(target),
        Horizontal::Geographic => {
            if target.is_none() {
                return Err(invalid(format!(
                    "{name}: geographic coordinates; give the projected CRS to work in (the campaign CRS, --epsg)"
                )));
            }
            Some(input.epsg.unwrap_or(4326))
        }
    };
    if let Some(e) = target
        && !crs::is_projected(e).or_invalid("CRS")?
    {
        return Err(invalid(format!("EPSG:{e}: not a projected CRS")));
    }
    let trajectory = crs::into_projected(raw, source, target).or_invalid(&name)?;
    Ok(LoadedTrajectory { trajectory, format: input.format, horizontal, epsg: target, name })
}

/// Write `corrected` (in the campaign CRS) the way `input` came, as `{prefix}{stem}.csv` or
/// `{prefix}{stem}.sbet` + `{prefix}{stem}.smrmsg`; returns the files written.
pub async fn write_like_input(
    files: &Files,
    prefix: &str,
    stem: &str,
    input: &LoadedTrajectory,
    corrected: &Trajectory,
) -> crate::Result<Vec<String>> {
    let raw = match (input.horizontal, input.epsg) {
        (Horizontal::Geographic, Some(epsg)) => crs::express(corrected, epsg, 4326).or_invalid("output CRS")?,
        _ => RawTrajectory::from_map_projected(corrected.records()),
    };
    match input.format {
        TrajectoryFormat::Csv => {
            let url = format!("{prefix}{stem}.csv");
            files.write(&url, formats::write_csv(&raw)).await?;
            Ok(vec![url])
        }
        TrajectoryFormat::Sbet => {
            let records = formats::raw_to_sbet(&raw).or_invalid("corrected trajectory as SBET")?;
            let (sbet, smrmsg) = (format!("{prefix}{stem}.sbet"), format!("{prefix}{stem}.smrmsg"));
            files.write(&sbet, formats::write_sbet(&records)).await?;
            files.write(&smrmsg, formats::write_smrmsg(&formats::raw_to_smrmsg(&raw))).await?;
            Ok(vec![sbet, smrmsg])
        }
    }
}
