//! The adjuster's logic, shared by `plumbline run` and the adjuster service: merge the tiles' observations,
//! run the global adjustment (with standstill constraints and the consistency check's weak links), and
//! write the campaign's outputs — the corrected trajectory in the input's format, per-epoch corrections,
//! `observations.gpkg`, `report.json` and `report.html`.
//!
//! ```text
//! merge(&[TileOutputV1]) → Merged (observations, image motions, image outcomes, pole frames, tiles, skipped)
//! join_shared_points(&mut merged) → tie points sharing an image point joined into one (count)
//! solve(&dg, &merged, &mount, &AdjusterConfig) → Solved (consistency check, adjustment, corrected trajectory)
//! solve_observed(…, &mut |iteration| …) → the same, each adjustment iteration reported as it ends
//! build_report(&campaign, &merged, &solved, reference, &stages) → plumbline_report::Report
//! observation_layers(&campaign, &merged, &solved) → the point layers of observations.gpkg
//! road_lines(&dg, &merged, &solved, depth) → RoadLines: the marking strokes placed with the corrected
//!     and the DG trajectory, assembled into lines; line_layers(&lines) → the line layers of it
//! finish(&files, &campaign, &tiles, &config, &progress).await → all of it, written under campaign.output
//! ```

mod config;
mod corrections;
mod finish;
mod join;
mod layers;
mod lines;
mod merge;
mod refs;
mod report;
mod residuals;
pub mod service;
mod solve;

pub use config::{AdjusterConfig, critical_value};
pub use corrections::{CORRECTIONS_HEADER, corrections_csv};
pub use finish::{Finished, STAGE, finish, stages};
pub use join::{SAME_POINT_SIGMAS, join_shared_points};
pub use layers::{LAYERS, observation_layers};
pub use lines::{LINE_LAYERS, RoadLines, fill_report, ground_below_body, line_layers, road_lines};
pub use merge::{ImageOutcome, Merged, PanoramaStrokes, merge, motions_of, tile_name};
pub use report::build_report;
pub use report::series::SERIES_POINTS;
pub use residuals::normalised_residuals;
pub use solve::{SolveError, Solved, panorama_mount, solve, solve_observed};
