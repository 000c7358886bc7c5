//! Opening every input a manifest names, cheaply, before a run: what `plumbline validate` reports.
//!
//! [`check_inputs`] reads what it can without the campaign's bulk: the trajectory (to know where and when the
//! drive is), the index tables and the header of the first image of each, the rasters' metadata through GDAL
//! (CRS, extent, bands, pixel type), each cadastre through the same reader the run uses, and the headers of
//! the point clouds. Everything found is returned at once:
//! - **problems** make the campaign (or a whole named input) unusable, or would make it silently yield
//!   nothing: a cadastre layer that does not exist, a raster in another CRS, an index whose rows all lie
//!   outside the trajectory, a point cloud that is no LAS file. `validate` exits with code 2 on any.
//! - **warnings** are item-level defects the run skips and reports (a bad row, one broken feature) and
//!   inputs the run does not use.

mod clouds;
mod images;
mod rasters;

use plumbline_campaign::manifest::{Cadastre, TrajectorySource};
use plumbline_campaign::tables::read_exterior;
use plumbline_campaign::{Consequence, DiagnosticKind, Location, ManifestV1};
use plumbline_geo::Trajectory;
use plumbline_runtime::Files;
use plumbline_runtime::cadastre::{CadastreSource, read_cadastre};
use plumbline_runtime::trajectory::load_trajectory;

use crate::load::{enough_records, manifest_base, trajectory_input};

/// Objects of a cadastre must lie this close to the drive for it to be any use, metres.
const CADASTRE_REACH_M: f64 = 100.0;
/// Rasters must overlap the drive's box grown by this much, metres.
const RASTER_REACH_M: f64 = 50.0;

/// What [`check_inputs`] found.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct InputCheck {
    /// Problems that make the campaign or a named input unusable (each names the manifest field and file).
    pub problems: Vec<String>,
    /// Item-level defects the run would skip, and inputs it would not use.
    pub warnings: Vec<String>,
}

/// Where and when the drive is, from its trajectory in the campaign CRS.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Drive {
    /// First and last epoch, seconds.
    pub span: (f64, f64),
    /// Smallest and largest easting and northing: `[min_e, min_n, max_e, max_n]`.
    pub bbox: [f64; 4],
}

impl Drive {
    fn of(trajectory: &Trajectory) -> Self {
        let mut bbox = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
        for r in trajectory.records() {
            let (e, n) = (r.position.x(), r.position.y());
            bbox = [bbox[0].min(e), bbox[1].min(n), bbox[2].max(e), bbox[3].max(n)];
        }
        Self { span: trajectory.span(), bbox }
    }

    /// Whether `[min_e, min_n, max_e, max_n]` overlaps the drive's box grown by `reach` metres.
    pub(crate) fn overlaps(&self, other: [f64; 4], reach: f64) -> bool {
        let b = self.bbox;
        other[0] <= b[2] + reach && other[2] >= b[0] - reach && other[1] <= b[3] + reach && other[3] >= b[1] - reach
    }

    /// Whether the point lies within `reach` metres of the drive's box.
    pub(crate) fn near(&self, e: f64, n: f64, reach: f64) -> bool {
        self.overlaps([e, n, e, n], reach)
    }

    pub(crate) fn describe(&self) -> String {
        let b = self.bbox;
        format!("E {:.0}–{:.0}, N {:.0}–{:.0}", b[0], b[2], b[1], b[3])
    }
}

/// The collector every check writes to.
#[derive(Debug)]
pub(crate) struct Checker<'a> {
    pub files: &'a Files,
    pub base: String,
    pub epsg: u32,
    pub drive: Option<Drive>,
    pub out: InputCheck,
}

