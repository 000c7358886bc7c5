//! Street-level imagery of a simulated campaign: panoramas and depth images along the drive, rendered with
//! the TRUE vehicle pose (the DG pose at the same time goes to the truth tables), with their index files.

use anyhow::Context as _;
use image::GrayImage;
use plumbline_geo::camera::{Equirectangular, Pinhole};
use plumbline_synth::motion::dg::DgSolution;
use plumbline_synth::motion::{Drive, DriveConfig};
use plumbline_synth::render::{
    DepthNoise, Panorama, Realism, Scene, VehicleBody, encode_jpeg, encode_png_gray, encode_png_gray16, render_depth,
    render_panorama_with, render_surfaces,
};
use plumbline_synth::sensors::Shot;
use plumbline_synth::sensors::{self, Mount};
use plumbline_synth::world::{Epoch, World};
use rayon::prelude::*;

use super::manifest::mount;
use super::{Args, Preset, Sink};
use crate::exit::invalid;

/// Image sizes and rates of the street-level sensors.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sizes {
    /// Panorama width (height = width / 2), pixels.
    pub panorama_width: u32,
    /// Distance driven between panoramas, metres.
    pub panorama_spacing: f64,
    /// Depth image width and height, pixels.
    pub depth: (u32, u32),
    /// Depth frames per second while moving.
    pub depth_rate: f64,
    /// What the street rig and the aerial camera add to the images.
    pub realism: Realism,
}

impl Sizes {
    /// The preset's sizes with the command line's overrides.
    pub(crate) fn of(args: &Args) -> anyhow::Result<Self> {
        let (width, spacing, depth, rate) = match args.preset {
            Preset::Tiny => (1024, 5.0, (320, 180), 1.0),
            Preset::District | Preset::City => (4096, 5.0, (1280, 720), 5.0),
        };
        let panorama_spacing = args.panorama_spacing.unwrap_or(spacing);
        let panorama_width = args.panorama_width.unwrap_or(width);
        if !(64..=16_384).contains(&panorama_width) || !panorama_width.is_multiple_of(2) {
            return Err(invalid(format!("--panorama-width {panorama_width}: expected an even width 64–16384")));
        }
        if !(panorama_spacing.is_finite() && panorama_spacing >= 0.5) {
            return Err(invalid(format!("--panorama-spacing {panorama_spacing}: expected ≥ 0.5 m")));
        }
        let depth_rate = args.depth_rate.unwrap_or(rate);
        if !(depth_rate.is_finite() && depth_rate > 0.0 && depth_rate <= 60.0) {
            return Err(invalid(format!("--depth-rate {depth_rate}: expected 0–60 Hz")));
        }
        Ok(Self { panorama_width, panorama_spacing, depth, depth_rate, realism: args.realism.realism() })
    }
}

/// Render and hand over the panoramas, their index, the vehicle mask and `truth/images.csv`; returns the
/// manifest's `[panoramas]`.
pub(crate) fn panoramas(
    world: &World,
    drive: &Drive,
    drive_config: &DriveConfig,
    dg: &DgSolution,
    sizes: &Sizes,
    sink: &Sink,
) -> anyhow::Result<String> {
    let (w, h) = (sizes.panorama_width, sizes.panorama_width / 2);
    let cam = Equirectangular::new(w, h).context("panorama camera")?;
    let times = sensors::spaced_times(drive, sizes.panorama_spacing)?;
    let shots = sensors::shots("pano", &times, &drive.trajectory, &dg.trajectory)?;
    let (scene, mount_, vehicle) = (Scene::mobile(world), Mount::PANORAMA.camera_mount(), VehicleBody::van());
    for_each_in_flight(&shots, |i, shot| {
        let pano = render_shot(&scene, &cam, shot, &drive.trajectory, &sizes.realism, i);
        let quality = sizes.realism.street.jpeg_quality;
        let jpeg = encode_jpeg(&pano.image, quality).with_context(|| format!("panorama {}", shot.id))?;
        sink.put(format!("panoramas/{}.jpg", shot.id), jpeg)?;
        pixel_truth(world, &cam, &mount_, shot, &vehicle, sink)?;
        if i == 0 {
            sink.put("panoramas/vehicle_mask.png", vehicle_mask_png(&pano)?)?;
        }
        Ok(())
    })?;
    sink.put("panoramas/index.csv", sensors::index_csv(&shots, "jpg"))?;
    sink.put("truth/images.csv", sensors::truth_csv(&shots))?;
    Ok(panorama_section(sizes, drive_config.imu_height))
}

