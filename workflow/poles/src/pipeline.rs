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

use crate::cloud::CloudConfig;
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
    /// Point clouds: slicing and the stem detector.
    #[serde(default)]
    pub clouds: CloudConfig,
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
/// length holds a bounded number of frames: a frame is settled once the [`GROUND_WINDOW`] frames after it
/// have arrived (their ground heights vote on its own, [`ground_among_neighbours`]); until then a depth frame
/// is held as its PNG bytes, not as its points (a 1280 × 720 depth image is about 1 MB of PNG and 50 MB of
/// points). Each frame is detected on its own ground estimate as it arrives; when the window keeps that
/// ground (most frames), those detections stand, and otherwise (a car roof or a wall taken for the ground,
/// no ground seen) the frame is decoded again and detected on the window's ground. Only the detections are
/// kept until [`PoleStream::finish`] matches them against the cadastre. The result is the same however the
/// frames are batched, and the same as detecting every frame with all its neighbours' grounds known.
#[derive(Debug)]
pub struct PoleStream {
    config: PoleConfig,
    /// Sensor heights of every frame received, metres (NaN: no points).
    origins_z: Vec<f64>,
    /// Own ground estimates of every frame received.
    own: Vec<Option<f64>>,
    /// Frames received and not yet settled: frames `settled..`.
    waiting: VecDeque<Waiting>,
    settled: usize,
    inputs: Vec<MatchInput>,
    failed: Vec<FrameReport>,
}

/// A frame received and not yet settled.
#[derive(Debug)]
struct Waiting {
    id: String,
    time: f64,
    dg_sigma_m: f64,
    /// Detections on the frame's own ground (`None`: it has none).
    speculative: Option<Result<FrameDetections, String>>,
    /// How to get the points again (or why there are none).
    source: Result<Source, String>,
}

/// Where a waiting frame's points come from when they are needed again.
#[derive(Debug)]
enum Source {
    /// A depth image: decoded again with its camera and DG record.
    Depth { camera: Box<DepthCamera>, png: Vec<u8>, dg: Box<TrajectoryRecord> },
    /// A point-cloud slice, kept as it is.
    Points(FramePoints),
}

impl PoleStream {
    /// An empty stream.
    pub fn new(config: &PoleConfig) -> Self {
        Self {
            config: *config,
            origins_z: Vec::new(),
            own: Vec::new(),
            waiting: VecDeque::new(),
            settled: 0,
            inputs: Vec::new(),
            failed: Vec::new(),
        }
    }