impl Checker<'_> {
    pub(crate) fn problem(&mut self, field: &str, message: impl std::fmt::Display) {
        self.out.problems.push(format!("{field}: {message}"));
    }

    pub(crate) fn warning(&mut self, field: &str, message: impl std::fmt::Display) {
        self.out.warnings.push(format!("{field}: {message}"));
    }

    /// The absolute URL of a manifest location; a bad one is a problem (and `None`).
    pub(crate) fn url(&mut self, field: &str, location: &Location) -> Option<String> {
        match plumbline_campaign::resolve(&self.base, location.as_str()) {
            Ok(url) => Some(url),
            Err(e) => {
                self.problem(field, e);
                None
            }
        }
    }

    /// A whole file; a failure is a problem naming the field (and `None`).
    pub(crate) async fn read(&mut self, field: &str, url: &str) -> Option<bytes::Bytes> {
        match self.files.read(url).await {
            Ok(bytes) => Some(bytes),
            Err(e) => {
                self.problem(field, format!("`{url}`: {e:#}"));
                None
            }
        }
    }
}

/// Open every input `manifest` names (resolved against `manifest_url`) and report what would go wrong.
/// The manifest is assumed to have passed its own validation.
pub async fn check_inputs(files: &Files, manifest_url: &str, manifest: &ManifestV1) -> InputCheck {
    let mut c = Checker {
        files,
        base: manifest_base(manifest_url),
        epsg: manifest.crs.0,
        drive: None,
        out: InputCheck::default(),
    };
    for (i, source) in manifest.trajectory.iter().enumerate() {
        trajectory(&mut c, &format!("trajectory[{i}]"), source).await;
    }
    if let Some(p) = &manifest.panoramas {
        let expected = p.width_px.zip(p.height_px);
        images::index(&mut c, "panoramas", &p.index, &p.images, images::Expect::Panorama(expected)).await;
        if let Some(mask) = &p.vehicle_mask {
            images::vehicle_mask(&mut c, mask, expected).await;
        }
    }
    for (i, d) in manifest.depth.iter().enumerate() {
        let expect = images::Expect::Depth(d.intrinsics.width_px, d.intrinsics.height_px);
        images::index(&mut c, &format!("depth[{i}]"), &d.index, &d.images, expect).await;
    }
    if let Some(aerial) = &manifest.aerial {
        if let Some(block) = &aerial.frames {
            aerial_frames(&mut c, block).await;
        }
        if let Some(o) = &aerial.orthophoto {
            rasters::raster(&mut c, "aerial.orthophoto.image", &o.image, rasters::Role::Orthophoto).await;
            rasters::raster(&mut c, "aerial.orthophoto.terrain", &o.terrain, rasters::Role::Terrain).await;
        }
    }
    for (i, spec) in manifest.cadastres.iter().enumerate() {
        cadastre(&mut c, &format!("cadastres[{i}]"), spec).await;
    }
    for (i, cloud) in manifest.point_clouds.iter().enumerate() {
        clouds::point_cloud(&mut c, &format!("point_clouds[{i}]"), cloud).await;
    }
    c.out
}

/// The DG trajectory loads into the campaign CRS; its reference, when named, too (a warning: the run goes on
/// without a before/after table).
async fn trajectory(c: &mut Checker<'_>, field: &str, source: &TrajectorySource) {
    let base = c.base.clone();
    let resolve = |l: &Location| {
        plumbline_campaign::resolve(&base, l.as_str())
            .map_err(|e| plumbline_runtime::invalid(format!("{}: {e}", l.as_str())))
    };
    let loaded = match trajectory_input(source, &resolve) {
        Ok(input) => load_trajectory(c.files, &input, Some(c.epsg)).await,
        Err(e) => Err(e),
    };
    match loaded {
        Ok(t) => match enough_records(&t) {
            Err(why) => c.problem(field, why),
            Ok(()) if c.drive.is_none() => c.drive = Some(Drive::of(&t.trajectory)),
            Ok(()) => {}
        },
        Err(e) => c.problem(field, format!("{e:#}")),
    }
    if let Some(reference) = source.reference() {
        let Ok(url) = resolve(reference) else { return };
        let input = plumbline_runtime::trajectory::TrajectoryInput {
            format: plumbline_campaign::TrajectoryFormat::of(&url),
            url,
            smrmsg: None,
            attitude: plumbline_geo::formats::AttitudeConvention::Applanix,
            epsg: None,
        };
        if let Err(e) = load_trajectory(c.files, &input, Some(c.epsg)).await {
            c.warning(&format!("{field}.reference"), format!("{e:#} (the run goes on without a before/after table)"));
        }
    }
}

