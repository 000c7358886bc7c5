//! Parsing the raw navigation files: header-driven CSV of GNSS fixes and IMU increments. A malformed value
//! is invalid input naming the file, line and column.

use std::collections::HashMap;

use plumbline_geo::{Point3, Vec3};
use plumbline_navigation::{GnssFix, ImuSample, NavError};

use crate::exit::invalid;

const GNSS_COLUMNS: [&str; 7] =
    ["time_s", "easting_m", "northing_m", "height_m", "std_east_m", "std_north_m", "std_height_m"];
const IMU_COLUMNS: [&str; 8] =
    ["time_s", "dt_s", "dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_mps", "dv_y_mps", "dv_z_mps"];

/// The rows of a CSV file as numbers in the order of `columns` (looked up by header name).
fn rows<const N: usize>(bytes: &[u8], name: &str, columns: [&str; N]) -> anyhow::Result<Vec<[f64; N]>> {
    let text = std::str::from_utf8(bytes).map_err(|e| invalid(format!("{name}: not UTF-8 text ({e})")))?;
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| invalid(format!("{name}: empty file")))?;
    let index: HashMap<&str, usize> = header.split(',').enumerate().map(|(i, h)| (h.trim(), i)).collect();
    let mut at = [0usize; N];
    for (slot, col) in at.iter_mut().zip(columns) {
        *slot = *index.get(col).ok_or_else(|| invalid(format!("{name}: line 1: missing column `{col}`")))?;
    }
    lines
        .map(|(n, line)| {
            let fields: Vec<&str> = line.split(',').collect();
            let mut row = [0.0; N];
            for ((value, i), col) in row.iter_mut().zip(at).zip(columns) {
                let text = fields.get(i).map_or("", |f| f.trim());
                *value = text.parse().map_err(|_| {
                    invalid(format!("{name}: line {}: column `{col}`: `{text}` is not a number", n + 1))
                })?;
            }
            Ok(row)
        })
        .collect()
}

/// GNSS fixes from CSV (antenna positions in the campaign CRS, σ per axis).
pub fn gnss(bytes: &[u8], name: &str) -> anyhow::Result<Vec<GnssFix>> {
    let rows = rows(bytes, name, GNSS_COLUMNS)?;
    if let Some(i) = rows.windows(2).position(|w| w[1][0] < w[0][0]) {
        return Err(invalid(format!("{name}: line {}: `time_s` goes backwards", i + 3)));
    }
    Ok(rows
        .into_iter()
        .map(|[t, e, n, h, se, sn, sh]| GnssFix { time: t, position: Point3::new(e, n, h), std: [se, sn, sh] })
        .collect())
}

/// IMU increments from CSV.
pub fn imu(bytes: &[u8], name: &str) -> anyhow::Result<Vec<ImuSample>> {
    let rows = rows(bytes, name, IMU_COLUMNS)?;
    if rows.is_empty() {
        return Err(invalid(format!("{name}: no IMU samples")));
    }
    Ok(rows
        .into_iter()
        .map(|[time, dt, ax, ay, az, vx, vy, vz]| ImuSample {
            time,
            dt,
            delta_theta: Vec3::new(ax, ay, az),
            delta_v: Vec3::new(vx, vy, vz),
        })
        .collect())
}

/// A filter error naming an IMU sample becomes invalid input naming the file line; others pass through.
pub fn name_sample(e: NavError, imu_name: &str) -> anyhow::Error {
    match e {
        NavError::Sample { index, .. } => invalid(format!("{imu_name}: line {}: {e}", index + 2)),
        NavError::Config { .. } | NavError::Empty => invalid(e.to_string()),
        other => other.into(),
    }
}
