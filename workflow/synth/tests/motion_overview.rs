//! The overview map: track where it belongs, coloured by the DG error, standstills marked.
#![allow(clippy::unwrap_used)]

use plumbline_synth::motion::dg::{self, DgConfig};
use plumbline_synth::motion::routes::{self, DEEP_CANYON};
use plumbline_synth::motion::{Drive, DriveConfig, overview_png};

#[test]
fn overview_shows_the_track_coloured_by_error_and_the_stops() {
    for seed in 1..=4 {
        check(seed);
    }
}

fn check(seed: u64) {
    let config = DriveConfig { rate_hz: 50.0, stop_probability: 1.0, ..DriveConfig::default() };
    let route = routes::block_loop((1000.0, 5000.0), 400.0, 300.0, 1, DEEP_CANYON);
    let drive = Drive::simulate(&route, &config, seed).unwrap();
    let dg = dg::simulate(&drive, &DgConfig::default(), seed).unwrap();
    let png = overview_png(&drive, &dg, 800).unwrap();
    let img = image::load_from_memory(&png).unwrap().to_rgb8();
    assert_eq!(img.width(), 800);
    // 400 × 300 m with a 10 % margin, north up: 800 px per 440 m, height 330 m.
    assert_eq!(img.height(), (330.0f64 * 800.0 / 440.0).ceil() as u32);
    let px = |e: f64, n: f64| {
        let s = 800.0 / 440.0;
        let (u, v) = (400.0 + (e - 1200.0) * s, f64::from(img.height()) / 2.0 - (n - 5150.0) * s);
        *img.get_pixel(u as u32, v as u32)
    };
    assert_eq!(px(1200.0, 5150.0).0, [255, 255, 255], "the block's inside is empty");
    // Every standstill (start, four corners' stop lines, end) is a black square on the track.
    for stop in &drive.stops {
        let i = drive.kinematics.partition_point(|k| k.distance < stop.s);
        let p = drive.trajectory.records()[i].position;
        assert_eq!(px(p.x(), p.y()).0, [0, 0, 0], "stop at {p:?}");
    }
    // Where the horizontal error exceeds 1 m, the track is red; below 5 cm, green. Dots overlap, so skip
    // the seconds around a jump's rise or fall, where neighbouring dots differ.
    let (mut red, mut green) = (0, 0);
    let steady = |t: f64| !dg.faults.iter().any(|f| [-1.5, 0.0, 1.5].iter().any(|d| f.in_transition(t + d)));
    for (i, e) in dg.errors.iter().enumerate().step_by(25).filter(|(_, e)| steady(e.time)) {
        let h = e.position.x().hypot(e.position.y());
        let p = drive.trajectory.records()[i].position;
        let c = px(p.x(), p.y()).0;
        if c == [0, 0, 0] {
            continue;
        }
        if h > 1.05 {
            assert!(c[0] == 255 && c[1] < 20, "{h} m drawn as {c:?}");
            red += 1;
        } else if h < 0.05 {
            assert!(c[1] == 200 && c[0] < 60, "{h} m drawn as {c:?}");
            green += 1;
        }
    }
    assert!(red + green > 10, "seed {seed}: {red} red, {green} green");
}
