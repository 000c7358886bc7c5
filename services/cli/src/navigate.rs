//! `plumbline navigate`: loosely coupled GNSS/INS fusion of raw fixes and IMU increments (the files
//! `plumbline simulate` writes as `nav/gnss.csv` and `nav/imu.csv`): coarse alignment, the Kalman filter
//! acting on its innovation tests, the RTS smoother, and the flagged epochs with the sensor they blame.
//!
//! Layout under `--out`: `trajectory.csv` (smoothed, in the fixes' projected CRS, with σ),
//! `innovations.csv` (every fix's innovation, its σ and statistic, and what the filter did with it),
//! `flags.csv` (every rejection of the four innovation tests), `summary.json` (what the filter did with the
//! fixes).

mod files;
mod output;

use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args as ClapArgs, ValueEnum};
use plumbline_geo::Vec3;
use plumbline_navigation::{
    Adaptation, AlignmentConfig, CorrelatedGnssError, Earth, EpisodeEnd, FixNoise, GapKind, GnssCorrelation,
    Implausible, ImuClass, ImuDatasheet, ImuGap, ImuGapModel, ImuModel, ImuSample, IntegrityConfig, MeasuredNoise,
    NavConfig, NavError, Physics, Plausibility, Runaway, STANDARD_GRAVITY, Screened, ScreenedFix, StepScreen, StepTest,
    TimeOffsetMeasurement, VehicleConstraint, align, angle_random_walk_deg_per_sqrt_h, divergences, filter,
    filter_adaptive, filter_excluding, filter_screened, measure_fix_noise, measure_gnss_correlation, measure_mounting,
    measure_noise, measure_time_offset, screen_fixes, shift_samples, smooth, test_innovations, to_trajectory,
    velocity_random_walk_m_per_s_per_sqrt_h,
};

use crate::adjust::triple;
use crate::exit::{OrInvalid, invalid};
use crate::io::{Context, file_name};

/// IMU grades `simulate` can generate (`plumbline_synth::motion::imu`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Grade {
    /// Navigation grade (LN-100 class, Grejner-Brzezinska and Toth 2000 §2.1; `navigate --imu-model navigation`).
    Tactical,
    /// Consumer MEMS (BMI160 class, Meyer et al. 2023 §3.1.1; `navigate --imu-model consumer`).
    Consumer,
}

/// How `navigate` judges the fixes (see `--integrity`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Integrity {
    /// GNSS steps against the IMU's free displacement (`plumbline_navigation::screen_steps`).
    Steps,
    /// The filter's online innovation tests (`plumbline_navigation::filter_adaptive`).
    Online,
    /// Every fix used.
    None,
}

/// `--imu-time-offset`: measured, or given in seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeOffset {
    Auto,
    Fixed(f64),
}

fn time_offset(text: &str) -> Result<TimeOffset, String> {
    if text == "auto" {
        return Ok(TimeOffset::Auto);
    }
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v.abs() <= 1.0 => Ok(TimeOffset::Fixed(v)),
        _ => Err(format!("expected `auto` or seconds within ±1 (e.g. 0.065), got {text:?}")),
    }
}

/// The GNSS fixes' lasting error: measured, none, or given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GnssErrorArg {
    Auto,
    None,
    Given(CorrelatedGnssError),
}

