//! The campaign quality report: what moved where, with what precision, what was flagged or skipped.
//!
//! [`Report`] is the data (`report.json`, versioned, schema in `schemas/report.v1.schema.json`);
//! [`html::render`] turns it into one self-contained page (`report.html`: inline CSS and SVG plots, no
//! network). The figures are the project's quality measures (docs/design.md): along-track, cross-track and height
//! differences before and after in the table form of Meyer et al. (2023), registration counts in the form of
//! Jende et al. (2017), Table 1, and the reasons images or features were skipped.
//!
//! Synchronous and I/O-free: the caller gathers the numbers and stores the bytes.

pub mod decimate;
pub mod html;
mod model;
pub mod svg;

pub use model::{
    Accuracy, CampaignInfo, CorrectionSeries, CrossTrackSeries, Figures, FlaggedEpoch, HeightBiasLine, InputWarning,
    MapData, MapLine, MapMark, MarkState, RejectedObservation, Report, ReportDoc, Residuals, RoadLineKind,
    RoadLinePanoramas, StageLine, Summary, TileLine, TrackPoint,
};

/// File name of the report schema under `schemas/`.
pub const REPORT_SCHEMA_FILE: &str = "report.v1.schema.json";

/// The JSON Schema of [`ReportDoc`].
pub fn report_schema() -> serde_json::Value {
    serde_json::to_value(schemars::schema_for!(ReportDoc)).unwrap_or_default()
}
