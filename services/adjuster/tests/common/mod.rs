//! A seeded synthetic campaign for the adjuster's tests: a drive through the `tiny` world with the DG errors
//! of a deep street canyon, observations simulated from the truth (`plumbline_synth::observations`) packed
//! into tile outputs the way workers deliver them, and a `Campaign` around the DG trajectory.
#![allow(dead_code, clippy::unwrap_used)]

use std::f64::consts::TAU;

use plumbline_adjustment::{AerialPoint, PoleUpdate, TiePoint, TiePointId, TieRay};
use plumbline_campaign::Manifest;
use plumbline_campaign::plan::plan_campaign;
use plumbline_campaign::tables::IndexRow;
use plumbline_geo::angle::wrap;
use plumbline_geo::formats::Horizontal;
use plumbline_geo::tiling::{TileId, TilingParams};
use plumbline_geo::{PositionInterpolation, Trajectory};
use plumbline_navigation::ImageMotion;
use plumbline_registration::TileResultV1;
use plumbline_registration::output::{DiscardReason, ImageDiagnostic, TileSummary};
use plumbline_runtime::trajectory::{LoadedTrajectory, TrajectoryFormat};
use plumbline_scheduler::{Campaign, SkippedInput};
use plumbline_synth::cadastre::{CadastreErrors, cadastre};
use plumbline_synth::motion::dg::{self, DgConfig};
use plumbline_synth::motion::routes::DEEP_CANYON;
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::observations::{ObservationConfig, pole_updates, tie_points};
use plumbline_synth::sensors::{Mount, spaced_times};
use plumbline_synth::world::{Preset, World, WorldConfig};
use plumbline_worker::TileOutputV1;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The campaign CRS of the tests.
pub const EPSG: u32 = 25832;

/// Panoramas per tile.
pub const PER_TILE: usize = 40;

/// Every this many panoramas one is discarded by the registration (no neighbour), its ties left out.
pub const DISCARD_EVERY: usize = 10;

/// A simulated campaign.
pub struct Scenario {
    pub truth: Trajectory,
    pub dg: Trajectory,
    pub panoramas: Vec<(String, f64)>,
    /// The motion from each panorama to the next as the images measure it (none for the last).
    pub motions: Vec<ImageMotion>,
    pub ties: Vec<TiePoint>,
    pub poles: Vec<PoleUpdate>,
}

/// Drive ~600 m of the tiny world at 10 Hz with deep-canyon DG errors; simulate poles and ties from truth.
pub fn scenario(seed: u64) -> Scenario {
    scenario_of(Preset::Tiny, 600.0, 10.0, seed)
}

/// Drive about `length_m` through a `preset` world at `rate_hz` with deep-canyon DG errors; simulate poles
/// and ties from truth.
pub fn scenario_of(preset: Preset, length_m: f64, rate_hz: f64, seed: u64) -> Scenario {
    let world = World::generate(&WorldConfig::new(preset, seed)).unwrap();
    let mut route = world.route(seed, length_m);
    for w in &mut route.waypoints {
        w.canyon = DEEP_CANYON;
    }
    let drive = Drive::simulate(&route, &DriveConfig { rate_hz, ..DriveConfig::default() }, seed).unwrap();
    let dg = dg::simulate(&drive, &DgConfig::default(), seed).unwrap().trajectory;
    let config = ObservationConfig::default();
    let objects = cadastre(&world, &CadastreErrors::typical(), seed);
    let poles = pole_updates(&drive, &dg, &objects, &config, seed)
        .unwrap()
        .into_iter()
        .map(|p| PoleUpdate {
            cadastre_id: format!("poles:{}", p.cadastre_id),
            time: p.time,
            cadastre: p.cadastre,
            observed: p.observed,
            sigma_camera: p.sigma_camera,
            sigma_pole: p.sigma_pole,
        })
        .collect();
    let times = spaced_times(&drive, config.panorama_spacing).unwrap();
    let panoramas = times.iter().enumerate().map(|(i, t)| (format!("pano-{i:05}"), *t)).collect();
    let ties = tie_points(&drive, &Mount::PANORAMA.camera_mount(), &config, seed)
        .unwrap()
        .into_iter()
        .map(|t| TiePoint {
            id: TiePointId(t.id),
            rays: t.rays.iter().map(|r| TieRay::new(r.time, r.direction, r.sigma)).collect(),
            aerial: Some(AerialPoint { position: t.aerial.0, covariance: t.aerial.1 }),
        })
        .collect();
    let motions = image_motions(&drive.trajectory, &times, seed);
    Scenario { truth: drive.trajectory, dg, panoramas, motions, ties, poles }
}