/// The panorama of `shot` (the `index`th) as the rig of `realism` sees it while the vehicle drives `truth`.
pub(crate) fn render_shot(
    scene: &Scene,
    cam: &Equirectangular,
    shot: &Shot,
    truth: &plumbline_geo::Trajectory,
    realism: &Realism,
    index: usize,
) -> Panorama {
    let velocity = sensors::velocity(truth, shot.time);
    let (mount, body) = (Mount::PANORAMA.camera_mount(), shot.truth.pose());
    let seed = 0x9E37_79B9_u64.wrapping_mul(index as u64 + 1);
    render_panorama_with(scene, cam, &mount, &body, &VehicleBody::van(), &velocity, realism, seed)
}

/// Run `f` on every item (with its index), as many items at once as rayon has threads: rendering is parallel
/// inside an item, but its encoding is not, so a second item renders while the first encodes. Whole chunks
/// keep memory at that many images. The first error stops the run; files go out in no fixed order.
pub(crate) fn for_each_in_flight<T: Sync>(
    items: &[T],
    f: impl Fn(usize, &T) -> anyhow::Result<()> + Sync,
) -> anyhow::Result<()> {
    let in_flight = rayon::current_num_threads().max(1);
    items
        .chunks(in_flight)
        .enumerate()
        .try_for_each(|(c, chunk)| chunk.par_iter().enumerate().try_for_each(|(k, item)| f(c * in_flight + k, item)))
}

/// The manifest's `[panoramas]` for the IMU `imu_height` above the road, with the ring of cameras the
/// panoramas were rendered through when the realism level has one (as a real rig's calibration gives it),
/// and its rolling shutter's readout time.
pub(crate) fn panorama_section(sizes: &Sizes, imu_height: f64) -> String {
    let (w, h) = (sizes.panorama_width, sizes.panorama_width / 2);
    // The IMU rides `imu_height` above the road; the lever arm's z points down.
    let camera_height = imu_height - Mount::PANORAMA.lever_arm_m[2];
    let rig = sizes.realism.rig;
    let readout = if rig.readout_s > 0.0 { format!("readout_s = {:?}\n", rig.readout_s) } else { String::new() };
    let ring = if rig.sub_cameras > 1 {
        format!("\n[panoramas.rig]\ncameras = {}\nradius_m = {:?}\n", rig.sub_cameras, rig.radius_m)
    } else {
        String::new()
    };
    format!(
        "[panoramas]\nindex = \"panoramas/index.csv\"\nimages = \"panoramas/\"\nwidth_px = {w}\nheight_px = {h}\n\
         vehicle_mask = \"panoramas/vehicle_mask.png\"\ncamera_height_m = {camera_height:?}\n{readout}{}{ring}",
        mount("panoramas", &Mount::PANORAMA)
    )
}

/// The manifest's vehicle mask (non-zero = vehicle; the renderer's mask has 255 = scene) as PNG.
pub(crate) fn vehicle_mask_png(pano: &Panorama) -> anyhow::Result<Vec<u8>> {
    let (w, h) = pano.mask.dimensions();
    let vehicle_mask = GrayImage::from_fn(w, h, |x, y| image::Luma([255 - pano.mask.get_pixel(x, y)[0]]));
    encode_png_gray(&vehicle_mask).context("vehicle mask")
}

