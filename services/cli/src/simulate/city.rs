//! The `city` preset: a drive of any length through the unbounded city (`plumbline_synth::world::city`), made
//! and written leg by leg (`CityWalk`, ~500 m each) so memory does not grow with the length. Per leg: the
//! city window around it, the true drive (legs join halfway along a straight street, standing 10 s), the DG
//! solution, GNSS fixes and IMU increments continued from the previous leg (`DgStream`, `GnssStream`,
//! `ImuStream`: fault timeline, drift, fix clock, IMU biases and noise carry over), and the leg's panoramas
//! with their per-pixel truth, depth images and the cadastre objects not yet written. Trajectories, raw data,
//! error series, indexes and truth tables are appended to their files; the cadastre GeoPackage is written at
//! the end from the listed features (~100 bytes each). The aerial frames, orthophoto and terrain tiles near each
//! leg's drive are made with the leg (module `city_aerial`), their VRT mosaics at the end. `overview.png` and
//! `map.png` are drawn leg by leg into grids of bounded size (`StreamedMap`). `--length` is met to within a panorama spacing by cutting the last
//! leg's route (`city_route::cut`); the legs before it are those of any longer campaign of the seed.

use std::collections::HashSet;

use anyhow::Context as _;
use plumbline_geo::camera::{Equirectangular, Pinhole};
use plumbline_geo::formats::{self, RawTrajectory};
use plumbline_synth::cadastre::{self, CadastreErrors};
use plumbline_synth::map::StreamedMap;
use plumbline_synth::motion::dg::{DgConfig, DgSolution, DgStream};
use plumbline_synth::motion::gnss::{GnssConfig, GnssStream};
use plumbline_synth::motion::imu::ImuStream;
use plumbline_synth::motion::{Drive, DriveConfig, files};
use plumbline_synth::render::{DepthNoise, Scene, VehicleBody, encode_jpeg, encode_png_gray16, render_depth};
use plumbline_synth::route::Route;
use plumbline_synth::sensors::{self, Mount, Shot};
use plumbline_synth::texture;
use plumbline_synth::world::city::{City, PoleOwner};
use plumbline_synth::world::city_route::{self, CityWalk, Leg};
use plumbline_synth::world::polyline;
use plumbline_synth::world::{Epoch, Preset, WorldConfig};

use super::city_aerial::CityAerial;
use super::imagery::{self, Sizes};
use super::{Args, OVERVIEW_WIDTH_PX, Sink, imu_grade, manifest, with_profile};
use crate::exit::OrInvalid;
use crate::trajectory::crs;

/// Length of a leg, metres.
const LEG_LENGTH_M: f64 = 500.0;
/// Longest side of the maps' grids, cells (`StreamedMap`: at most 4 bytes each).
const MAP_BUDGET_CELLS: usize = 1600;
/// Drives of the last leg tried while cutting it to the requested length.
const CUT_ATTEMPTS: usize = 4;
/// Standstill where legs join, seconds on each side.
const JOIN_DWELL_S: f64 = 5.0;

/// What the legs so far have made: counts, and what must not be written twice.
#[derive(Default)]
struct Progress {
    driven: f64,
    epochs: usize,
    fixes: usize,
    panoramas: usize,
    written_poles: HashSet<PoleOwner>,
    poles: Vec<cadastre::CadastreObject>,
    /// Keys of the streets whose painted markings are written.
    written_streets: HashSet<u32>,
}

