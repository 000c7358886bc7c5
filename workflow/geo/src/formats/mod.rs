//! Trajectory file formats (parse from bytes, write to bytes).
//!
//! Every format is read into and written from one intermediate, [`RawTrajectory`], which keeps the
//! coordinates as the file has them: projected (easting, northing, height; heading from grid north) or
//! geographic (longitude, latitude in degrees, ellipsoidal height; heading from true north). The crate never
//! projects coordinates itself: [`RawTrajectory::into_map`] and [`RawTrajectory::from_map`] take the
//! projection as a closure (the services pass a GDAL transformation).
//!
//! - [`csv`]: header-driven text, projected or geographic, units in the header.
//! - [`sbet`]: Applanix SBET binary (geographic), with its standard-deviation companion [`smrmsg`].
//!
//! Parsers are strict about values and units and name the input, the line or byte offset, and the
//! column of the first defect ([`FormatError`]). Plausibility (time order, speed) is left to
//! [`crate::Trajectory::new`].

pub mod csv;
pub mod sbet;
pub mod smrmsg;

mod binary;
mod error;
mod raw;

pub use csv::{ParsedCsv, parse_csv, write_csv, write_csv_with_columns};
pub use error::{FormatError, Quantity, UnitProblem};
pub use raw::{AttitudeConvention, Horizontal, MapPoint, ProjectionError, RawRecord, RawTrajectory};
pub use sbet::{SbetRecord, parse_sbet, raw_to_sbet, sbet_to_raw, write_sbet};
pub use smrmsg::{SmrmsgRecord, parse_smrmsg, raw_to_smrmsg, write_smrmsg};