fn gnss_error(text: &str) -> Result<GnssErrorArg, String> {
    match text {
        "auto" => return Ok(GnssErrorArg::Auto),
        "none" => return Ok(GnssErrorArg::None),
        _ => {}
    }
    let bad = || {
        format!(
            "expected `auto`, `none` or σ east,north,up in m and a correlation time in s as E,N,U@T (e.g. 0.2,0.2,0.4@10), got {text:?}"
        )
    };
    let (stds, time) = text.split_once('@').ok_or_else(bad)?;
    let std: Vec<f64> =
        stds.split(',').map(|v| v.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
    let [e, n, u] = std[..] else { return Err(bad()) };
    let model = CorrelatedGnssError { std: [e, n, u], correlation_time: time.trim().parse().map_err(|_| bad())? };
    model.check().map_err(|e| e.to_string())?;
    Ok(GnssErrorArg::Given(model))
}

/// Arguments of `navigate`.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// GNSS antenna fixes (CSV: time_s, easting_m, northing_m, height_m, std_east_m, std_north_m, std_height_m).
    #[arg(long, value_name = "PATH|URL")]
    pub gnss: String,
    /// IMU increments (CSV: time_s, dt_s, dtheta_{x,y,z}_rad, dv_{x,y,z}_mps; body x forward, y right, z down).
    #[arg(long, value_name = "PATH|URL")]
    pub imu: String,
    /// GNSS antenna in the body frame (x forward, y right, z down), metres: X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = triple, default_value = "0,0,0")]
    pub lever_arm: [f64; 3],
    /// Error model of the IMU: a class (navigation, tactical, industrial, consumer; their figures are in
    /// docs/guide.md § IMU models) or a TOML file of datasheet figures (`class = "…"` plus any figures that differ).
    #[arg(long, value_name = "CLASS|FILE.toml", default_value = "tactical")]
    pub imu_model: String,
    /// Geodetic latitude of the drive, degrees: mechanise on the WGS 84 Earth (Earth rotation, transport
    /// rate, normal gravity), as real IMU data needs. Without it the Earth is flat and still, with standard
    /// gravity: the simulator's world.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub latitude: Option<f64>,
    /// EPSG code of the fixes' projected CRS: the latitude for the WGS 84 mechanisation is then taken from
    /// the middle fix through GDAL/PROJ (`--latitude` wins when both are given).
    #[arg(long, value_name = "CODE")]
    pub epsg: Option<u32>,
    /// Significance level of the innovation tests and the step test.
    #[arg(long, default_value_t = 0.001)]
    pub alpha: f64,
    /// Fixes in the moving window of the global tests.
    #[arg(long, default_value_t = 25)]
    pub window: usize,
    /// How fixes are judged before use: `steps` (GNSS steps found against the IMU's own acceleration,
    /// independent of the filter's drift; the default), `online` (the filter acting on its innovation tests,
    /// Cazzaniga et al. 2007 §3.2: excluding, re-opening, re-initialising; suits IMU data its model describes) or
    /// `none` (every fix used).
    #[arg(long, value_enum, default_value_t = Integrity::Steps)]
    pub integrity: Integrity,
    /// The smallest GNSS step the step test excludes fixes for, m.
    #[arg(long, value_name = "M", default_value_t = StepTest::default().min_step)]
    pub min_step: f64,
    /// Use every fix as it comes: the same as `--integrity none`.
    #[arg(long)]
    pub no_adapt: bool,
    /// The platform is not a wheeled vehicle (a backpack, a trolley): do not hold the body's lateral and
    /// vertical velocity near zero
    #[arg(long)]
    pub no_vehicle_constraint: bool,
    /// Take every IMU sample as measured: do not look for stretches a logger filled in (runs of exactly
    /// interpolated or repeated samples) or lost (intervals over 5 × the median), which otherwise get
    /// extra process noise for the motion they hide
    #[arg(long)]
    pub ignore_imu_gaps: bool,
    /// How far the IMU's time tags lag the GNSS's, seconds (IMU time − GNSS time of the same instant), or
    /// `auto`: measured from the data within ±0.3 s and applied when a likelihood-ratio test finds it
    /// (units that filter their output, loggers that stamp on arrival). The IMU's tags are moved back by it;
    /// the outputs are in GNSS time. `0` takes the tags as they are
    #[arg(long, value_name = "SECONDS|auto", default_value = "auto", value_parser = time_offset, allow_negative_numbers = true)]
    pub imu_time_offset: TimeOffset,
    /// The lasting part of the fixes' error, estimated as a state (a first-order Gauss–Markov process per
    /// axis): `auto` takes the σ the fixes state, measures the correlation time from the data and uses the
    /// state when a likelihood-ratio test finds it, `none` takes the fixes' errors as white, `E,N,U@T` gives
    /// σ east, north, up (m) and the correlation time (s)
    #[arg(long, value_name = "auto|none|E,N,U@T", default_value = "auto", value_parser = gnss_error)]
    pub gnss_error: GnssErrorArg,
    /// Directory or object-store prefix for the results.
    #[arg(long, value_name = "DIR|URL")]
    pub out: String,
}

/// The datasheet `--imu-model` names: a class, or a file (local path or URL) of figures.
async fn datasheet_of(ctx: &Context, spec: &str) -> anyhow::Result<ImuDatasheet> {
    if let Ok(class) = spec.parse::<ImuClass>() {
        return Ok(class.datasheet());
    }
    if !spec.ends_with(".toml") {
        let classes: Vec<&str> = ImuClass::ALL.iter().map(|c| c.name()).collect();
        return Err(invalid(format!("--imu-model {spec}: expected one of {} or a .toml file", classes.join(", "))));
    }
    let bytes = ctx.read(spec).await?;
    let text = std::str::from_utf8(&bytes).map_err(|e| invalid(format!("{spec}: not UTF-8 text: {e}")))?;
    let bad = |e: String| invalid(format!("{spec}: {e}"));
    let mut figures: toml::Table = toml::from_str(text).map_err(|e| bad(e.to_string()))?;
    // The class's figures, overridden by those the file gives; without a class, the file must give all.
    let mut sheet = match figures.remove("class") {
        None => toml::Table::new(),
        Some(toml::Value::String(name)) => {
            let class: ImuClass = name.parse().map_err(|e: String| bad(format!("`class`: {e}")))?;
            toml::Table::try_from(class.datasheet()).map_err(|e| bad(e.to_string()))?
        }
        Some(other) => return Err(bad(format!("`class` is {other}; expected a class name in quotes"))),
    };
    sheet.extend(figures);
    let sheet: ImuDatasheet = toml::Value::Table(sheet).try_into().map_err(|e: toml::de::Error| bad(e.to_string()))?;
    sheet.check().map_err(|e| bad(e.to_string()))?;
    Ok(sheet)
}

