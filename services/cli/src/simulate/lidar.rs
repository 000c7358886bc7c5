//! The mobile laser scanner of a simulated campaign (`--point-cloud laz|copc`): the roof profile scanner of
//! `plumbline_synth::mls` along the drive, written as LAZ strips (LAS 1.4, point format 6, GPS week seconds,
//! the campaign CRS as WKT) of at most [`STRIP_S`] seconds of scanning each, as survey deliveries cut a
//! drive into strips, or as COPC files of the same strips (points by octree node). Each strip is made,
//! compressed and handed over before the next is scanned.

use anyhow::Context as _;
use plumbline_poles::{LasEncoding, LasPoint, encode_copc, encode_las};
use plumbline_synth::mls::{ProfileScanner, profile_times, scan_profiles};
use plumbline_synth::motion::Drive;
use plumbline_synth::motion::dg::DgSolution;
use plumbline_synth::world::World;

use super::Sink;
use super::manifest::mount;

/// Longest strip, seconds of scanning.
pub(crate) const STRIP_S: f64 = 30.0;

/// Scan the drive and hand over its strips; returns the manifest's `[[point_clouds]]` entries.
pub(crate) fn write(
    world: &World,
    drive: &Drive,
    dg: &DgSolution,
    crs: u32,
    seed: u64,
    copc: bool,
    sink: &Sink,
) -> anyhow::Result<String> {
    let scanner = ProfileScanner::ROOF;
    let times = profile_times(drive, &scanner)?;
    let wkt = plumbline_runtime::crs::wkt_of_epsg(crs).with_context(|| format!("WKT of EPSG:{crs}"))?;
    let encoding = LasEncoding { compressed: true, wkt: Some(wkt), adjusted_standard_week: None };
    let mut section = String::new();
    let mut points_total = 0usize;
    for (k, strip) in strips(&times).into_iter().enumerate() {
        let points = scan_profiles(world, &drive.trajectory, &dg.trajectory, &scanner, strip, seed)?;
        points_total += points.len();
        let points: Vec<LasPoint> =
            points.into_iter().map(|p| LasPoint { position: p.position, gps_time: p.gps_time }).collect();
        let (file, bytes, format) = if copc {
            let bytes = encode_copc(&points, &encoding).with_context(|| format!("COPC strip {k}"))?;
            (format!("lidar/strip_{k:03}.copc.laz"), bytes, "copc")
        } else {
            let bytes = encode_las(&points, &encoding).with_context(|| format!("LAZ strip {k}"))?;
            (format!("lidar/strip_{k:03}.laz"), bytes, "laz")
        };
        sink.put(&file, bytes)?;
        section.push_str(&format!(
            "[[point_clouds]]\nurl = \"{file}\"\nformat = \"{format}\"\ntime = \"week_seconds\"\n{}\n",
            mount("point_clouds", &scanner.mount).trim_start()
        ));
    }
    if points_total == 0 {
        anyhow::bail!("the simulated scanner measured no point along the drive");
    }
    Ok(section)
}

/// The profile times cut into strips of at most [`STRIP_S`] seconds.
fn strips(times: &[f64]) -> Vec<&[f64]> {
    let mut out = Vec::new();
    let mut rest = times;
    while let Some(&first) = rest.first() {
        let n = rest.iter().position(|&t| t >= first + STRIP_S).unwrap_or(rest.len());
        let (strip, tail) = rest.split_at(n);
        out.push(strip);
        rest = tail;
    }
    out
}
