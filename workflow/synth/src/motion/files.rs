//! The bytes of the simulator's own CSV files (trajectories use `plumbline_geo::formats`).
//!
//! All files have one header line, comma-separated columns, SI units named in the column, and values in
//! Rust's shortest round-trip notation (lossless):
//! - GNSS: `time_s,easting_m,northing_m,height_m,std_east_m,std_north_m,std_height_m,environment` — the
//!   antenna position in the campaign CRS.
//! - IMU: `time_s,dt_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps` — increments over
//!   the `dt_s` ending at `time_s`, body frame x forward, y right, z down; Δv is specific force × dt (a
//!   resting IMU reads dv_z = −g·dt).
//! - DG error series: `time_s,east_m,north_m,up_m,roll_rad,pitch_rad,heading_rad,environment,fault` — DG
//!   minus truth per epoch; `fault` is `jump`, `outage` or empty.

use std::fmt::Write as _;

use super::dg::{DgError, FaultKind};
use super::gnss::GnssRecord;
use super::imu::ImuData;

/// The GNSS fixes as CSV.
pub fn gnss_csv(records: &[GnssRecord]) -> Vec<u8> {
    let mut s = String::from("time_s,easting_m,northing_m,height_m,std_east_m,std_north_m,std_height_m,environment\n");
    for r in records {
        let p = &r.position;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{}",
            r.time,
            p.x(),
            p.y(),
            p.z(),
            r.std[0],
            r.std[1],
            r.std[2],
            r.environment.name()
        );
    }
    s.into_bytes()
}

/// The IMU increments as CSV.
pub fn imu_csv(imu: &ImuData) -> Vec<u8> {
    let mut s = String::from("time_s,dt_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps\n");
    for r in &imu.records {
        let (a, v) = (&r.delta_theta, &r.delta_v);
        let _ = writeln!(s, "{},{},{},{},{},{},{},{}", r.time, r.dt, a.x(), a.y(), a.z(), v.x(), v.y(), v.z());
    }
    s.into_bytes()
}

/// The DG error series as CSV.
pub fn dg_errors_csv(errors: &[DgError]) -> Vec<u8> {
    let mut s = String::from("time_s,east_m,north_m,up_m,roll_rad,pitch_rad,heading_rad,environment,fault\n");
    for e in errors {
        let p = &e.position;
        let fault = match e.fault {
            Some(FaultKind::Jump) => "jump",
            Some(FaultKind::Outage) => "outage",
            None => "",
        };
        let [r, pt, h] = e.attitude;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{}",
            e.time,
            p.x(),
            p.y(),
            p.z(),
            r,
            pt,
            h,
            e.environment.name(),
            fault
        );
    }
    s.into_bytes()
}