/// The datasheet's model with its random walks raised to the noise the records show (vibration of the mount
/// adds to the sensor's own), said on stderr when it does; the measurement, if the records allow one.
fn noise_floor(datasheet: &ImuDatasheet, imu: &[ImuSample], name: &str) -> (ImuModel, Option<MeasuredNoise>) {
    let model = datasheet.model();
    let Some(measured) = measure_noise(imu) else {
        eprintln!("warning: {name}: too few regular samples to measure the IMU noise; the datasheet's is used");
        return (model, None);
    };
    let (arw, vrw) = (
        angle_random_walk_deg_per_sqrt_h(measured.gyro_random_walk),
        velocity_random_walk_m_per_s_per_sqrt_h(measured.accel_random_walk),
    );
    let floored = model.with_noise_floor(&measured);
    if floored != model {
        eprintln!(
            "IMU noise measured in {name}: ARW {arw:.3} °/√h, VRW {vrw:.3} m/s/√h (worst axis); the filter uses \
             the larger of these and the datasheet's"
        );
    }
    (floored, Some(measured))
}

/// The fixes the plausibility tests set aside: counted, the first ones named on stderr (all in
/// `summary.json`).
fn report_screened(rejected: &[ScreenedFix], total: usize, name: &str) {
    if rejected.is_empty() {
        return;
    }
    eprintln!("warning: {name}: {} of {total} fixes set aside as implausible before the filter", rejected.len());
    for r in rejected.iter().take(SKIPPED_LISTED) {
        let why = match r.reason {
            Implausible::Spike { deviation, allowed } => {
                format!("{deviation:.1} m off the line between its neighbours (at most {allowed:.1} m plausible)")
            }
            Implausible::Speed { speed } => format!("implies {speed:.0} m/s"),
        };
        eprintln!("warning: {name} line {}: fix set aside: {why}", r.fix + 2);
    }
    if rejected.len() > SKIPPED_LISTED {
        eprintln!("warning: {name}: {} more fixes set aside (summary.json)", rejected.len() - SKIPPED_LISTED);
    }
}

/// The geodetic latitude (degrees, WGS 84) of the middle fix, whose coordinates are in projected `epsg`, and
/// the meridian convergence there (rad).
fn place_from_crs(epsg: u32, gnss: &[plumbline_navigation::GnssFix], name: &str) -> anyhow::Result<(f64, f64)> {
    let projected = plumbline_runtime::is_projected(epsg).map_err(|e| invalid(format!("--epsg {epsg}: {e}")))?;
    if !projected {
        return Err(invalid(format!(
            "--epsg {epsg} is not a projected CRS: navigate reads easting/northing in metres (give --latitude instead)"
        )));
    }
    let Some(middle) = gnss.get(gnss.len() / 2) else {
        return Err(invalid(format!("{name}: no fixes to take the latitude from")));
    };
    let to_geographic = plumbline_runtime::CrsTransform::new(epsg, WGS84_GEOGRAPHIC)
        .map_err(|e| invalid(format!("--epsg {epsg}: {e}")))?;
    let p = middle.position.p;
    let (longitude, latitude, _) =
        to_geographic.transform_point(p.x, p.y, p.z).map_err(|e| invalid(format!("--epsg {epsg}: {e}")))?;
    if !latitude.is_finite() || latitude.abs() > 90.0 {
        return Err(invalid(format!("--epsg {epsg}: the middle fix of {name} maps to latitude {latitude}")));
    }
    let convergence = plumbline_runtime::meridian_convergence(epsg, longitude, latitude)
        .map_err(|e| invalid(format!("--epsg {epsg}: meridian convergence: {e}")))?;
    eprintln!(
        "latitude {latitude:.4}° (WGS 84), grid convergence {:.4}° from EPSG:{epsg} at the middle fix of {name}",
        convergence.to_degrees()
    );
    Ok((latitude, convergence))
}

