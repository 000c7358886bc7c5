//! Road markings as lines, after Grejner-Brzezinska & Toth's mapping of linear features from directly
//! georeferenced imagery: strokes are extracted from each panorama's ortho patch ([`extract`]: background
//! removal, thresholding, linking, vectorising), the strokes of overlapping patches are tracked into pieces
//! and the pieces classified into road lines ([`assemble`]), and pieces are scored against true markings
//! ([`evaluate`]); true elements can be read from CSV ([`parse_markings_csv`]).
//!
//! Synchronous and I/O-free. Map coordinates are easting/northing in metres; headings are radians clockwise
//! from grid north.

mod assemble;
mod background;
mod evaluate;
mod extract;
mod geometry;
mod lines;
mod markings;
mod piece;
#[cfg(test)]
mod scene;

pub use assemble::{Assembly, Observed, assemble};
pub use evaluate::{
    ElementScore, EvaluateConfig, FOUND_SHARE, LineScore, TruthElement, evaluate, per_element, within_reach,
};
pub use extract::{ExtractConfig, Stroke, extract};
pub use lines::{DashPattern, LineKind, RoadLine};
pub use markings::{MarkingsCsvError, parse_markings_csv};
pub use piece::{AssembleConfig, Piece};