/// Simulate a city campaign of `length` metres and hand its files to `sink`; returns a summary.
pub(crate) fn generate(args: &Args, length: f64, sink: &Sink) -> anyhow::Result<String> {
    let seed = args.seed;
    let realism = args.realism.realism();
    let config = WorldConfig { changes: realism.world, relief: realism.relief, ..WorldConfig::new(Preset::City, seed) };
    let crs = config.epsg;
    let mut walk = CityWalk::new(City::new(&config), seed, LEG_LENGTH_M);
    let (imu_errors, outage_growth) = imu_grade(args.imu);
    let dg_config = DgConfig { outage_growth, ..DgConfig::default() };
    let mut raw = RawStreams {
        dg: DgStream::new(&dg_config, seed).or_invalid("DG error process")?,
        gnss: GnssStream::new(&dg_config, &GnssConfig::default(), seed).or_invalid("GNSS")?,
        imu: ImuStream::new(&imu_errors, seed).or_invalid("IMU")?,
    };
    let sizes = Sizes::of(args)?;
    let mut aerial = (!args.navigation_only)
        .then(|| CityAerial::new(&config, args.aerial_gsd, args.realism.realism().aerial))
        .transpose()?;
    let mut progress = Progress::default();
    let mut maps = Maps::new(args.navigation_only);
    let mut start_time = DriveConfig::default().start_time;
    // Within one panorama spacing of the request: the last leg is cut to what remains (± half a spacing).
    let tolerance = sizes.panorama_spacing / 2.0;
    while length - progress.driven > tolerance {
        let leg = walk.next_leg();
        let first = leg.index == 0;
        let drive_config = DriveConfig {
            start_time,
            start_dwell: if first { DriveConfig::default().start_dwell } else { JOIN_DWELL_S },
            end_dwell: JOIN_DWELL_S,
            ..DriveConfig::default()
        };
        let route = with_profile(leg.route.clone(), args.profile);
        let leg_seed = seed ^ (leg.index as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let drive = drive_leg(&route, &drive_config, leg_seed, (length - progress.driven, tolerance))?;
        let solution = raw.dg.leg(&drive).or_invalid("DG error process")?;
        progress.fixes += write_navigation(&drive, &solution, &mut raw, crs, first, sink)?;
        maps.leg(&leg, &drive, &solution);
        if !args.navigation_only {
            progress.panoramas += write_imagery(&leg, &drive, &solution, &sizes, seed, sink)?;
            write_markings(&leg, &drive, &mut progress, sink)?;
            list_poles(&leg, &mut progress, seed);
            if let Some(aerial) = aerial.as_mut() {
                maps.footprints(&aerial.leg(&drive, sink)?);
            }
        }
        let (_, t1) = drive.trajectory.span();
        start_time = t1 + 1.0 / drive_config.rate_hz;
        progress.driven += drive.kinematics.last().map_or(0.0, |k| k.distance);
        progress.epochs += drive.trajectory.len();
        eprintln!("city leg {}: {:.0} m driven", leg.index, progress.driven);
    }
    let mut sections = manifest::Sections::default();
    if !args.navigation_only {
        sections.panoramas = Some(imagery::panorama_section(&sizes, DriveConfig::default().imu_height));
        sections.depth = Some(imagery::depth_section(&sizes)?);
        sections.cadastre = Some(super::cadastre::write_objects(&progress.poles, crs, sink)?);
        sections.aerial = aerial.as_ref().map(|a| a.finish(sink)).transpose()?;
    }
    maps.write(sink)?;
    let id = format!("synth-city-{seed}");
    sink.put("campaign.toml", manifest::manifest(&id, crs, &sections)?.into_bytes())?;
    let p = &progress;
    Ok(format!("{id}: {:.0} m, {} epochs, {} GNSS fixes, {} panoramas", p.driven, p.epochs, p.fixes, p.panoramas))
}

/// The drive along a leg's route: all of it, or — when that would pass `remaining` metres by more than
/// `tolerance` — the route cut where the drive ends `remaining` ± `tolerance` metres on, standing the usual
/// end dwell of a drive (the cut is corrected for the rounded corners a few times; the closest drive wins).
fn drive_leg(
    route: &Route,
    config: &DriveConfig,
    seed: u64,
    (remaining, tolerance): (f64, f64),
) -> anyhow::Result<Drive> {
    let driven = |d: &Drive| d.kinematics.last().map_or(0.0, |k| k.distance);
    let whole = Drive::simulate(route, config, seed).or_invalid("simulated drive")?;
    if driven(&whole) <= remaining + tolerance {
        return Ok(whole);
    }
    let config = DriveConfig { end_dwell: DriveConfig::default().end_dwell, ..*config };
    let mut at = remaining;
    let mut best = (f64::INFINITY, whole);
    for _ in 0..CUT_ATTEMPTS {
        let drive = Drive::simulate(&city_route::cut(route, at), &config, seed).or_invalid("simulated drive")?;
        let miss = remaining - driven(&drive);
        if miss.abs() < best.0 {
            best = (miss.abs(), drive);
        }
        if miss.abs() <= tolerance {
            break;
        }
        at += miss;
    }
    Ok(best.1)
}

/// `overview.png` (the drive coloured by DG error, standstills) and — with imagery — `map.png` (also the
/// buildings, streets and poles of every leg's window and the aerial frames' footprints), drawn leg by leg in bounded memory (`StreamedMap`).
struct Maps {
    overview: StreamedMap,
    map: Option<StreamedMap>,
}

impl Maps {
    fn new(navigation_only: bool) -> Self {
        let map = (!navigation_only).then(|| StreamedMap::new(MAP_BUDGET_CELLS));
        Self { overview: StreamedMap::new(MAP_BUDGET_CELLS), map }
    }

    fn leg(&mut self, leg: &Leg, drive: &Drive, dg: &DgSolution) {
        self.overview.drive(drive, dg);
        if let Some(map) = self.map.as_mut() {
            map.world(&leg.window.world);
            map.drive(drive, dg);
        }
    }

    /// Draw the ground footprints of aerial frames on the campaign map.
    fn footprints(&mut self, corners: &[[[f64; 2]; 4]]) {
        if let Some(map) = self.map.as_mut() {
            corners.iter().for_each(|c| map.footprint(c));
        }
    }

    fn write(&self, sink: &Sink) -> anyhow::Result<()> {
        sink.put("overview.png", self.overview.png(OVERVIEW_WIDTH_PX).context("overview map")?)?;
        if let Some(map) = &self.map {
            sink.put("map.png", map.png(OVERVIEW_WIDTH_PX).context("campaign map")?)?;
        }
        Ok(())
    }
}

/// The error processes continued from leg to leg: the DG solution and the raw sensor data it comes from.
struct RawStreams {
    dg: DgStream,
    gnss: GnssStream,
    imu: ImuStream,
}

/// Append one leg's trajectories, raw GNSS and IMU, and error series; returns the number of GNSS fixes.
fn write_navigation(
    drive: &Drive,
    dg: &DgSolution,
    raw: &mut RawStreams,
    crs: u32,
    first: bool,
    sink: &Sink,
) -> anyhow::Result<usize> {
    let csv = |bytes: Vec<u8>| if first { bytes } else { without_header(bytes) };
    let geographic = crs::express(&dg.trajectory, crs, 4326).context("DG trajectory to WGS 84")?;
    let sbet = formats::raw_to_sbet(&geographic).context("DG trajectory as SBET")?;
    sink.append("nav/dg.sbet", formats::write_sbet(&sbet))?;
    sink.append("nav/dg.smrmsg", formats::write_smrmsg(&formats::raw_to_smrmsg(&geographic)))?;
    sink.append("nav/dg.csv", csv(formats::write_csv(&RawTrajectory::from_map_projected(dg.trajectory.records()))))?;
    let fixes = raw.gnss.leg(drive, dg).or_invalid("GNSS")?;
    sink.append("nav/gnss.csv", csv(files::gnss_csv(&fixes)))?;
    sink.append("nav/imu.csv", csv(files::imu_csv(&raw.imu.leg(drive))))?;
    let truth = formats::write_csv(&RawTrajectory::from_map_projected(drive.trajectory.records()));
    sink.append("truth/trajectory.csv", csv(truth))?;
    sink.append("truth/dg_errors.csv", csv(files::dg_errors_csv(&dg.errors)))?;
    Ok(fixes.len())
}

/// The bytes after the first line.
fn without_header(bytes: Vec<u8>) -> Vec<u8> {
    let cut = bytes.iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| i + 1);
    bytes[cut..].to_vec()
}

