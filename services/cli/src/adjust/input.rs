//! Reading what `plumbline adjust` works on: the DG trajectory into the campaign CRS, the observation sets
//! (merged, each observation remembering its file and index there), and optional weak links.

use plumbline_adjustment::{ObservationRef, ObservationSet, ObservationSetV1, WeakLink};
use plumbline_campaign::TrajectoryFormat;
use plumbline_geo::formats::AttitudeConvention;
use plumbline_runtime::trajectory::{TrajectoryInput, load_trajectory};

use super::Args;
use crate::exit::{OrInvalid, invalid};
use crate::io::{Context, file_name};

pub use plumbline_campaign::LoadedTrajectory;

/// Read and project the trajectory `args` names; every defect is invalid input naming file, record, field.
pub async fn trajectory(ctx: &Context, args: &Args) -> anyhow::Result<LoadedTrajectory> {
    let input = TrajectoryInput {
        url: args.trajectory.clone(),
        format: args.format.map_or_else(|| TrajectoryFormat::of(&args.trajectory), TrajectoryFormat::from),
        smrmsg: args.smrmsg.clone(),
        attitude: AttitudeConvention::Applanix,
        epsg: None,
    };
    if let Some(e) = args.epsg
        && !plumbline_runtime::is_projected(e).or_invalid("--epsg")?
    {
        return Err(invalid(format!("--epsg {e}: not a projected CRS")));
    }
    Ok(load_trajectory(ctx.files(), &input, args.epsg).await?)
}

/// How many observations of each kind one file contributed.
#[derive(Clone, Debug)]
pub struct SourceFile {
    /// File name.
    pub name: String,
    ties: usize,
    poles: usize,
    gnss: usize,
}

/// All observation sets merged, with their provenance.
#[derive(Clone, Debug, Default)]
pub struct Observations {
    /// The merged set (files in command-line order).
    pub set: ObservationSetV1,
    /// The files, in the same order.
    pub files: Vec<SourceFile>,
}

impl Observations {
    /// Total number of observations (tie points, poles, GNSS positions).
    pub fn count(&self) -> usize {
        self.set.ties.len() + self.set.poles.len() + self.set.gnss.len()
    }

    /// The file and the index within it of merged index `index` of a kind (0 ties, 1 poles, 2 GNSS).
    pub fn locate(&self, kind: usize, mut index: usize) -> Option<(&str, usize)> {
        for f in &self.files {
            let n = [f.ties, f.poles, f.gnss][kind];
            if index < n {
                return Some((&f.name, index));
            }
            index -= n;
        }
        None
    }

    /// `file: poles[3] (id)` for an observation of the merged set.
    pub fn describe(&self, item: &ObservationRef) -> String {
        let (kind, index, what, extra) = match item {
            ObservationRef::Pole { index, cadastre_id } => (1, *index, "poles", format!(" ({cadastre_id})")),
            ObservationRef::Gnss { index } => (2, *index, "gnss", String::new()),
            ObservationRef::TieRay { index, point, ray } => (0, *index, "ties", format!(".rays[{ray}] ({})", point.0)),
            ObservationRef::TieAerial { index, point } => (0, *index, "ties", format!(".aerial ({})", point.0)),
            ObservationRef::Tie { index, point } => (0, *index, "ties", format!(" ({})", point.0)),
        };
        match self.locate(kind, index) {
            Some((file, local)) => format!("{file}: {what}[{local}]{extra}"),
            None => format!("{what}[{index}]{extra}"),
        }
    }

    /// The epoch of an observation of the merged set (a tie point: its first ray's).
    pub fn time(&self, item: &ObservationRef) -> Option<f64> {
        match item {
            ObservationRef::Pole { index, .. } => self.set.poles.get(*index).map(|p| p.time),
            ObservationRef::Gnss { index } => self.set.gnss.get(*index).map(|g| g.time),
            ObservationRef::TieRay { index, ray, .. } => {
                self.set.ties.get(*index).and_then(|t| t.rays.get(*ray)).map(|r| r.time)
            }
            ObservationRef::TieAerial { index, .. } | ObservationRef::Tie { index, .. } => {
                self.set.ties.get(*index).and_then(|t| t.rays.first()).map(|r| r.time)
            }
        }
    }
}

/// Read and merge the observation files; a file that is not a valid v1 set is invalid input naming the file,
/// the field path, line and column.
pub async fn observations(ctx: &Context, urls: &[String]) -> anyhow::Result<Observations> {
    let mut out = Observations::default();
    for url in urls {
        let name = file_name(url).to_owned();
        let bytes = ctx.read(url).await?;
        let set = parse_set(&bytes, &name)?;
        out.files.push(SourceFile { name, ties: set.ties.len(), poles: set.poles.len(), gnss: set.gnss.len() });
        out.set.extend(set);
    }
    Ok(out)
}

/// One observation file: the version tag first, then the set with the failing field's path in errors (an
/// internally tagged enum would hide it).
fn parse_set(bytes: &[u8], name: &str) -> anyhow::Result<ObservationSetV1> {
    let mut value: serde_json::Value = serde_json::from_slice(bytes).map_err(|e| invalid(format!("{name}: {e}")))?;
    let version = value.get("version").cloned();
    match (value.as_object_mut(), version.as_ref().and_then(|v| v.as_str())) {
        (Some(object), Some("1")) => {
            object.remove("version");
            let set: ObservationSetV1 = serde_path_to_error::deserialize(value)
                .map_err(|e| invalid(format!("{name}: at `{}`: {}", e.path(), e.inner())))?;
            Ok(ObservationSet::V1(set).into_latest())
        }
        (None, _) => Err(invalid(format!("{name}: not a JSON object"))),
        (Some(_), _) => Err(invalid(format!("{name}: `version` is {version:?}; expected \"1\""))),
    }
}

/// Read a JSON list of weak links; each must have finite start < end and a factor ≥ 1.
pub async fn weak_links(ctx: &Context, url: &str) -> anyhow::Result<Vec<WeakLink>> {
    let name = file_name(url);
    let bytes = ctx.read(url).await?;
    let mut de = serde_json::Deserializer::from_slice(&bytes);
    let links: Vec<WeakLink> = serde_path_to_error::deserialize(&mut de)
        .map_err(|e| invalid(format!("{name}: at `{}`: {}", e.path(), e.inner())))?;
    for (i, l) in links.iter().enumerate() {
        if !(l.start.is_finite() && l.end.is_finite() && l.start < l.end) {
            return Err(invalid(format!("{name}: [{i}]: `start`/`end` must be finite with start < end")));
        }
        if !(l.factor.is_finite() && l.factor >= 1.0) {
            return Err(invalid(format!("{name}: [{i}].factor is {}; expected a finite number ≥ 1", l.factor)));
        }
    }
    Ok(links)
}