/// EPSG code of WGS 84 geographic coordinates.
const WGS84_GEOGRAPHIC: u32 = 4326;

/// How the innovations compare with their modelled covariance, on stderr; a warning where the IMU model is
/// far too optimistic for the data (the innovation tests then flag model misfit, not faults).
fn report_consistency(c: &output::Consistency, imu_model: &str) {
    eprintln!(
        "innovation consistency: median vᵀC⁻¹v {:.2} against {:.2} for a model that fits (×{:.1}); the local test \
         flagged {:.1} % of the fixes used (nominal {:.1} %)",
        c.median_statistic,
        c.expected_median,
        c.variance_factor,
        100.0 * c.local_flagged_share,
        100.0 * c.nominal_share
    );
    if c.variance_factor > MISFIT_FACTOR {
        eprintln!(
            "warning: the innovations run {:.1}× their modelled variance: the IMU model `{imu_model}` is too optimistic \
             for this unit, and flags.csv records model misfit more than faults (a worse --imu-model class or a \
             datasheet file with larger bias and noise figures fits better); the step test does not depend on it",
            c.variance_factor
        );
    }
}

/// Above this ratio of the median innovation statistic to its expected value the IMU model is called unfit.
const MISFIT_FACTOR: f64 = 3.0;

/// The IMU's unrecorded stretches, one warning each (all of them are in `summary.json`).
fn report_imu_gaps(gaps: &[ImuGap], name: &str) {
    if gaps.is_empty() {
        return;
    }
    let total: f64 = gaps.iter().map(ImuGap::duration).sum();
    eprintln!(
        "warning: {name}: {} stretch(es) of {total:.1} s in all were not recorded (filled in or lost); the filter \
         mechanises them as written with extra process noise for the motion they hide (--ignore-imu-gaps to trust them)",
        gaps.len()
    );
    for g in gaps.iter().take(SKIPPED_LISTED) {
        let what = match g.kind {
            GapKind::Filled => "samples interpolated or held",
            GapKind::Missing => "one interval far longer than the rate",
        };
        eprintln!(
            "warning: {name} lines {}–{}: {what}, {:.2} s from time {:.2} s",
            g.first + 2,
            g.last + 2,
            g.duration(),
            g.start
        );
    }
    if gaps.len() > SKIPPED_LISTED {
        eprintln!("warning: {name}: {} more unrecorded stretches (summary.json)", gaps.len() - SKIPPED_LISTED);
    }
}

/// The step test's episodes on stderr: counted, the first ones named (all in `summary.json`).
fn report_steps(steps: &StepScreen, name: &str) {
    let s = steps.scale;
    eprintln!(
        "GNSS step test: {} fixes tested against the IMU (σ of the step evidence {:.2}/{:.2}/{:.2} m/s \
         east/north/up, smallest step {:.2} m), {} excluded in {} episode(s)",
        steps.tested,
        s[0],
        s[1],
        s[2],
        steps.min_step,
        steps.excluded_count(),
        steps.episodes.len()
    );
    for e in steps.episodes.iter().take(SKIPPED_LISTED) {
        let how = match e.ended {
            EpisodeEnd::Returned => "until the fixes came back",
            EpisodeEnd::Gap => "until a gap in the fixes or the IMU record",
            EpisodeEnd::Data => "until the end of the data",
        };
        let [e_, n, u] = e.step;
        eprintln!(
            "warning: {name} line {}: a step of {:.1} m (east {e_:.1}, north {n:.1}, up {u:.1}) at time {:.2} s: {} \
             fix(es) excluded {how}",
            e.first_fix + 2,
            (e_ * e_ + n * n + u * u).sqrt(),
            e.start,
            e.fixes
        );
    }
    if steps.episodes.len() > SKIPPED_LISTED {
        eprintln!("warning: {name}: {} more step episodes (summary.json)", steps.episodes.len() - SKIPPED_LISTED);
    }
}

