//! The whole pole pipeline of one drive (what `plumbline` calls per tile): depth images or point-cloud
//! slices → detections → matches → coordinate updates + frame reports. One broken frame gives a report with
//! its problem; the others are processed.

use plumbline_adjustment::PoleUpdate;
use plumbline_campaign::CadastreFeature;
use plumbline_campaign::manifest::DepthCamera;
use plumbline_geo::TrajectoryRecord;
use plumbline_geo::dg::{Boresight, CameraMount};
use rayon::prelude::*;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::cupt::{CuptConfig, coordinate_updates};
use crate::depth::{decode_depth_png, depth_points};
use crate::detect::{DetectConfig, detect, detect_on_ground, estimate_ground, ground_from_neighbours};
use crate::matching::{MatchConfig, MatchInput, match_frames};
use crate::points::FramePoints;
use crate::report::{FrameReport, failed_frame, frame_reports};

/// All parameters of the pipeline.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PoleConfig {
    /// Detection.
    #[serde(default)]
    pub detect: DetectConfig,
    /// Matching.
    #[serde(default)]
    pub matching: MatchConfig,
    /// Updates.
    #[serde(default)]
    pub cupt: CuptConfig,
}

/// DG horizontal σ used when a trajectory record carries none, metres.
pub const DEFAULT_DG_SIGMA_M: f64 = 1.0;

/// One depth image of a drive.
#[derive(Clone, Copy, Debug)]
pub struct DepthFrame<'a> {
    /// Image id.
    pub id: &'a str,
    /// The PNG bytes.
    pub png: &'a [u8],
    /// The DG vehicle pose at the image's time (interpolated by the caller), with its σ if known.
    pub dg: &'a TrajectoryRecord,
}

/// One frame of points (a depth image already back-projected, or a point-cloud time slice).
#[derive(Clone, Debug)]
pub struct PointFrame {
    /// Frame id.
    pub id: String,
    /// Epoch, seconds.
    pub time: f64,
    /// Horizontal DG σ per axis, metres.
    pub dg_sigma_m: f64,
    /// The points, or why there are none.
    pub points: Result<FramePoints, String>,
}

/// What the pipeline delivers.
#[derive(Clone, Debug, PartialEq)]
pub struct PoleOutput {
    /// Coordinate updates for the adjustment (`ObservationSetV1::poles`).
    pub updates: Vec<PoleUpdate>,
    /// One report per frame, in time order.
    pub reports: Vec<FrameReport>,
}

/// The camera mount of a manifest's depth camera.
pub fn depth_mount(camera: &DepthCamera) -> CameraMount {
    let [roll, pitch, yaw] = camera.mount.boresight_deg;
    CameraMount::new(camera.mount.lever_arm_m, &Boresight::from_degrees(roll, pitch, yaw))
}

/// Process the depth images of one drive (frames in time order).
pub fn process_depth_frames(
    camera: &DepthCamera,
    frames: &[DepthFrame<'_>],
    cadastre: &[CadastreFeature],
    config: &PoleConfig,
) -> PoleOutput {
    let mount = depth_mount(camera);
    let point_frames = frames
        .par_iter()
        .map(|f| PointFrame {
            id: f.id.to_owned(),
            time: f.dg.time,
            dg_sigma_m: f.dg.std.map_or(DEFAULT_DG_SIGMA_M, |s| s.east.max(s.north)),
            points: decode_depth_png(f.id, f.png, &camera.intrinsics)
                .map(|d| depth_points(&d, &camera.intrinsics, camera.range_error_share, &mount, &f.dg.pose()))
                .map_err(|e| e.to_string()),
        })
        .collect();
    process_point_frames(point_frames, cadastre, config)
}

/// Process frames of points (in time order): detect, match, update, report.
pub fn process_point_frames(frames: Vec<PointFrame>, cadastre: &[CadastreFeature], config: &PoleConfig) -> PoleOutput {
    let own: Vec<Option<f64>> = frames
        .par_iter()
        .map(|f| f.points.as_ref().ok().and_then(|p| estimate_ground(p, &config.detect).ok()))
        .collect();
    let origins: Vec<f64> = frames.iter().map(|f| f.points.as_ref().map_or(f64::NAN, |p| p.origin.z)).collect();
    let grounds = ground_from_neighbours(&origins, &own);
    let detected: Vec<(PointFrame, Result<crate::detect::FrameDetections, String>)> = frames
        .into_par_iter()
        .zip(grounds)
        .map(|(f, ground)| {
            let d = match (&f.points, ground) {
                (Ok(points), Some(g)) => {
                    detect_on_ground(points, &config.detect, g).map_err(|e| format!("frame {}: {e}", f.id))
                }
                (Ok(points), None) => detect(points, &config.detect).map_err(|e| format!("frame {}: {e}", f.id)),
                (Err(problem), _) => Err(problem.clone()),
            };
            (f, d)
        })
        .collect();
    let mut failed = Vec::new();
    let mut inputs = Vec::new();
    for (f, d) in detected {
        match d {
            Ok(detections) => {
                inputs.push(MatchInput { frame: f.id, time: f.time, dg_sigma_m: f.dg_sigma_m, detections })
            }
            Err(problem) => failed.push(failed_frame(&f.id, f.time, problem)),
        }
    }
    let matched = match_frames(&inputs, cadastre, &config.matching);
    let updates = coordinate_updates(&inputs, &matched, cadastre, &config.cupt);
    let mut reports = frame_reports(&inputs, &matched, cadastre, &config.cupt);
    reports.extend(failed);
    reports.sort_by(|a, b| time(a).total_cmp(&time(b)));
    PoleOutput { updates, reports }
}

fn time(r: &FrameReport) -> f64 {
    match r {
        FrameReport::V1(v) => v.time,
    }
}