/// Image-motion σ of consecutive panoramas: east, north (m), heading (rad) (Jende et al. 2017 §3.3 at 3 cm GSD).
pub const IMAGE_STD: [f64; 3] = [0.02, 0.02, 1e-3];

/// Motions between consecutive panoramas measured from the truth with [`IMAGE_STD`] noise.
fn image_motions(truth: &Trajectory, times: &[f64], seed: u64) -> Vec<ImageMotion> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let at = |t: f64| truth.interpolate(t, PositionInterpolation::Cubic).unwrap();
    times
        .windows(2)
        .map(|w| {
            let (a, b) = (at(w[0]), at(w[1]));
            let d = b.position - a.position;
            let turn = wrap(b.attitude.heading - a.attitude.heading);
            let mut g = || gauss(&mut rng);
            ImageMotion {
                start: w[0],
                end: w[1],
                displacement: [d.x() + IMAGE_STD[0] * g(), d.y() + IMAGE_STD[1] * g()],
                heading_change: turn + IMAGE_STD[2] * g(),
                std: IMAGE_STD,
            }
        })
        .collect()
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
}

/// A panorama's diagnostic (built through serde so fields added later with defaults do not break it).
pub fn diagnostic(
    image: &str,
    time: f64,
    discarded: Option<DiscardReason>,
    motion: Option<ImageMotion>,
) -> ImageDiagnostic {
    serde_json::from_value(serde_json::json!({
        "image": image,
        "time": time,
        "neighbour": null,
        "transform": null,
        "corners": {"detected": 0, "candidates": 0, "matched": 0, "triangulated": 0, "rejected_geometry": 0,
                    "rejected_miss": 0, "rejected_off_ground": 0},
        "aerial_images": aerial_images(time, discarded.is_none()),
        "aerial_points": if discarded.is_none() { 4 } else { 0 },
        "discarded": discarded,
        "motion": motion,
    }))
    .unwrap()
}

/// Seconds of drive whose panoramas are matched in the same pair of aerial frames.
pub const FRAME_SPAN: f64 = 20.0;

/// The aerial frames a panorama at `time` overlaps: `aerial{n}` and `aerial{n+1}`, n = time / FRAME_SPAN;
/// both gave correspondences when it was matched, neither when not.
fn aerial_images(time: f64, matched: bool) -> serde_json::Value {
    let n = (time / FRAME_SPAN).floor() as i64;
    let frame = |k: i64| {
        serde_json::json!({"frame": format!("aerial{k:04}"), "passed": matched, "rejection": null,
            "initial_inliers": 20, "fallback_ncc": null, "offset_m": 0.1, "candidates": 20, "matched": 12,
            "correspondences": if matched { 10 } else { 0 }})
    };
    serde_json::json!([frame(n), frame(n + 1)])
}

/// Index of the panorama a tie starts at (`tie-{i:06}-{k}`).
fn tie_panorama(tie: &TiePoint) -> usize {
    tie.id.0[4..10].parse().unwrap()
}

