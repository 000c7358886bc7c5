//! Pole-like objects from cadastres as control (Meyer et al. 2023): detection in depth images and point clouds,
//! matching to the cadastre, and coordinate updates (CUPTs) for the adjustment.
//!
//! Synchronous and I/O-free; rayon parallelism inside. The pipeline of one drive:
//! 1. [`depth::decode_depth_png`] + [`depth::depth_points`] (or [`las::read_las`] + [`points::FramePoints`])
//!    put the measurements into the mapping frame through the DG pose;
//! 2. [`detect::detect`] finds vertical structures per frame;
//! 3. [`matching::match_frames`] associates them with the cadastre (one common offset per frame, tracks over
//!    consecutive frames, ambiguities rejected, never forced; [`matching::MatchInput`] per frame);
//! 4. [`cupt::coordinate_updates`] turns the matches into `plumbline_adjustment::PoleUpdate`s and
//!    [`report::frame_reports`] into the versioned per-frame diagnostics.
//!
//! [`pipeline::process_depth_frames`] runs all of it for a drive's depth images; [`pipeline::PoleStream`] does
//! the same fed a batch of frames at a time, holding the points of a bounded number of frames (the worker's
//! way through a tile of any length).
//! [`las_header::parse_las_header`] checks a point cloud's header from its first bytes, without the points.
//! [`copc::CopcIndex`] reads a COPC file's octree nodes, checked against the file, only those a caller selects.
//! [`stems::StemDetector`] finds poles and trunks in a static cloud (no trajectory, time or scanner needed),
//! fed by [`las::stream_las_xyz`]: `plumbline poles detect`.

pub mod cloud;
pub mod copc;
pub mod cupt;
pub mod depth;
pub mod detect;
pub mod las;
pub mod las_header;
pub mod matching;
pub mod pipeline;
pub mod points;
pub mod report;
pub mod stems;

pub use cloud::{CloudConfig, CloudCounts, CloudSlicer, Pass, PassIndex, ScannerTrack, untimed_inputs};
pub use copc::{CopcIndex, CopcNode, encode_copc};
pub use cupt::{CuptConfig, coordinate_updates};
pub use depth::{DepthError, DepthImage, decode_depth_png, depth_points};
pub use detect::{
    DetectConfig, DetectError, Detection, FrameDetections, GROUND_WINDOW, ViewSector, detect, detect_on_ground,
    estimate_ground, ground_among_neighbours, ground_from_neighbours,
};
pub use las::{
    CloudSlicing, LasEncoding, LasError, LasPoint, LasPoints, cloud_frames, encode_las, read_las, stream_las_points,
    stream_las_points_from, stream_las_xyz, stream_las_xyz_from,
};
pub use las_header::{LAS_PREFIX_BYTES, LasCrs, LasHeader, LasHeaderError, parse_las_header};
pub use matching::{Match, MatchConfig, MatchInput, MatchedFrame, Unmatched, UnmatchedReason, match_frames};
pub use pipeline::{
    DepthFrame, PointFrame, PoleConfig, PoleOutput, PoleStream, match_inputs, process_depth_frames,
    process_point_frames,
};
pub use points::{FramePoint, FramePoints};
pub use report::{FrameReport, FrameReportV1, failed_frame, frame_reports};
pub use stems::{
    Candidate, Stem, StemClass, StemConfig, StemDetector, StemFit, Tiling, merge_stems, surroundings_cells,
};