/// `truth/pixels/{id}_range.png` (16-bit, millimetres along the pixel-centre ray, 0 = nothing stored) and
/// `truth/pixels/{id}_class.png` (`plumbline_synth::render::SurfaceClass` codes) of one panorama.
pub(crate) fn pixel_truth(
    world: &World,
    cam: &Equirectangular,
    mount: &plumbline_geo::dg::CameraMount,
    shot: &Shot,
    vehicle: &VehicleBody,
    sink: &Sink,
) -> anyhow::Result<()> {
    let truth = render_surfaces(world, Epoch::Mobile, cam, mount, &shot.truth.pose(), vehicle);
    let range = encode_png_gray16(&truth.range_mm).with_context(|| format!("range truth of {}", shot.id))?;
    sink.put(format!("truth/pixels/{}_range.png", shot.id), range)?;
    let class = encode_png_gray(&truth.class).with_context(|| format!("class truth of {}", shot.id))?;
    sink.put(format!("truth/pixels/{}_class.png", shot.id), class)
}

/// The depth camera: the field of view of Meyer et al. 2023 §3.1.2 (fx = width / 2, ≈ 90° horizontally).
pub(crate) fn depth_camera(width: u32, height: u32) -> anyhow::Result<Pinhole> {
    let f = f64::from(width) / 2.0;
    Pinhole::new(width, height, f, f, f64::from(width) / 2.0, f64::from(height) / 2.0, 0.0, 0.0).context("depth camera")
}

/// Render and hand over the depth images, their index and `truth/depth_images.csv`; returns `[[depth]]`.
pub(crate) fn depth(
    world: &World,
    drive: &Drive,
    dg: &DgSolution,
    sizes: &Sizes,
    seed: u64,
    sink: &Sink,
) -> anyhow::Result<String> {
    let (w, h) = sizes.depth;
    let cam = depth_camera(w, h)?;
    let times = sensors::moving_times(drive, sizes.depth_rate)?;
    let shots = sensors::shots("depth", &times, &drive.trajectory, &dg.trajectory)?;
    let camera_mount = Mount::DEPTH.camera_mount();
    for_each_in_flight(&shots, |i, shot| {
        let noise = DepthNoise::realsense(seed.wrapping_mul(1_000_003).wrapping_add(i as u64));
        let pose = camera_mount.camera_pose(&shot.truth.pose());
        let image = render_depth(world, Epoch::Mobile, &cam, &pose, &noise);
        let png = encode_png_gray16(&image).with_context(|| format!("depth image {}", shot.id))?;
        sink.put(format!("depth/right/{}.png", shot.id), png)
    })?;
    sink.put("depth/right/index.csv", sensors::index_csv(&shots, "png"))?;
    sink.put("truth/depth_images.csv", sensors::truth_csv(&shots))?;
    depth_section(sizes)
}

/// The manifest's `[[depth]]`.
pub(crate) fn depth_section(sizes: &Sizes) -> anyhow::Result<String> {
    let (w, h) = sizes.depth;
    let cam = depth_camera(w, h)?;
    let noise = DepthNoise::realsense(0);
    Ok(format!(
        "[[depth]]\nindex = \"depth/right/index.csv\"\nimages = \"depth/right/\"\nrange_error_share = {:?}\n\n\
         [depth.intrinsics]\nfx = {:?}\nfy = {:?}\ncx = {:?}\ncy = {:?}\nwidth_px = {w}\nheight_px = {h}\n\
         depth_scale_m = 0.001\nmin_range_m = {:?}\nmax_range_m = {:?}\n{}",
        noise.share,
        cam.fx,
        cam.fy,
        cam.cx,
        cam.cy,
        noise.min,
        noise.max,
        mount("depth", &Mount::DEPTH)
    ))
}