/// How the fixes' scatter compares with their stated σ, on stderr; a warning where it exceeds them.
fn report_fix_noise(noise: Option<&FixNoise>, name: &str) {
    let Some(n) = noise else {
        eprintln!("note: {name}: too few fixes used to compare their scatter with their σ");
        return;
    };
    let [e, nn, u] = n.factor.map(f64::sqrt);
    let excess = n.excess();
    if !excess.contains(&true) {
        eprintln!(
            "{name}: the fixes scatter no more than their σ state (× {e:.2}/{nn:.2}/{u:.2} east/north/up, most \
             likely over {} used fixes; no excess at {:.0} %)",
            n.fixes,
            100.0 * plumbline_navigation::NOISE_ALPHA
        );
        return;
    }
    let axes: Vec<&str> = ["east", "north", "up"].into_iter().zip(excess).filter(|(_, x)| *x).map(|(a, _)| a).collect();
    eprintln!(
        "warning: {name}: the fixes scatter more than their σ state: × {e:.2}/{nn:.2}/{u:.2} east/north/up, most \
         likely over {} used fixes, significant ({:.0} %, correlation of consecutive fixes allowed for) {}; the \
         innovation tests (flags.csv) judge them against the stated σ and flag more than their α",
        n.fixes,
        100.0 * plumbline_navigation::NOISE_ALPHA,
        if axes.len() == 1 { format!("{} only", axes[0]) } else { format!("on {}", axes.join(", ")) }
    );
}

/// A filter error about a fix, numbered as in the file.
fn renumber(e: NavError, fix: usize) -> NavError {
    match e {
        NavError::Fix { time, field, value, expected, .. } => {
            NavError::Fix { index: fix, time, field, value, expected }
        }
        NavError::FixOutsideImu { time, .. } => NavError::FixOutsideImu { index: fix, time },
        other => other,
    }
}

/// What left the physical limits, in words.
fn runaway_text(r: Runaway) -> &'static str {
    match r {
        Runaway::Speed => "the speed beyond a road vehicle's",
        Runaway::VerticalSpeed => "a vertical speed no road allows",
        Runaway::AccelBias => "an accelerometer bias estimate beyond the unit's plausibility",
        Runaway::GyroBias => "a gyro bias estimate beyond the unit's plausibility",
    }
}

fn imu_name_of(args: &Args) -> String {
    file_name(&args.imu).to_owned()
}

/// The IMU's time offset on stderr: what was measured and whether it was applied.
/// What `--gnss-error` came to: the model the final passes ran with, and the measurement behind it.
fn report_gnss_error(
    mode: GnssErrorArg,
    (measured, model): &(Option<GnssCorrelation>, Option<CorrelatedGnssError>),
    gnss: &str,
) {
    let describe = |m: &CorrelatedGnssError| {
        format!(
            "σ {:.2}/{:.2}/{:.2} m east/north/up, correlation time {:.0} s",
            m.std[0], m.std[1], m.std[2], m.correlation_time
        )
    };
    match (mode, measured, model) {
        (GnssErrorArg::None, ..) => {}
        (GnssErrorArg::Given(_), _, Some(m)) => {
            eprintln!(
                "{gnss}: the fixes' lasting error estimated as a state with the given {} (--gnss-error)",
                describe(m)
            );
        }
        (_, None, _) => {
            eprintln!("note: {gnss}: too few fixes to measure their lasting (correlated) error; taken as white")
        }
        (_, Some(c), Some(m)) => eprintln!(
            "{gnss}: the fixes carry a lasting error: {} (measured over {} fixes: −2 log-likelihood {:.0} → {:.0}, \
             needed a fall of {:.1}); estimated as a state",
            describe(m),
            c.fixes,
            c.cost_white,
            c.cost,
            c.critical
        ),
        (_, Some(c), None) => eprintln!(
            "{gnss}: no significant lasting error in the fixes (best {} lowers −2 log-likelihood by {:.1}, needed \
             {:.1}); their errors taken as white",
            describe(&c.best),
            c.cost_white - c.cost,
            c.critical
        ),
    }
}

fn report_time_offset(mode: TimeOffset, measured: Option<&TimeOffsetMeasurement>, imu: &str) {
    match (mode, measured) {
        (TimeOffset::Fixed(v), _) => {
            eprintln!("{imu}: time tags moved back by the given {:.1} ms (--imu-time-offset)", v * 1e3);
        }
        (TimeOffset::Auto, None) => eprintln!(
            "note: {imu}: too few fixes to measure the IMU's time offset against the GNSS; tags taken as they are"
        ),
        (TimeOffset::Auto, Some(m)) if m.at_edge => eprintln!(
            "warning: {imu}: the innovations fit best at the edge of the ±{:.1} s searched for the IMU's time \
             offset against the GNSS; tags taken as they are (give --imu-time-offset if the offset is known)",
            plumbline_navigation::TIME_OFFSET_SEARCH
        ),
        (TimeOffset::Auto, Some(m)) if m.significant() => eprintln!(
            "{imu}: time tags lag the GNSS by {:.1} ms (measured over {} fixes: the innovations' χ² sum {:.0} → \
             {:.0}; the drive's fifths {}); moved back by it",
            m.offset * 1e3,
            m.fixes,
            m.cost_at_zero,
            m.cost,
            milliseconds(&m.segments)
        ),
        (TimeOffset::Auto, Some(m)) => eprintln!(
            "{imu}: no significant time offset against the GNSS (best {:.1} ms lowers the innovations' χ² sum by \
             {:.1}, needed {:.1}; the drive's fifths {} agree to t = {:.1}, needed {:.1}); tags taken as they are",
            m.best * 1e3,
            m.cost_at_zero - m.cost,
            m.critical,
            milliseconds(&m.segments),
            m.t,
            plumbline_navigation::TIME_OFFSET_T_CRITICAL
        ),
    }
}