/// Render and append one leg's panoramas (with per-pixel truth) and depth images; returns the panorama count.
fn write_imagery(
    leg: &Leg,
    drive: &Drive,
    dg: &DgSolution,
    sizes: &Sizes,
    seed: u64,
    sink: &Sink,
) -> anyhow::Result<usize> {
    let world = &leg.window.world;
    let first = leg.index == 0;
    let csv = |bytes: Vec<u8>| if first { bytes } else { without_header(bytes) };
    let (w, h) = (sizes.panorama_width, sizes.panorama_width / 2);
    let cam = Equirectangular::new(w, h).context("panorama camera")?;
    let times = sensors::spaced_times(drive, sizes.panorama_spacing)?;
    let shots = sensors::shots(&format!("pano{:04}_", leg.index), &times, &drive.trajectory, &dg.trajectory)?;
    let (scene, mount, vehicle) = (Scene::mobile(world), Mount::PANORAMA.camera_mount(), VehicleBody::van());
    imagery::for_each_in_flight(&shots, |k, shot| {
        let pano = imagery::render_shot(&scene, &cam, shot, &drive.trajectory, &sizes.realism, k);
        sink.put(format!("panoramas/{}.jpg", shot.id), encode_jpeg(&pano.image, sizes.realism.street.jpeg_quality)?)?;
        imagery::pixel_truth(world, &cam, &mount, shot, &vehicle, sink)?;
        if first && k == 0 {
            sink.put("panoramas/vehicle_mask.png", imagery::vehicle_mask_png(&pano)?)?;
        }
        Ok(())
    })?;
    sink.append("panoramas/index.csv", csv(sensors::index_csv(&shots, "jpg")))?;
    sink.append("truth/images.csv", csv(sensors::truth_csv(&shots)))?;
    let panoramas = shots.len();
    let (dw, dh) = sizes.depth;
    let depth_cam: Pinhole = imagery::depth_camera(dw, dh)?;
    let times = sensors::moving_times(drive, sizes.depth_rate)?;
    let shots: Vec<Shot> =
        sensors::shots(&format!("depth{:04}_", leg.index), &times, &drive.trajectory, &dg.trajectory)?;
    let depth_mount = Mount::DEPTH.camera_mount();
    imagery::for_each_in_flight(&shots, |i, shot| {
        let noise = DepthNoise::realsense(seed.wrapping_mul(1_000_003).wrapping_add((leg.index * 100_000 + i) as u64));
        let image =
            render_depth(world, Epoch::Mobile, &depth_cam, &depth_mount.camera_pose(&shot.truth.pose()), &noise);
        sink.put(format!("depth/right/{}.png", shot.id), encode_png_gray16(&image)?)
    })?;
    sink.append("depth/right/index.csv", csv(sensors::index_csv(&shots, "png")))?;
    sink.append("truth/depth_images.csv", csv(sensors::truth_csv(&shots)))?;
    Ok(panoramas)
}

