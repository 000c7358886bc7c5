//! The report's data, version 1: every figure `report.html` shows, in the same units.

use plumbline_campaign::{SkipReason, SkippedInput, Stage};
use plumbline_geo::metrics::{Comparison, Stats};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A report of any supported version, tagged by `"version"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "version")]
pub enum ReportDoc {
    /// Version 1.
    #[serde(rename = "1")]
    V1(Report),
}

/// The quality report of one campaign run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Report {
    /// Which campaign.
    pub campaign: CampaignInfo,
    /// Counts at a glance.
    pub summary: Summary,
    /// Before/after against a reference trajectory, when the manifest names one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accuracy: Option<Accuracy>,
    /// The correction applied along the trajectory (decimated for plotting).
    pub correction: CorrectionSeries,
    /// Cross-track difference to the reference along the trajectory, before and after (decimated).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cross_track: Option<CrossTrackSeries>,
    /// The map: trajectory coloured by correction, images and poles.
    pub map: MapData,
    /// Normalised residuals (residual / σ) per observation kind, for the histograms.
    pub residuals: Vec<Residuals>,
    /// Per-stage progress and time.
    pub stages: Vec<StageLine>,
    /// Per-tile diagnostics.
    pub tiles: Vec<TileLine>,
    /// Every skipped input item, with its reason.
    pub skipped: Vec<SkippedInput>,
    /// Observations rejected by data snooping.
    pub rejected: Vec<RejectedObservation>,
    /// Epochs flagged by the integrity and consistency tests.
    pub flags: Vec<FlaggedEpoch>,
    /// The estimated height bias of each aerial frame set (absent in reports written before it existed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub height_biases: Vec<HeightBiasLine>,
    /// The road lines extracted from the panoramas' ortho-images, by kind (absent when none was found).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub road_lines: Vec<RoadLineKind>,
    /// How many registered panoramas gave the road lines strokes, and how many were skipped (absent when
    /// no panorama gave any).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub road_line_panoramas: Option<RoadLinePanoramas>,
    /// Inputs the manifest names that gave the adjustment no control at all (absent when every named input
    /// contributed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<InputWarning>,
}

/// A named input that yielded no control: the run went on without it, and says so loudly.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InputWarning {
    /// The manifest field that names the input, e.g. `cadastres[1]`, `aerial.orthophoto`, `point_clouds[0]`.
    pub input: String,
    /// Its location as the manifest gives it.
    pub location: String,
    /// What it yielded and the likely reasons.
    pub message: String,
}

impl std::fmt::Display for InputWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} (`{}`): {}", self.input, self.location, self.message)
    }
}

/// Identity of the campaign.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CampaignInfo {
    /// Campaign id.
    pub id: String,
    /// Human-readable name.
    pub name: String,
    /// EPSG code of the mapping frame.
    pub crs: u32,
    /// The program and version that wrote the report.
    pub generated_by: String,
}

/// Counts at a glance.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Summary {
    /// Trajectory epochs corrected.
    pub epochs: usize,
    /// Duration of the trajectory, seconds.
    pub duration_s: f64,
    /// Length driven, metres.
    pub length_m: f64,
    /// Panoramas processed.
    pub images: usize,
    /// Panoramas with aerial correspondences (Jende et al. 2017, Table 1 "images matched").
    pub images_matched: usize,
    /// Tie points used.
    pub ties: usize,
    /// Pole coordinate updates used.
    pub pole_updates: usize,
    /// GNSS positions used.
    pub gnss: usize,
    /// Largest horizontal correction, metres.
    pub max_correction_m: f64,
    /// Adjustment's a-posteriori σ0.
    pub sigma0: f64,
}

/// Differences to a reference, summarised in the table form of Meyer et al. (2023).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Figures {
    /// Along-track |d| statistics, metres.
    pub along: Stats,
    /// Cross-track |d| statistics, metres.
    pub cross: Stats,
    /// Height |d| statistics, metres.
    pub height: Stats,
    /// Horizontal RMSE, metres.
    pub rmse_2d: f64,
    /// 3D RMSE, metres.
    pub rmse_3d: f64,
}

impl From<&Comparison> for Figures {
    fn from(c: &Comparison) -> Self {
        Self { along: c.along, cross: c.cross, height: c.height, rmse_2d: c.rmse_2d, rmse_3d: c.rmse_3d }
    }
}

/// Before (DG) and after (adjusted) against the reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Accuracy {
    /// The reference trajectory's name (URL).
    pub reference: String,
    /// The DG trajectory against the reference.
    pub before: Figures,
    /// The corrected trajectory against the reference.
    pub after: Figures,
}

impl Accuracy {
    /// The before/after table in the form of Meyer et al. 2023 (|difference| median, 95 %, 99 %, max per direction,
    /// then the 2D RMSE), metres, as plain text.
    pub fn table(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ =
            writeln!(s, "{:<12} {:>6} {:>8} {:>8} {:>8} {:>8}", "vs reference", "", "median", "95 %", "99 %", "max");
        let rows = [
            ("along-track", self.before.along, self.after.along),
            ("cross-track", self.before.cross, self.after.cross),
            ("height", self.before.height, self.after.height),
        ];
        for (name, before, after) in rows {
            for (when, st) in [("DG", before), ("after", after)] {
                let _ = writeln!(
                    s,
                    "{name:<12} {when:>6} {:>8.3} {:>8.3} {:>8.3} {:>8.3}",
                    st.median, st.p95, st.p99, st.max
                );
            }
        }
        let _ = writeln!(
            s,
            "RMSE 2D: DG {:.3} m -> after {:.3} m;  3D: {:.3} m -> {:.3} m",
            self.before.rmse_2d, self.after.rmse_2d, self.before.rmse_3d, self.after.rmse_3d
        );
        s
    }
}

/// The correction (adjusted − DG) along the trajectory, with its posterior σ.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CorrectionSeries {
    /// Epoch times, seconds.
    pub time: Vec<f64>,
    /// Easting correction, metres.
    pub east: Vec<f64>,
    /// Northing correction, metres.
    pub north: Vec<f64>,
    /// Height correction, metres.
    pub up: Vec<f64>,
    /// Posterior horizontal σ, metres.
    pub sigma_horizontal: Vec<f64>,
}

/// Cross-track differences to the reference, before and after.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CrossTrackSeries {
    /// Epoch times, seconds.
    pub time: Vec<f64>,
    /// DG minus reference, metres.
    pub before: Vec<f64>,
    /// Corrected minus reference, metres.
    pub after: Vec<f64>,
}

/// A trajectory vertex for the map.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TrackPoint {
    /// Easting, metres.
    pub e: f64,
    /// Northing, metres.
    pub n: f64,
    /// Horizontal correction there, metres.
    pub correction: f64,
}

/// What became of a mapped image or pole.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MarkState {
    /// Used as control (image registered to the aerial block, pole matched).
    Used,
    /// Processed without result.
    Unused,
    /// Skipped for a reason listed in `skipped`.
    Skipped,
}

/// An image or pole on the map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MapMark {
    /// Id of the image or pole.
    pub id: String,
    /// Easting, metres.
    pub e: f64,
    /// Northing, metres.
    pub n: f64,
    /// What became of it.
    pub state: MarkState,
}

/// Everything drawn on the map.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MapData {
    /// The corrected trajectory (decimated).
    pub track: Vec<TrackPoint>,
    /// Panorama positions.
    pub images: Vec<MapMark>,
    /// Cadastre poles near the trajectory.
    pub poles: Vec<MapMark>,
    /// Road markings extracted along the drive, placed with the corrected trajectory (absent in reports
    /// written before the line product existed, or when none was found).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lines: Vec<MapLine>,
}

/// A road line on the map.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MapLine {
    /// Its kind: `solid`, `dashed`, `stop_line`, `zebra_stripe`, `other`.
    pub kind: String,
    /// Vertices, easting/northing, metres.
    pub points: Vec<[f64; 2]>,
}

/// The road lines of one kind.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RoadLineKind {
    /// The kind: `solid`, `dashed`, `stop_line`, `zebra_stripe`, `other`.
    pub kind: String,
    /// Lines of this kind.
    pub lines: usize,
    /// Their total length, metres (a dashed line's from its first dash to its last).
    pub length_m: f64,
    /// The median over their vertices of the vertex σ, metres.
    pub median_sigma_m: f64,
}

/// Which panoramas the road lines came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RoadLinePanoramas {
    /// Panoramas whose strokes were placed.
    pub with_strokes: usize,
    /// Registered panoramas whose ortho patch gave no stroke (no paint in view, paint hidden by traffic,
    /// shadows or the vehicle, or no ortho patch): skipped.
    pub without_strokes: usize,
    /// Panoramas with strokes that could not be placed (their time outside the trajectory): skipped.
    pub unplaced: usize,
}

/// Normalised residuals of one observation kind.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Residuals {
    /// Observation kind: `tie`, `pole`, `gnss`.
    pub kind: String,
    /// Residual / σ per observation component.
    pub normalised: Vec<f64>,
}

/// One stage of the run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StageLine {
    /// Stage name (e.g. `registration`, `poles`, `adjustment`).
    pub name: String,
    /// Items finished.
    pub done: usize,
    /// Items in all.
    pub total: usize,
    /// Items skipped.
    pub skipped: usize,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// One tile's diagnostics.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TileLine {
    /// Tile id (e.g. `c12_r-3`).
    pub tile: String,
    /// Panoramas processed.
    pub images: usize,
    /// Panoramas registered to the aerial block.
    pub matched: usize,
    /// Tie points produced.
    pub ties: usize,
    /// Pole updates produced.
    pub poles: usize,
    /// Items skipped.
    pub skipped: usize,
}

/// An observation rejected by data snooping.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RejectedObservation {
    /// Observation kind: `tie`, `pole`, `gnss`.
    pub kind: String,
    /// Its id (tie point id, cadastre id, epoch).
    pub id: String,
    /// Epoch of the observation, seconds.
    pub time: f64,
    /// Baarda's w-test value at rejection.
    pub w_test: f64,
    /// For a whole tie point: the id of its rejected part (`….rays[k]`, `….aerial`) that left it undetermined
    /// — it was not tested itself. Absent for observations the test rejected.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub follows: Option<String>,
}

/// An epoch flagged by an integrity or consistency test.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FlaggedEpoch {
    /// Epoch, seconds.
    pub time: f64,
    /// The test that fired (e.g. `local_overall`, `consistency`).
    pub test: String,
    /// The sensor it blames (e.g. `gnss`, `imu`, `dg`).
    pub sensor: String,
}

/// The common height bias of the aerial points triangulated from one set of aerial frames.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HeightBiasLine {
    /// The set's aerial frames.
    pub frames: Vec<String>,
    /// Aerial heights of the set the adjustment used.
    pub points: usize,
    /// The bias (triangulated aerial height − adjusted height), metres.
    pub bias_m: f64,
    /// Its posterior σ, metres.
    pub sigma_m: f64,
    /// Its prior σ, metres.
    pub prior_sigma_m: f64,
}

impl Report {
    /// Rejected observations the w-test rejected itself (not left undetermined by another rejection).
    pub fn rejected_by_test(&self) -> usize {
        self.rejected.iter().filter(|r| r.follows.is_none()).count()
    }

    /// Skipped items counted by (stage, reason), most frequent first, then by stage and reason name.
    pub fn skipped_by_reason(&self) -> Vec<(Stage, SkipReason, usize)> {
        let mut counts: std::collections::BTreeMap<(Stage, String), (SkipReason, usize)> = Default::default();
        for s in &self.skipped {
            counts.entry((s.stage, s.reason.name().into_owned())).or_insert_with(|| (s.reason.clone(), 0)).1 += 1;
        }
        let mut out: Vec<(Stage, SkipReason, usize)> =
            counts.into_iter().map(|((stage, _), (reason, n))| (stage, reason, n)).collect();
        out.sort_by(|a, b| b.2.cmp(&a.2).then_with(|| (a.0, a.1.name()).cmp(&(b.0, b.1.name()))));
        out
    }

    /// `report.json`: the versioned document, pretty-printed.
    pub fn to_json(&self) -> Vec<u8> {
        serde_json::to_vec_pretty(&ReportDoc::V1(self.clone())).unwrap_or_default()
    }
}