/// Offsets in ms, e.g. "55/61/58 ms".
fn milliseconds(offsets: &[f64]) -> String {
    let v: Vec<String> = offsets.iter().map(|o| format!("{:.0}", o * 1e3)).collect();
    format!("{} ms", v.join("/"))
}

/// Skipped fixes named one by one on stderr (all of them are in `summary.json`).
const SKIPPED_LISTED: usize = 10;

/// Run `navigate`.
pub async fn run(ctx: &Context, args: Args) -> anyhow::Result<ExitCode> {
    let adaptation = Adaptation { alpha: args.alpha, window: args.window, ..Adaptation::default() };
    adaptation.check().or_invalid("--alpha/--window")?;
    let step_test = StepTest { alpha: args.alpha, min_step: args.min_step, ..StepTest::default() };
    step_test.check().or_invalid("--alpha/--min-step")?;
    let datasheet = datasheet_of(ctx, &args.imu_model).await?;
    let gnss = files::gnss(&ctx.read(&args.gnss).await?, file_name(&args.gnss))?;
    let from_crs = match args.epsg {
        Some(epsg) => Some(place_from_crs(epsg, &gnss, file_name(&args.gnss))?),
        None => None,
    };
    let latitude = args.latitude.or(from_crs.map(|p| p.0));
    let convergence = from_crs.map_or(0.0, |p| p.1);
    let earth = match latitude {
        Some(deg) => Earth::Wgs84 { latitude: deg.to_radians(), convergence },
        None => {
            eprintln!(
                "note: no --latitude or --epsg: flat, non-rotating Earth with standard gravity (simulated data); \
                 real IMU data senses Earth rotation (15 °/h) and needs one of them"
            );
            Earth::Flat { gravity: STANDARD_GRAVITY }
        }
    };
    earth.check().or_invalid("--latitude")?;
    let imu = files::imu(&ctx.read(&args.imu).await?, file_name(&args.imu))?;
    let imu_name = file_name(&args.imu).to_owned();
    let lever = Vec3::new(args.lever_arm[0], args.lever_arm[1], args.lever_arm[2]);
    eprintln!(
        "IMU model {}: gyro bias {} °/h (instability {} °/h), ARW {} °/√h; accelerometer bias {} mg \
         (instability {} µg), VRW {} m/s/√h",
        args.imu_model,
        datasheet.gyro_bias_deg_per_h,
        datasheet.gyro_bias_instability_deg_per_h,
        datasheet.angle_random_walk_deg_per_sqrt_h,
        datasheet.accel_bias_mg,
        datasheet.accel_bias_instability_ug,
        datasheet.velocity_random_walk_m_per_s_per_sqrt_h
    );
    let (model, noise) = noise_floor(&datasheet, &imu, &imu_name);
    let vehicle = (!args.no_vehicle_constraint).then(VehicleConstraint::default);
    let gaps = (!args.ignore_imu_gaps).then(ImuGapModel::default);
    let given = match args.gnss_error {
        GnssErrorArg::Given(m) => Some(m),
        GnssErrorArg::Auto | GnssErrorArg::None => None,
    };
    if let Some(g) = &given {
        g.check().or_invalid("--gnss-error")?;
    }
    let config = NavConfig { imu: model, lever_arm: lever, earth, vehicle, gaps, gnss_error: None };
    config.check().or_invalid("navigation config")?;
    let integrity = if args.no_adapt { Integrity::None } else { args.integrity };
    let gnss_name = file_name(&args.gnss).to_owned();
    let screened = screen_fixes(&gnss, &Plausibility::default());
    report_screened(&screened.rejected, gnss.len(), &gnss_name);
    let rejected = screened.rejected.clone();
    let time_offset = args.imu_time_offset;
    let gnss_error = args.gnss_error;
    let (forward, trajectory, flags, initial, diverged, steps, mounting, measured_offset, fix_noise, correlation) =
        tokio::task::spawn_blocking(move || -> anyhow::Result<_> {
            let Screened { kept: gnss, index, .. } = screened;
            let mut imu = imu;
            if let TimeOffset::Fixed(offset) = time_offset {
                shift_samples(&mut imu, offset);
            }
            let alignment = AlignmentConfig::default();
            let mut initial = align(&imu, &gnss, &lever, &alignment).or_invalid("coarse alignment")?;
            let name = |e| files::name_sample(e, &imu_name);
            // The IMU's mounting in the vehicle, for the vehicle constraint.
            let mut config = config;
            let mounting = if config.vehicle.is_some() {
                measure_mounting(&imu, &gnss, &initial, &config).map_err(name)?
            } else {
                None
            };
            if let (Some(vehicle), Some(m)) = (config.vehicle.as_mut(), mounting) {
                vehicle.mounting = m.mounting;
            }
            // The IMU's time-tag lag, then everything again on the corrected tags.
            let measured_offset = match time_offset {
                TimeOffset::Auto => measure_time_offset(&imu, &gnss, &initial, &config).map_err(name)?,
                TimeOffset::Fixed(_) => None,
            };
            if let Some(m) = measured_offset.as_ref().filter(|m| m.significant()) {
                shift_samples(&mut imu, m.offset);
                initial = align(&imu, &gnss, &lever, &alignment).or_invalid("coarse alignment")?;
            }
            // The fixes' lasting error, after the mounting and the time offset (those are measured against
            // white fixes) and after the step test (its exclusions stand for the measurement and the final
            // pass).
            let (mut forward, steps) = match integrity {
                Integrity::Steps => {
                    let (forward, steps) = filter_screened(&imu, &gnss, &initial, &config, &step_test).map_err(name)?;
                    (Some(forward), Some(steps))
                }
                Integrity::Online | Integrity::None => (None, None),
            };
            let excluded = steps.as_ref().map_or(Vec::new(), |s| s.excluded.clone());
            let correlation = match gnss_error {
                GnssErrorArg::Auto => {
                    measure_gnss_correlation(&imu, &gnss, &initial, &config, &excluded).map_err(name)?
                }
                GnssErrorArg::None | GnssErrorArg::Given(_) => None,
            };
            config.gnss_error = given.or(correlation.and_then(|c| c.model()));
            if config.gnss_error.is_some() {
                forward = None;
            }
            let mut forward = match (forward, integrity) {
                (Some(forward), _) => forward,
                (None, Integrity::Steps) => {
                    filter_excluding(&imu, &gnss, &initial, &config, &excluded).map_err(name)?
                }
                (None, Integrity::Online) => {
                    filter_adaptive(&imu, &gnss, &initial, &config, &adaptation).map_err(name)?
                }
                (None, Integrity::None) => filter(&imu, &gnss, &initial, &config).map_err(name)?,
            };
            let steps = steps.map(|mut s| {
                for e in &mut s.episodes {
                    e.first_fix = index[e.first_fix];
                }
                s
            });
            // The fixes' scatter against their σ (numbered as the filter saw them).
            let fix_noise = measure_fix_noise(&forward, &gnss);
            // Fix numbers back to the file's, past the fixes screened out.
            forward.innovations.iter_mut().for_each(|i| i.fix = index[i.fix]);
            for s in &mut forward.skipped {
                s.fix = index[s.fix];
                s.reason = renumber(s.reason.clone(), s.fix);
            }
            // A runaway or a smoother failure still leaves the filter's record to be written.
            let diverged = divergences(&forward, &Physics::for_unit(config.imu.accel_bias, config.imu.gyro_bias));
            let trajectory = match diverged.first() {
                Some(d) => Err(anyhow::anyhow!(
                    "the filter diverged in {} span(s); the first from time {:.2} s to {:.2} s ({}, speed up to {:.1} \
                 m/s): its IMU model does not fit the data (try a worse --imu-model class) or the GNSS it trusted \
                 was wrong",
                    diverged.len(),
                    d.start,
                    d.end,
                    runaway_text(d.first),
                    d.max_speed
                )),
                None => smooth(&forward)
                    .context("RTS smoother")
                    .and_then(|smoothed| to_trajectory(&smoothed).context("smoothed trajectory")),
            };
            let tests = IntegrityConfig { alpha: adaptation.alpha, window: adaptation.window };
            let flags = test_innovations(&forward.innovations, &tests).context("innovation tests")?;
            let correlation = (correlation, config.gnss_error);
            Ok((
                forward,
                trajectory,
                flags,
                initial,
                diverged,
                steps,
                mounting,
                measured_offset,
                fix_noise,
                correlation,
            ))
        })
        .await
        .context("navigation task")??;
    let prefix = if args.out.ends_with('/') { args.out.clone() } else { format!("{}/", args.out) };
    ctx.write(&format!("{prefix}innovations.csv"), output::innovations_csv(&forward)).await?;
    ctx.write(&format!("{prefix}flags.csv"), output::flags_csv(&flags)).await?;
    report_imu_gaps(forward.imu_gaps(), file_name(&args.imu));
    if let Some(m) = &mounting {
        eprintln!(
            "IMU mounting measured over {:.0} s of straight driving: yaw {:.2}°, pitch {:.2}° against the vehicle's \
             axes (the vehicle constraint holds the vehicle's lateral and vertical velocity)",
            m.seconds,
            m.mounting.yaw.to_degrees(),
            m.mounting.pitch.to_degrees()
        );
    } else if config.vehicle.is_some() {
        eprintln!(
            "note: too little straight driving to measure the IMU's mounting; the vehicle constraint takes the IMU's axes as the vehicle's"
        );
    }
    report_time_offset(time_offset, measured_offset.as_ref(), &imu_name_of(&args));
    report_gnss_error(args.gnss_error, &correlation, &gnss_name);
    if let Some(steps) = &steps {
        report_steps(steps, &gnss_name);
    }
    let consistency = output::consistency(&forward, &flags, args.alpha);
    report_consistency(&consistency, &args.imu_model);
    report_fix_noise(fix_noise.as_ref(), &gnss_name);
    let mut summary = output::summary(&forward, &flags, &initial, integrity != Integrity::None);
    summary["integrity"] = output::integrity_name(integrity).into();
    summary["consistency"] = serde_json::to_value(consistency)?;
    summary["steps"] = serde_json::to_value(&steps)?;
    summary["screened_fixes"] = serde_json::to_value(&rejected)?;
    summary["fix_noise"] = serde_json::to_value(fix_noise)?;
    summary["imu_gaps"] = serde_json::to_value(forward.imu_gaps())?;
    summary["mounting"] = serde_json::to_value(mounting)?;
    summary["gnss_error"] = serde_json::json!({
        "mode": match args.gnss_error {
            GnssErrorArg::Auto => "auto",
            GnssErrorArg::None => "none",
            GnssErrorArg::Given(_) => "given",
        },
        "model": correlation.1,
        "measurement": correlation.0,
    });
    summary["imu_time_offset"] = serde_json::json!({
        "mode": if time_offset == TimeOffset::Auto { "auto" } else { "given" },
        "offset_s": match time_offset {
            TimeOffset::Fixed(v) => v,
            TimeOffset::Auto => measured_offset.as_ref().map_or(0.0, |m| m.offset),
        },
        "measurement": &measured_offset,
    });
    summary["imu_model"] = output::imu_model(&args.imu_model, &datasheet, noise.as_ref(), &config.imu);
    summary["earth"] = match earth {
        Earth::Wgs84 { latitude, convergence } => serde_json::json!({
            "model": "wgs84",
            "latitude_deg": latitude.to_degrees(),
            "convergence_deg": convergence.to_degrees(),
            "latitude_from": if args.latitude.is_some() { "--latitude".to_owned() } else { format!("EPSG:{}", args.epsg.unwrap_or_default()) },
        }),
        Earth::Flat { gravity } => serde_json::json!({"model": "flat", "gravity_mps2": gravity}),
    };
    summary["divergences"] = serde_json::to_value(&diverged)?;
    if let Err(e) = &trajectory {
        summary["trajectory_error"] = format!("{e:#}").into();
    }
    ctx.write(&format!("{prefix}summary.json"), serde_json::to_vec_pretty(&summary)?).await?;
    let trajectory = trajectory.context(format!(
        "no trajectory written; {prefix}innovations.csv, flags.csv and summary.json record what the filter did"
    ))?;
    ctx.write(&format!("{prefix}trajectory.csv"), output::trajectory_csv(&trajectory)).await?;
    eprintln!(
        "navigated {} IMU epochs with {} fixes: {} flags, {} fixes skipped",
        forward.len(),
        forward.innovations.len(),
        flags.len(),
        forward.skipped.len()
    );
    for s in forward.skipped.iter().take(SKIPPED_LISTED) {
        // Fix indices are 0-based data rows: the file's line is two further on (1-based, after the header).
        eprintln!("warning: {gnss_name} line {}: fix skipped: {}", s.fix + 2, s.reason);
    }
    if forward.skipped.len() > SKIPPED_LISTED {
        eprintln!("warning: {gnss_name}: {} more fixes skipped (summary.json)", forward.skipped.len() - SKIPPED_LISTED);
    }
    println!("{prefix}summary.json");
    Ok(ExitCode::SUCCESS)
}