    /// Decode the next depth images of `camera` (in time order, after every frame pushed before), in parallel.
    pub fn push_depth(&mut self, camera: &DepthCamera, frames: &[DepthFrame<'_>]) {
        let mount = depth_mount(camera);
        let config = &self.config.detect;
        let received: Vec<(Waiting, f64, Option<f64>)> = frames
            .par_iter()
            .map(|f| {
                let points = depth_frame_points(camera, &mount, f.id, f.png, f.dg);
                let (origin_z, own, speculative) = speculate(&points, config, f.id);
                let source = points.map(|_| Source::Depth {
                    camera: Box::new(camera.clone()),
                    png: f.png.to_vec(),
                    dg: Box::new(*f.dg),
                });
                let dg_sigma_m = f.dg.std.map_or(DEFAULT_DG_SIGMA_M, |s| s.east.max(s.north));
                (Waiting { id: f.id.to_owned(), time: f.dg.time, dg_sigma_m, speculative, source }, origin_z, own)
            })
            .collect();
        self.receive(received);
    }

    /// Add the next frames of points (in time order, after every frame pushed before); their points are kept
    /// until the frame is settled.
    pub fn push_points(&mut self, frames: Vec<PointFrame>) {
        let config = &self.config.detect;
        let received: Vec<(Waiting, f64, Option<f64>)> = frames
            .into_par_iter()
            .map(|f| {
                let (origin_z, own, speculative) = speculate(&f.points, config, &f.id);
                let source = f.points.map(Source::Points);
                (Waiting { id: f.id, time: f.time, dg_sigma_m: f.dg_sigma_m, speculative, source }, origin_z, own)
            })
            .collect();
        self.receive(received);
    }

    fn receive(&mut self, received: Vec<(Waiting, f64, Option<f64>)>) {
        for (w, origin_z, own) in received {
            self.origins_z.push(origin_z);
            self.own.push(own);
            self.waiting.push_back(w);
        }
        self.settle_up_to(self.own.len().saturating_sub(GROUND_WINDOW));
    }

    /// Frames received and not yet settled (held as PNG bytes or points).
    pub fn held(&self) -> usize {
        self.waiting.len()
    }

    /// Settle the waiting frames before index `end`: keep their speculative detections where the window
    /// keeps their own ground, else detect them again on the window's ground.
    fn settle_up_to(&mut self, end: usize) {
        let count = end.saturating_sub(self.settled).min(self.waiting.len());
        if count == 0 {
            return;
        }
        let grounds: Vec<(Option<f64>, Option<f64>)> = (self.settled..self.settled + count)
            .map(|k| (ground_among_neighbours(k, &self.origins_z, &self.own), self.own[k]))
            .collect();
        let batch: Vec<Waiting> = self.waiting.drain(..count).collect();
        let config = &self.config.detect;
        let settled: Vec<(String, f64, f64, Result<FrameDetections, String>)> = batch
            .into_par_iter()
            .zip(grounds)
            .map(|(w, (ground, own))| {
                let d = match (w.speculative, ground) {
                    (Some(spec), Some(g)) if own == Some(g) => spec,
                    _ => redetect(&w.id, w.source, ground, config),
                };
                (w.id, w.time, w.dg_sigma_m, d)
            })
            .collect();
        for (frame, time, dg_sigma_m, d) in settled {
            match d {
                Ok(detections) => self.inputs.push(MatchInput { frame, time, dg_sigma_m, detections }),
                Err(problem) => self.failed.push(failed_frame(&frame, time, problem)),
            }
        }
        self.settled += count;
    }

    /// Settle the frames still waiting, then match every detection against `cadastre`, compute the updates and
    /// report per frame.
    pub fn finish(mut self, cadastre: &[CadastreFeature]) -> PoleOutput {
        self.settle_up_to(self.own.len());
        let mut output = match_inputs(&self.inputs, cadastre, &self.config);
        output.reports.extend(self.failed);
        output.reports.sort_by(|a, b| time(a).total_cmp(&time(b)));
        output
    }
}

/// Match frames' detections (in time order) against `cadastre`, compute the updates and report per frame: the
/// common end of the depth and point-cloud paths.
pub fn match_inputs(inputs: &[MatchInput], cadastre: &[CadastreFeature], config: &PoleConfig) -> PoleOutput {
    let matched = match_frames(inputs, cadastre, &config.matching);
    let updates = coordinate_updates(inputs, &matched, cadastre, &config.cupt);
    let reports = frame_reports(inputs, &matched, cadastre, &config.cupt);
    PoleOutput { updates, reports }
}

/// A depth image's points in the mapping frame, or why there are none.
fn depth_frame_points(
    camera: &DepthCamera,
    mount: &CameraMount,
    id: &str,
    png: &[u8],
    dg: &TrajectoryRecord,
) -> Result<FramePoints, String> {
    decode_depth_png(id, png, &camera.intrinsics)
        .map(|d| depth_points(&d, &camera.intrinsics, camera.range_error_share, mount, &dg.pose()))
        .map_err(|e| e.to_string())
}

/// A frame's sensor height (NaN without points), own ground estimate, and detections on that ground.
fn speculate(
    points: &Result<FramePoints, String>,
    config: &DetectConfig,
    id: &str,
) -> (f64, Option<f64>, Option<Result<FrameDetections, String>>) {
    let Ok(p) = points else { return (f64::NAN, None, None) };
    let own = estimate_ground(p, config).ok();
    let speculative = own.map(|g| detect_on_ground(p, config, g).map_err(|e| format!("frame {id}: {e}")));
    (p.origin.z, own, speculative)
}

/// Detect a frame on the window's ground (`None`: on its own estimate, which then fails as it did before).
fn redetect(
    id: &str,
    source: Result<Source, String>,
    ground: Option<f64>,
    config: &DetectConfig,
) -> Result<FrameDetections, String> {
    let points = match source? {
        Source::Depth { camera, png, dg } => depth_frame_points(&camera, &depth_mount(&camera), id, &png, &dg)?,
        Source::Points(points) => points,
    };
    match ground {
        Some(g) => detect_on_ground(&points, config, g),
        None => detect(&points, config),
    }
    .map_err(|e| format!("frame {id}: {e}"))
}

fn time(r: &FrameReport) -> f64 {
    match r {
        FrameReport::V1(v) => v.time,
    }
}
