//! Rendering benchmark: megapixels per second of panoramas (and their per-pixel truth), depth images and
//! aerial frames of the `tiny` world, on all rayon threads; the time to make a city window. Run with
//! `cargo bench -p plumbline-synth --bench render`.

use std::time::Instant;

use plumbline_geo::camera::{Equirectangular, Pinhole};
use plumbline_geo::dg::{Boresight, CameraMount};
use plumbline_geo::{Attitude, MapFromBody, MapFromCamera, OmegaPhiKappa, Point3};
use plumbline_synth::render::{
    AerialOptics, DepthNoise, Scene, VehicleBody, encode_jpeg, encode_png_gray16, render_aerial, render_depth,
    render_panorama, render_surfaces,
};
use plumbline_synth::world::city::City;
use plumbline_synth::world::{Epoch, Preset, World, WorldConfig};

/// Median wall time of `runs` calls, seconds.
fn time(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn row(what: &str, pixels: u64, seconds: f64) {
    let mp = pixels as f64 / 1e6;
    println!("| {what:<32} | {mp:>6.2} | {seconds:>8.3} | {:>7.2} |", mp / seconds);
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let start = Instant::now();
    let district = World::generate(&WorldConfig::new(Preset::District, 1))?;
    let generated = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let long = district.route(1, 3000.0);
    println!(
        "district world: {} streets, {} buildings, {} poles, {} cars generated in {generated:.3} s; \
         3 km route ({} waypoints) in {:.3} s",
        district.streets.len(),
        district.buildings.len(),
        district.poles.len(),
        district.cars.len(),
        long.waypoints.len(),
        start.elapsed().as_secs_f64()
    );
    let city = City::new(&WorldConfig::new(Preset::City, 1));
    let o = [city.config().origin_east, city.config().origin_north];
    let start = Instant::now();
    let window = city.window_box([o[0] - 370.0, o[1] - 370.0], [o[0] + 370.0, o[1] + 370.0]).world;
    println!(
        "city window 740 m square (a 500 m leg with its margin): {} streets, {} buildings, {} poles in {:.3} s",
        window.streets.len(),
        window.buildings.len(),
        window.poles.len(),
        start.elapsed().as_secs_f64()
    );
    let world = World::generate(&WorldConfig::new(Preset::Tiny, 1))?;
    let route = world.route(1, 300.0);
    let (p, q) = (route.waypoints[30], route.waypoints[31]);
    let heading = (q.east - p.east).atan2(q.north - p.north);
    let body = MapFromBody::new(
        Attitude::new(0.0, 0.0, heading).to_rotation(),
        Point3::new(p.east, p.north, p.ground_height + 1.0),
    );
    let mount = CameraMount::new([0.6, 0.0, -1.9], &Boresight::default());
    let threads = rayon::current_num_threads();
    println!("tiny world, seed 1, {threads} rayon threads, median of 3 runs\n");
    println!("| image                            |     MP |  seconds |    MP/s |");
    println!("|----------------------------------|--------|----------|---------|");
    for (w, h) in [(2048u32, 1024u32), (4096, 2048)] {
        let cam = Equirectangular::new(w, h)?;
        let scene = Scene::mobile(&world);
        let s = time(3, || drop(render_panorama(&scene, &cam, &mount, &body, &VehicleBody::van())));
        row(&format!("panorama {w}x{h} (shadows)"), u64::from(w * h), s);
        let pano = render_panorama(&scene, &cam, &mount, &body, &VehicleBody::van());
        let s = time(3, || drop(encode_jpeg(&pano.image, 90)));
        row(&format!("  jpeg encode {w}x{h}"), u64::from(w * h), s);
        let s = time(3, || drop(render_surfaces(&world, Epoch::Mobile, &cam, &mount, &body, &VehicleBody::van())));
        row(&format!("  per-pixel truth {w}x{h}"), u64::from(w * h), s);
        let truth = render_surfaces(&world, Epoch::Mobile, &cam, &mount, &body, &VehicleBody::van());
        let s = time(3, || drop(encode_png_gray16(&truth.range_mm)));
        row(&format!("  range png encode {w}x{h}"), u64::from(w * h), s);
    }
    let dcam = Pinhole::new(1280, 720, 640.0, 640.0, 640.0, 360.0, 0.0, 0.0)?;
    let dpose = CameraMount::new([0.2, 0.9, -1.0], &Boresight::from_degrees(0.0, 0.0, 90.0)).camera_pose(&body);
    let s = time(3, || drop(render_depth(&world, Epoch::Mobile, &dcam, &dpose, &DepthNoise::realsense(1))));
    row("depth 1280x720", 1280 * 720, s);
    let acam = Pinhole::new(2000, 2000, 8000.0, 8000.0, 1000.0, 1000.0, -1.0, 0.0)?;
    let apose = MapFromCamera::new(
        OmegaPhiKappa::from_degrees(0.5, -0.3, 5.0).to_rotation(),
        Point3::new(p.east, p.north, p.ground_height + 1000.0),
    );
    let scene = Scene::aerial(&world);
    let s = time(3, || drop(render_aerial(&scene, &acam, &apose, &AerialOptics::typical(1))));
    row("aerial 2000x2000 @12.5 cm", 2000 * 2000, s);
    Ok(())
}