/// How near the leg's drive a street must come for its markings to be written with the leg, metres: the
/// panoramas' reach (`lines compare` counts paint within 10 m of them) plus the widest street's half
/// corridor, with room to spare. Such a street lies well inside the leg's window, whole.
const MARKINGS_NEAR_M: f64 = 40.0;

/// Append to `truth/road_markings.csv` the painted markings of the streets the leg's drive comes within
/// [`MARKINGS_NEAR_M`] of and no earlier leg wrote (a street is the same lattice edge in every window).
fn write_markings(leg: &Leg, drive: &Drive, progress: &mut Progress, sink: &Sink) -> anyhow::Result<()> {
    let first = leg.index == 0;
    let track: Vec<[f64; 2]> = drive
        .trajectory
        .records()
        .iter()
        .map(|r| [r.position.x(), r.position.y()])
        .scan(None::<[f64; 2]>, |last, p| {
            // One position every 2 m of the drive is enough against a 40 m radius.
            let keep = last.is_none_or(|l| (p[0] - l[0]).hypot(p[1] - l[1]) >= 2.0);
            if keep {
                *last = Some(p);
            }
            Some(keep.then_some(p))
        })
        .flatten()
        .collect();
    let world = &leg.window.world;
    let near: HashSet<u32> = world
        .streets
        .iter()
        .filter(|st| !progress.written_streets.contains(&st.key))
        .filter(|st| {
            track.iter().any(|&p| {
                (0..st.points.len().saturating_sub(1)).any(|i| {
                    polyline::station_on_segment(&st.points, &st.cum, i, p).1 <= MARKINGS_NEAR_M * MARKINGS_NEAR_M
                })
            })
        })
        .map(|st| st.key)
        .collect();
    let markings = texture::road_markings_where(world, |st| near.contains(&st.key));
    progress.written_streets.extend(near);
    let bytes = texture::markings_csv(&markings);
    sink.append("truth/road_markings.csv", if first { bytes } else { without_header(bytes) })
}

/// The cadastre entries of the poles of the leg's window not listed yet (errors and defects drawn per leg).
fn list_poles(leg: &Leg, progress: &mut Progress, seed: u64) {
    let world = &leg.window.world;
    let mut batch = Vec::new();
    for (pole, owner) in world.poles.iter().zip(&leg.window.owners) {
        if progress.written_poles.insert(*owner) {
            let mut one = pole.clone();
            one.id = progress.written_poles.len() as u32;
            batch.push(one);
        }
    }
    let leg_seed = seed ^ (leg.index as u64 + 1).wrapping_mul(0xD1B5_4A32_D192_ED03);
    let first_id = progress.poles.iter().filter_map(|o| o.cadastre_id).max().unwrap_or(0) + 1;
    progress.poles.extend(cadastre::cadastre_of(&batch, &CadastreErrors::typical(), leg_seed, first_id));
}
