//! Raw GNSS and IMU made leg by leg (`GnssStream`, `ImuStream`, as the `city` preset makes them): the joined
//! series equal those of the joined drive made at once, and run through a join without a gap or a step.

use plumbline_geo::{Trajectory, ValidationLimits};

use super::dg::{DgConfig, DgSolution, DgStream, FaultKind};
use super::gnss::{self, GnssConfig, GnssRecord, GnssStream};
use super::imu::{self, ImuErrors, ImuRecord, ImuStream};
use super::routes::DEEP_CANYON;
use super::{Drive, DriveConfig};
use crate::world::city::City;
use crate::world::city_route::CityWalk;
use crate::world::{Preset, WorldConfig};

const SEED: u64 = 11;
const DWELL_S: f64 = 5.0;

/// Two consecutive ~250 m city legs in deep canyons, joined standing `DWELL_S` on each side, with their DG
/// solutions from one `DgStream`.
fn two_legs() -> Vec<(Drive, DgSolution)> {
    let mut walk = CityWalk::new(City::new(&WorldConfig::new(Preset::City, SEED)), SEED, 250.0);
    let mut dg = DgStream::new(&DgConfig::default(), SEED).unwrap();
    let mut start_time = DriveConfig::default().start_time;
    (0..2)
        .map(|_| {
            let leg = walk.next_leg();
            let config = DriveConfig { start_time, start_dwell: DWELL_S, end_dwell: DWELL_S, ..DriveConfig::default() };
            let drive = Drive::simulate(&leg.route.with_canyon(DEEP_CANYON), &config, SEED + leg.index as u64).unwrap();
            start_time = drive.trajectory.span().1 + 1.0 / config.rate_hz;
            let solution = dg.leg(&drive).unwrap();
            (drive, solution)
        })
        .collect()
}

/// The legs as one drive and one DG solution.
fn joined(legs: &[(Drive, DgSolution)]) -> (Drive, DgSolution) {
    let limits = ValidationLimits::default();
    let truth = legs.iter().flat_map(|(d, _)| d.trajectory.records().iter().copied()).collect();
    let dg = legs.iter().flat_map(|(_, s)| s.trajectory.records().iter().copied()).collect();
    let drive = Drive {
        trajectory: Trajectory::new(truth, &limits).unwrap(),
        kinematics: legs.iter().flat_map(|(d, _)| d.kinematics.iter().copied()).collect(),
        stops: Vec::new(),
    };
    let errors = legs.iter().flat_map(|(_, s)| s.errors.iter().copied()).collect();
    (drive, DgSolution { trajectory: Trajectory::new(dg, &limits).unwrap(), errors, faults: Vec::new() })
}

fn streamed(legs: &[(Drive, DgSolution)], errors: &ImuErrors) -> (Vec<GnssRecord>, Vec<ImuRecord>) {
    let mut gnss = GnssStream::new(&DgConfig::default(), &GnssConfig::default(), SEED).unwrap();
    let mut imu = ImuStream::new(errors, SEED).unwrap();
    let mut fixes = Vec::new();
    let mut increments = Vec::new();
    for (drive, solution) in legs {
        fixes.extend(gnss.leg(drive, solution).unwrap());
        increments.extend(imu.leg(drive).records);
    }
    (fixes, increments)
}

#[test]
fn streamed_raw_data_equal_the_joined_drive_made_at_once() {
    let legs = two_legs();
    let (drive, solution) = joined(&legs);
    let (fixes, increments) = streamed(&legs, &ImuErrors::CONSUMER);
    let whole_fixes = gnss::simulate(&drive, &solution, &DgConfig::default(), &GnssConfig::default(), SEED).unwrap();
    let whole_imu = imu::simulate(&drive, &ImuErrors::CONSUMER, SEED).unwrap();
    // A restarted bias, noise stream or fix clock, or a missing increment over the join, changes these bits.
    assert_eq!(increments.len(), drive.trajectory.len() - 1);
    assert!(increments == whole_imu.records, "IMU records differ from the joined drive's");
    assert!(fixes.len() > 250, "{} fixes", fixes.len());
    assert!(fixes == whole_fixes, "GNSS fixes differ from the joined drive's");
}

/// Mean per axis of (measured − error-free) increments over `records`.
fn mean_error(measured: &[ImuRecord], perfect: &[ImuRecord]) -> [f64; 6] {
    let mut sum = [0.0; 6];
    for (m, p) in measured.iter().zip(perfect) {
        let (dt, dv) = (m.delta_theta.v - p.delta_theta.v, m.delta_v.v - p.delta_v.v);
        for k in 0..3 {
            sum[k] += dt[k];
            sum[k + 3] += dv[k];
        }
    }
    sum.map(|s| s / measured.len() as f64)
}

#[test]
fn raw_series_run_through_a_join_without_a_gap_or_a_step() {
    let legs = two_legs();
    let (fixes, increments) = streamed(&legs, &ImuErrors::CONSUMER);
    let (_, perfect) = streamed(&legs, &ImuErrors::PERFECT);
    let join = legs[0].0.trajectory.len() - 1; // the increment from leg 0's last epoch to leg 1's first
    let first_time = legs[1].0.trajectory.records()[0].time;
    assert!((increments[join].time - first_time).abs() < 1e-12);
    for w in increments.windows(2) {
        assert!((w[1].time - w[0].time - 0.005).abs() < 1e-9 && (w[1].dt - 0.005).abs() < 1e-9, "gap at {}", w[0].time);
    }
    // Standing still on both sides: the error is (bias + instability)·dt + noise. Consumer turn-on biases are
    // 1°/s and 13 mg (σ): redrawn at the join they would step by ~1e-4 rad and ~7e-4 m/s per record; the mean
    // of 200 records has noise σ 6e-7 rad and 9e-6 m/s.
    let n = 200;
    let before = mean_error(&increments[join - n..join], &perfect[join - n..join]);
    let after = mean_error(&increments[join + 1..join + 1 + n], &perfect[join + 1..join + 1 + n]);
    for k in 0..6 {
        let limit = if k < 3 { 5e-6 } else { 6e-5 };
        assert!((after[k] - before[k]).abs() < limit, "axis {k}: {} before, {} after the join", before[k], after[k]);
    }
    // The biases are there to be continued: the largest axis stands far above the limits.
    let largest = |axes: &[f64]| axes.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(largest(&before[..3]) > 5e-5 && largest(&before[3..]) > 6e-4, "{before:?}");
    // GNSS: one 5 Hz clock through the join; the antenna error (DG error + receiver noise) does not step.
    for w in fixes.windows(2) {
        let steps = (w[1].time - w[0].time) / 0.2;
        assert!((steps - steps.round()).abs() < 1e-6 && steps.round() >= 1.0, "off the clock at {}", w[0].time);
    }
    let split = fixes.partition_point(|f| f.time < first_time);
    let around = &fixes[split - 1..=split];
    let outage_near = legs
        .iter()
        .flat_map(|(_, s)| &s.errors)
        .any(|e| e.fault == Some(FaultKind::Outage) && (e.time - first_time).abs() < 1.0);
    assert!(
        outage_near || (around[1].time - around[0].time - 0.2).abs() < 1e-6,
        "{} {}",
        around[0].time,
        around[1].time
    );
}
