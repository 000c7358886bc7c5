//! The whole pole pipeline of one drive (what `plumbline` calls per tile): depth images or point-cloud
//! slices → detections → matches → coordinate updates + frame reports. One broken frame gives a report with
//! its problem; the others are processed.

use std::collections::VecDeque;

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
use crate::detect::{
    DetectConfig, FrameDetections, GROUND_WINDOW, detect, detect_on_ground, estimate_ground, ground_among_neighbours,
};
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

/// Process the depth images of one drive (frames in time order), all at once: [`PoleStream`] with one push.
pub fn process_depth_frames(
    camera: &DepthCamera,
    frames: &[DepthFrame<'_>],
    cadastre: &[CadastreFeature],
    config: &PoleConfig,
) -> PoleOutput {
    let mut stream = PoleStream::new(config);
    stream.push_depth(camera, frames);
    stream.finish(cadastre)
}

/// Process frames of points (in time order): detect, match, update, report; [`PoleStream`] with one push.
pub fn process_point_frames(frames: Vec<PointFrame>, cadastre: &[CadastreFeature], config: &PoleConfig) -> PoleOutput {
    let mut stream = PoleStream::new(config);
    stream.push_points(frames);
    stream.finish(cadastre)
}

/// The pole pipeline of one drive fed a batch of frames at a time, in time order, so that a drive of any
/// length holds the points of a bounded number of frames: a frame's points are dropped once it is detected,
/// which happens as soon as the [`GROUND_WINDOW`] frames after it have arrived (their ground heights vote on
/// its own, [`ground_among_neighbours`]). Only the detections (a few per frame) are kept until
/// [`PoleStream::finish`] matches them against the cadastre. The result is the same however the frames are
/// batched.
#[derive(Debug)]
pub struct PoleStream {
    config: PoleConfig,
    /// Sensor heights of every frame received, metres (NaN: no points).
    origins_z: Vec<f64>,
    /// Own ground estimates of every frame received.
    own: Vec<Option<f64>>,
    /// Frames received and not yet detected: frames `detected..`.
    waiting: VecDeque<PointFrame>,
    detected: usize,
    inputs: Vec<MatchInput>,
    failed: Vec<FrameReport>,
}

impl PoleStream {
    /// An empty stream.
    pub fn new(config: &PoleConfig) -> Self {
        Self {
            config: *config,
            origins_z: Vec::new(),
            own: Vec::new(),
            waiting: VecDeque::new(),
            detected: 0,
            inputs: Vec::new(),
            failed: Vec::new(),
        }
    }

    /// Decode the next depth images of `camera` (in time order, after every frame pushed before), in parallel.
    pub fn push_depth(&mut self, camera: &DepthCamera, frames: &[DepthFrame<'_>]) {
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
        self.push_points(point_frames);
    }

    /// Add the next frames of points (in time order, after every frame pushed before) and detect every frame
    /// whose ground window is now complete.
    pub fn push_points(&mut self, frames: Vec<PointFrame>) {
        let detect = &self.config.detect;
        let own: Vec<Option<f64>> =
            frames.par_iter().map(|f| f.points.as_ref().ok().and_then(|p| estimate_ground(p, detect).ok())).collect();
        for (f, g) in frames.into_iter().zip(own) {
            self.origins_z.push(f.points.as_ref().map_or(f64::NAN, |p| p.origin.z));
            self.own.push(g);
            self.waiting.push_back(f);
        }
        self.detect_up_to(self.own.len().saturating_sub(GROUND_WINDOW));
    }

    /// Frames whose points the stream holds now.
    pub fn held(&self) -> usize {
        self.waiting.len()
    }

    /// Detect the waiting frames before index `end`.
    fn detect_up_to(&mut self, end: usize) {
        let count = end.saturating_sub(self.detected).min(self.waiting.len());
        if count == 0 {
            return;
        }
        let grounds: Vec<Option<f64>> = (self.detected..self.detected + count)
            .map(|k| ground_among_neighbours(k, &self.origins_z, &self.own))
            .collect();
        let batch: Vec<PointFrame> = self.waiting.drain(..count).collect();
        let config = &self.config.detect;
        let detected: Vec<(PointFrame, Result<FrameDetections, String>)> = batch
            .into_par_iter()
            .zip(grounds)
            .map(|(f, ground)| {
                let d = match (&f.points, ground) {
                    (Ok(points), Some(g)) => {
                        detect_on_ground(points, config, g).map_err(|e| format!("frame {}: {e}", f.id))
                    }
                    (Ok(points), None) => detect(points, config).map_err(|e| format!("frame {}: {e}", f.id)),
                    (Err(problem), _) => Err(problem.clone()),
                };
                (f, d)
            })
            .collect();
        for (f, d) in detected {
            match d {
                Ok(detections) => {
                    self.inputs.push(MatchInput { frame: f.id, time: f.time, dg_sigma_m: f.dg_sigma_m, detections })
                }
                Err(problem) => self.failed.push(failed_frame(&f.id, f.time, problem)),
            }
        }
        self.detected += count;
    }

    /// Detect the frames still waiting, then match every detection against `cadastre`, compute the updates and
    /// report per frame.
    pub fn finish(mut self, cadastre: &[CadastreFeature]) -> PoleOutput {
        self.detect_up_to(self.own.len());
        let matched = match_frames(&self.inputs, cadastre, &self.config.matching);
        let updates = coordinate_updates(&self.inputs, &matched, cadastre, &self.config.cupt);
        let mut reports = frame_reports(&self.inputs, &matched, cadastre, &self.config.cupt);
        reports.extend(self.failed);
        reports.sort_by(|a, b| time(a).total_cmp(&time(b)));
        PoleOutput { updates, reports }
    }
}

fn time(r: &FrameReport) -> f64 {
    match r {
        FrameReport::V1(v) => v.time,
    }
}