/// Tiles of [`PER_TILE`] panoramas each: their ties (those of discarded panoramas left out), diagnostics,
/// and the pole updates whose epoch falls between the tile's first panorama and the next tile's.
pub fn tiles(s: &Scenario, poles: &[PoleUpdate]) -> Vec<TileOutputV1> {
    let chunks: Vec<&[(String, f64)]> = s.panoramas.chunks(PER_TILE).collect();
    let mut out = Vec::new();
    for (c, chunk) in chunks.iter().enumerate() {
        let first = c * PER_TILE;
        let tile = TileId { col: c as i64, row: 0 };
        let discarded = |i: usize| i % DISCARD_EVERY == DISCARD_EVERY - 1;
        let images: Vec<ImageDiagnostic> = chunk
            .iter()
            .enumerate()
            .map(|(k, (id, t))| {
                let why = discarded(first + k).then_some(DiscardReason::NoNeighbour { nearest_m: Some(20.0) });
                diagnostic(id, *t, why, s.motions.get(first + k).copied())
            })
            .collect();
        let ties: Vec<TiePoint> = s
            .ties
            .iter()
            .filter(|t| (first..first + chunk.len()).contains(&tie_panorama(t)) && !discarded(tie_panorama(t)))
            .cloned()
            .collect();
        let start = if c == 0 { f64::NEG_INFINITY } else { chunk[0].1 };
        let end = chunks.get(c + 1).map_or(f64::INFINITY, |n| n[0].1);
        let summary = TileSummary::of(&images, &ties);
        out.push(TileOutputV1 {
            tile,
            registration: Some(TileResultV1 { tile, ties, images, summary }),
            poles: poles.iter().filter(|p| p.time >= start && p.time < end).cloned().collect(),
            pole_frames: Vec::new(),
            skipped: vec![SkippedInput {
                stage: "poles".into(),
                item: format!("depth-{c}"),
                reason: "decode".into(),
                detail: format!("depth-{c}.png: not a PNG"),
            }],
            seconds: vec![("registration".into(), 1.5), ("poles".into(), 0.5)],
            fingerprint: None,
        })
    }
    out
}

/// The index of the best-measured street light's update: the one a test makes 1 m wrong.
pub fn best_light(poles: &[PoleUpdate]) -> usize {
    (0..poles.len())
        .filter(|&i| poles[i].sigma_pole < 0.2)
        .min_by(|&a, &b| poles[a].sigma_camera.total_cmp(&poles[b].sigma_camera))
        .unwrap()
}

/// A campaign around the scenario's DG trajectory (a projected CSV in [`EPSG`]), the truth as the
/// reference, writing under `output` (a directory path ending in `/`).
pub fn campaign(s: &Scenario, output: &str) -> Campaign {
    let p = Mount::PANORAMA;
    let toml = format!(
        "version = \"1\"\ncrs = {EPSG}\noutput = \"{output}\"\n[campaign]\nid = \"adjuster-test\"\nname = \"test\"\n\
         [[trajectory]]\nformat = \"csv\"\nurl = \"dg.csv\"\nreference = \"truth.csv\"\n\
         [panoramas]\nindex = \"panoramas/index.csv\"\nimages = \"panoramas/\"\n\
         [panoramas.mount]\nlever_arm_m = {:?}\nboresight_deg = {:?}\n",
        p.lever_arm_m, p.boresight_deg
    );
    let manifest = Manifest::from_toml_str(&toml).unwrap().into_latest();
    let rows: Vec<IndexRow> = s
        .panoramas
        .iter()
        .map(|(id, t)| IndexRow { image_id: id.clone(), time: *t, file: format!("{id}.jpg") })
        .collect();
    let plan = plan_campaign(&rows, &[], &s.dg, &TilingParams::new(200.0, 20.0)).unwrap();
    let trajectory = LoadedTrajectory {
        trajectory: s.dg.clone(),
        format: TrajectoryFormat::Csv,
        horizontal: Horizontal::Projected,
        epsg: Some(EPSG),
        name: "dg.csv".into(),
    };
    Campaign {
        base: format!("file://{output}campaign.toml"),
        manifest,
        output: output.to_owned(),
        trajectory,
        reference: Some(s.truth.clone()),
        aerial_frames: Vec::new(),
        plan,
        skipped: Vec::new(),
    }
}