/// The aerial block's orientation table, its frames near the drive, and the first frame's size.
async fn aerial_frames(c: &mut Checker<'_>, block: &plumbline_campaign::manifest::FrameBlock) {
    let field = "aerial.frames.index";
    let Some(url) = c.url(field, &block.index) else { return };
    let Some(bytes) = c.read(field, &url).await else { return };
    let table = match read_exterior(&url, &bytes) {
        Ok(table) => table,
        Err(e) => return c.problem(field, e),
    };
    images::skipped_rows(c, field, &table.skipped);
    if table.rows.is_empty() {
        return c.problem(field, format!("`{url}` has no usable row"));
    }
    if let Some(drive) = c.drive {
        let near = table.rows.iter().filter(|r| drive.near(r.centre[0], r.centre[1], 2_000.0)).count();
        if near == 0 {
            c.problem(
                field,
                format!(
                    "none of the {} projection centres lies within 2 km of the drive ({}): another CRS?",
                    table.rows.len(),
                    drive.describe()
                ),
            );
        }
    }
    let interior = &block.interior;
    let first = &table.rows[0];
    images::first_image(
        c,
        field,
        &block.images,
        &first.file,
        images::Expect::Aerial(interior.width_px, interior.height_px),
    )
    .await;
}

/// A cadastre through the run's own reader: every layer it would skip is a problem, feature-level defects are
/// warnings, and objects must lie near the drive (a wrong `epsg` puts them elsewhere).
async fn cadastre(c: &mut Checker<'_>, field: &str, spec: &Cadastre) {
    let Some(url) = c.url(&format!("{field}.url"), &spec.url) else { return };
    let Some(bytes) = c.read(&format!("{field}.url"), &url).await else { return };
    let (owned, name, epsg) = (spec.clone(), url.clone(), plumbline_campaign::Epsg(c.epsg));
    let read = tokio::task::spawn_blocking(move || {
        read_cadastre(CadastreSource::Bytes { name: &name, bytes: &bytes }, &owned, epsg, None)
    })
    .await;
    let read = match read {
        Ok(Ok(read)) => read,
        Ok(Err(e)) => return c.problem(field, e),
        Err(e) => return c.problem(field, format!("`{url}`: the reading task failed: {e}")),
    };
    let mut feature_level: std::collections::BTreeMap<DiagnosticKind, (usize, String)> = Default::default();
    for d in &read.diagnostics {
        // A layer skipped, a layer read only in part, or an `epsg` that is not used: the campaign would get less
        // control than the manifest promises.
        let damaging = d.consequence == Consequence::LayerSkipped
            || matches!(d.kind, DiagnosticKind::ReadFailed | DiagnosticKind::SrsConflict);
        if damaging {
            c.problem(field, d);
        } else {
            feature_level.entry(d.kind).or_insert((0, d.to_string())).0 += 1;
        }
    }
    for (kind, (n, first)) in feature_level {
        c.warning(field, format!("{n} diagnostic(s) of kind {kind:?}, e.g. {first}"));
    }
    let used: usize = read.layers.iter().map(|l| l.used).sum();
    if used == 0 {
        return c.problem(field, format!("`{url}`: no usable object in layers {:?}", spec.layers));
    }
    if let Some(drive) = c.drive {
        let near = read.features.iter().filter(|f| drive.near(f.easting, f.northing, CADASTRE_REACH_M)).count();
        if near == 0 {
            let f = &read.features[0];
            c.problem(
                field,
                format!(
                    "`{url}`: none of its {used} objects lies within {CADASTRE_REACH_M} m of the drive ({}); the first \
                     is at E {:.0}, N {:.0} in the campaign CRS — is the layer's CRS (or `epsg`) right?",
                    drive.describe(),
                    f.easting,
                    f.northing
                ),
            );
        }
    }
}
