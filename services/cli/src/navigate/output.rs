//! Writing the results of `plumbline navigate`: the smoothed trajectory, the innovations, the flags and the
//! summary.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use plumbline_geo::Trajectory;
use plumbline_geo::formats::{self, RawTrajectory};
use plumbline_navigation::{
    Decision, Flag, ForwardPass, ImuDatasheet, ImuModel, InitialState, Innovation, MeasuredNoise, chi2_critical,
};
use serde_json::{Value, json};

/// The smoothed trajectory as projected CSV with σ.
pub fn trajectory_csv(trajectory: &Trajectory) -> Vec<u8> {
    formats::write_csv(&RawTrajectory::from_map_projected(trajectory.records()))
}

/// Snake-case name of a serialisable enum value.
fn name<T: serde::Serialize>(value: &T) -> String {
    serde_json::to_value(value).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_default()
}

/// One row per rejection: time, fix index, test, statistic, critical value, blamed component and sensor.
pub fn flags_csv(flags: &[Flag]) -> Vec<u8> {
    let mut s = String::from("time_s,fix,window_start_s,test,statistic,critical,component,sensor\n");
    for f in flags {
        let component = f.component.as_ref().map(name).unwrap_or_default();
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{}",
            f.time,
            f.fix,
            f.window_start,
            name(&f.test),
            f.statistic,
            f.critical,
            component,
            name(&f.sensor)
        );
    }
    s.into_bytes()
}

/// One row per fix the filter met: time, fix index, the innovation (fix − prediction) east/north/up, its σ
/// from C_v, the normalised statistic vᵀC_v⁻¹v (χ² with 3 degrees of freedom when the model holds) and what
/// the filter did with the fix.
pub fn innovations_csv(forward: &ForwardPass) -> Vec<u8> {
    let mut s = String::from(
        "time_s,fix,residual_east_m,residual_north_m,residual_up_m,std_east_m,std_north_m,std_up_m,statistic,decision\n",
    );
    for i in &forward.innovations {
        let r = &i.residual;
        let c = &i.covariance;
        let statistic = i.statistic();
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{}",
            i.time,
            i.fix,
            r.x,
            r.y,
            r.z,
            c[(0, 0)].sqrt(),
            c[(1, 1)].sqrt(),
            c[(2, 2)].sqrt(),
            statistic,
            name(&i.decision)
        );
    }
    s.into_bytes()
}

/// What the filter did: fixes by decision (with the times of every non-plain one), skipped fixes with
/// their reason, flag counts by test and sensor, and the alignment.
pub fn summary(forward: &ForwardPass, flags: &[Flag], initial: &InitialState, adaptive: bool) -> Value {
    let mut decisions: BTreeMap<String, usize> = BTreeMap::new();
    for i in &forward.innovations {
        *decisions.entry(name(&i.decision)).or_default() += 1;
    }
    let actions: Vec<Value> = forward
        .innovations
        .iter()
        .filter(|i| i.decision != Decision::Used)
        .map(|i| json!({"time": i.time, "fix": i.fix, "decision": i.decision}))
        .collect();
    let skipped: Vec<Value> =
        forward.skipped.iter().map(|k| json!({"fix": k.fix, "reason": k.reason.to_string()})).collect();
    let mut by_test: BTreeMap<String, usize> = BTreeMap::new();
    let mut by_sensor: BTreeMap<String, usize> = BTreeMap::new();
    for f in flags {
        *by_test.entry(name(&f.test)).or_default() += 1;
        *by_sensor.entry(name(&f.sensor)).or_default() += 1;
    }
    let a = &initial.attitude;
    let (accel, gyro) = forward.final_biases();
    json!({
        "version": "1",
        "adaptive": adaptive,
        "epochs": forward.len(),
        "fixes": forward.innovations.len(),
        "decisions": decisions,
        "actions": actions,
        "skipped_fixes": skipped,
        "flags": {"total": flags.len(), "by_test": by_test, "by_sensor": by_sensor},
        "alignment": {
            "time": initial.time,
            "position": [initial.position.x(), initial.position.y(), initial.position.z()],
            "roll_deg": a.roll.to_degrees(),
            "pitch_deg": a.pitch.to_degrees(),
            "heading_deg": a.heading.to_degrees(),
            "velocity_mps": [initial.velocity.x(), initial.velocity.y(), initial.velocity.z()],
            "attitude_std_deg": initial.attitude_std.map(f64::to_degrees),
        },
        "final_biases": {"accelerometer_mps2": [accel.x, accel.y, accel.z], "gyro_radps": [gyro.x, gyro.y, gyro.z]},
    })
}

/// `summary.json`'s `consistency`: the innovations of the used fixes against their modelled covariance.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Consistency {
    /// Median vᵀC_v⁻¹v over the used fixes.
    pub median_statistic: f64,
    /// Its value when the model fits (the median of χ² with 3 degrees of freedom).
    pub expected_median: f64,
    /// Their ratio: the factor by which the innovations exceed their modelled variance.
    pub variance_factor: f64,
    /// Share of the used fixes the local overall test flagged.
    pub local_flagged_share: f64,
    /// The test's nominal false-alarm rate (α).
    pub nominal_share: f64,
}

/// The consistency of `forward`'s used innovations, with the local-test flags among `flags`.
pub fn consistency(forward: &ForwardPass, flags: &[Flag], alpha: f64) -> Consistency {
    let mut statistics: Vec<f64> = forward
        .innovations
        .iter()
        .filter(|i| i.decision != Decision::Excluded)
        .map(Innovation::statistic)
        .filter(|x| x.is_finite())
        .collect();
    let used = statistics.len();
    let median = if statistics.is_empty() {
        f64::NAN
    } else {
        let mid = statistics.len() / 2;
        *statistics.select_nth_unstable_by(mid, f64::total_cmp).1
    };
    let used_fixes: std::collections::HashSet<usize> =
        forward.innovations.iter().filter(|i| i.decision != Decision::Excluded).map(|i| i.fix).collect();
    // The median of χ² with 3 degrees of freedom (2.37).
    let expected_median = chi2_critical(3.0, 0.5);
    let local = flags
        .iter()
        .filter(|f| f.test == plumbline_navigation::TestKind::LocalOverall && used_fixes.contains(&f.fix))
        .count();
    Consistency {
        median_statistic: median,
        expected_median,
        variance_factor: median / expected_median,
        local_flagged_share: if used == 0 { 0.0 } else { local as f64 / used as f64 },
        nominal_share: alpha,
    }
}

/// `summary.json`'s `integrity`: how the fixes were judged.
pub fn integrity_name(integrity: super::Integrity) -> &'static str {
    match integrity {
        super::Integrity::Steps => "steps",
        super::Integrity::Online => "online",
        super::Integrity::None => "none",
    }
}

/// `summary.json`'s `imu_model`: what `--imu-model` named, its datasheet, the noise measured in the records
/// and the random walks the filter used (SI).
pub fn imu_model(spec: &str, datasheet: &ImuDatasheet, measured: Option<&MeasuredNoise>, used: &ImuModel) -> Value {
    json!({
        "name": spec,
        "datasheet": datasheet,
        "measured": measured,
        "used": {"gyro_random_walk_rad_per_sqrt_s": used.gyro_random_walk, "accel_random_walk_m_per_s_per_sqrt_s": used.accel_random_walk},
    })
}
