//! Throughput of the forward filter and the RTS smoother: a simulated drive at 200 Hz IMU with 5 Hz GNSS,
//! tactical grade, for growing durations up to 1 h (`cargo bench -p plumbline-navigation`).
#![allow(clippy::unwrap_used)]

use plumbline_fixtures::navigation;

use std::time::Instant;

use plumbline_navigation::{IntegrityConfig, filter, smooth, test_innovations, to_trajectory};
use plumbline_synth::motion::imu::ImuErrors;

fn main() {
    println!("| drive | IMU epochs | fixes | filter s | smoother s | tests s | epochs/s (filter + smoother) |");
    println!("|---|---|---|---|---|---|---|");
    // One pass around the block takes ~2.8 min; 21 passes ≈ 1 h.
    for passes in [3, 9, 21] {
        let s = navigation::scenario(7, &navigation::block_route(passes), &ImuErrors::NAVIGATION, 200.0, 5.0);
        let t = Instant::now();
        let fw = filter(&s.imu, &s.gnss, &s.initial, &s.config).unwrap();
        let t_filter = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let traj = to_trajectory(&smooth(&fw).unwrap()).unwrap();
        let t_smooth = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let flags = test_innovations(&fw.innovations, &IntegrityConfig::default()).unwrap();
        let t_tests = t.elapsed().as_secs_f64();
        let (a, b) = traj.span();
        let epochs = fw.len();
        println!(
            "| {:.1} min | {epochs} | {} | {t_filter:.2} | {t_smooth:.2} | {t_tests:.3} | {:.0} |",
            (b - a) / 60.0,
            fw.innovations.len(),
            epochs as f64 / (t_filter + t_smooth),
        );
        std::hint::black_box(flags);
    }
}
