//! Tests of the CSV reader and writer: layouts, units, conventions, errors, round trips.

// Tests panic on unexpected errors by design.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use proptest::prelude::*;

use super::*;
use crate::attitude::NovatelAttitude;
use plumbline_testkit::mutation::{edits, mutate};

const APPLANIX: AttitudeConvention = AttitudeConvention::Applanix;

fn parse(text: &str) -> ParsedCsv {
    parse_csv(text.as_bytes(), "t.csv", APPLANIX).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// Parse `input` and compare the error message with `expect`.
fn check(input: &str, expect: &str) {
    match parse_csv(input.as_bytes(), "t.csv", APPLANIX) {
        Ok(parsed) => panic!("expected the error\n  {expect}\nbut parsed\n  {parsed:?}\nfrom\n{input}"),
        Err(e) => assert_eq!(e.to_string(), expect, "input:\n{input}"),
    }
}

const HEADER: &str = "time,easting,northing,height,roll,pitch,heading";

#[test]
fn unit_and_value_errors_name_line_column_and_text() {
    let row = "0.5,500000.25,5800000.5,45.125,1.5,-2.25,270.0";
    let cases = [
        (
            format!("time,easting[deg],northing,height,roll,pitch,heading\n{row}"),
            r#"t.csv line 1, column "easting": unit "deg" is an angle, but the column holds a length; use [m]"#,
        ),
        (
            format!("time,easting,northing,height,roll[m],pitch,heading\n{row}"),
            r#"t.csv line 1, column "roll": unit "m" is a length, but the column holds an angle; use [deg] or [rad]"#,
        ),
        (
            format!("time[ms],easting,northing,height,roll,pitch,heading\n{row}"),
            r#"t.csv line 1, column "time": unknown unit "ms"; use [s]"#,
        ),
        (
            format!("time,easting,northing,height,roll[deg,pitch,heading\n{row}"),
            r#"t.csv line 1, column "roll": malformed unit in "roll[deg"; write name[unit]"#,
        ),
        (format!("{HEADER}\n# comment\n0.5,1,2,3,NaN,0,0"), r#"t.csv line 3, column "roll": "NaN" is not finite"#),
        (format!("{HEADER}\n\n{row}\ninf,1,2,3,0,0,0"), r#"t.csv line 4, column "time": "inf" is not finite"#),
        (format!("{HEADER}\n0.5,1,2,3,0,abc,0"), r#"t.csv line 2, column "pitch": "abc" is not a number"#),
        (format!("{HEADER}\n0.5,1,2,,0,0,0"), r#"t.csv line 2, column "height": "" is not a number"#),
        (
            "time,latitude[rad],longitude,height,roll,pitch,heading\n0,1e307,2,3,0,0,0".to_owned(),
            r#"t.csv line 2, column "latitude": "1e307" is not finite"#,
        ),
        (format!("{HEADER}\n0.5,1,2,3,0,0"), "t.csv line 2: 6 fields, but the header has 7"),
        (
            "time;easting;northing;height;roll;pitch;heading\n0,5;1;2;3;0;0;0".to_owned(),
            r#"t.csv line 2, column "time": "0,5" is not a number"#,
        ),
    ];
    for (input, expect) in cases {
        check(&input, expect);
    }
}

#[test]
fn header_errors_name_the_columns() {
    check(
        "time,easting,northing,height,roll,pitch,heading,std_easting,std_northing\n",
        "t.csv: standard deviations need all six std_ columns or none; missing std_height, std_roll, std_pitch, std_heading",
    );
    check(
        "time,easting,northing,height,pitch,heading\n",
        r#"t.csv: missing column "roll"; header found: time, easting, northing, height, pitch, heading"#,
    );
    check(
        "time,easting,height,roll,pitch,heading\n",
        r#"t.csv: missing column "northing"; header found: time, easting, height, roll, pitch, heading"#,
    );
    check(
        "time,height,roll,pitch,heading\n",
        "t.csv: no position columns (need easting,northing or latitude,longitude); header found: time, height, roll, pitch, heading",
    );
    check(
        "time,easting,northing,latitude,longitude,height,roll,pitch,heading\n",
        "t.csv: both projected (easting/northing) and geographic (latitude/longitude) columns; keep one set",
    );
    check(&format!("{HEADER},azimuth\n"), r#"t.csv line 1: column "azimuth" holds the same field as column "heading""#);
    check("# only a comment\n\n  \n", "t.csv: no header line (the file is empty or holds only comments)");
}

#[test]
fn invalid_utf8_names_the_line() {
    let err = parse_csv(b"time,easting\n1,2\n\xff,3\n", "t.csv", APPLANIX).unwrap_err();
    assert_eq!(err.to_string(), "t.csv line 3: not valid UTF-8 text");
}

/// Columns of one record as (header cell, value) pairs, with σ.
fn columns() -> Vec<(&'static str, &'static str)> {
    vec![
        ("time[s]", "1000.5"),
        ("easting[m]", "500100.25"),
        ("northing", "5800200.5"),
        ("height[m]", "45.125"),
        ("roll[deg]", "1.5"),
        ("pitch", "-2.25"),
        ("heading[deg]", "270"),
        ("std_easting", "0.02"),
        ("std_northing[m]", "0.03"),
        ("std_height", "0.05"),
        ("std_roll[deg]", "0.01"),
        ("std_pitch", "0.02"),
        ("std_heading[deg]", "0.1"),
    ]
}

fn csv_of(columns: &[(&str, &str)], separator: &str) -> String {
    let header: Vec<_> = columns.iter().map(|c| c.0).collect();
    let row: Vec<_> = columns.iter().map(|c| c.1).collect();
    format!("{}\n{}\n", header.join(separator), row.join(separator))
}

#[test]
fn values_land_in_the_right_fields_in_canonical_units() {
    let r = parse(&csv_of(&columns(), ",")).trajectory.records[0];
    assert_eq!((r.time, r.x, r.y, r.z), (1000.5, 500100.25, 5800200.5, 45.125));
    assert_eq!(r.attitude, Attitude::from_degrees(1.5, -2.25, 270.0));
    let s = r.std.unwrap();
    assert_eq!((s.east, s.north, s.height), (0.02, 0.03, 0.05));
    assert_eq!((s.roll, s.pitch, s.heading), (0.01f64.to_radians(), 0.02f64.to_radians(), 0.1f64.to_radians()));
}

#[test]
fn column_order_does_not_matter() {
    let reference = parse(&csv_of(&columns(), ","));
    let n = columns().len();
    for k in 0..n {
        for reverse in [false, true] {
            let mut cols = columns();
            cols.rotate_left(k);
            if reverse {
                cols.reverse();
            }
            assert_eq!(parse(&csv_of(&cols, ",")), reference, "rotation {k}, reversed {reverse}");
        }
    }
}

#[test]
fn semicolons_whitespace_comments_crlf_and_bom_are_accepted() {
    let reference = parse(&csv_of(&columns(), ","));
    assert_eq!(parse(&csv_of(&columns(), ";")), reference);
    let messy =
        format!("\u{feff}# exported by hand\r\n\r\n{}", csv_of(&columns(), " ;\t").replace('\n', "\r\n# x\r\n"));
    assert_eq!(parse(&messy), reference);
}

#[test]
fn radians_and_degrees_give_the_same_attitude() {
    let (roll, pitch, heading): (f64, f64, f64) = (0.05, -0.1, 4.0);
    let deg = format!(
        "time,easting,northing,height,roll[deg],pitch[deg],heading[deg]\n0,1,2,3,{},{},{}",
        roll.to_degrees(),
        pitch.to_degrees(),
        heading.to_degrees()
    );
    let rad =
        format!("time,easting,northing,height,roll[rad],pitch[rad],heading[rad]\n0,1,2,3,{roll},{pitch},{heading}");
    let (a, b) = (parse(&deg).trajectory.records[0].attitude, parse(&rad).trajectory.records[0].attitude);
    assert_eq!(b, Attitude::new(roll, pitch, heading));
    for (x, y) in [(a.roll, b.roll), (a.pitch, b.pitch), (a.heading, b.heading)] {
        assert!((x - y).abs() < 1e-15, "{a:?} {b:?}");
    }
}

#[test]
fn geographic_columns_keep_degrees_in_x_longitude_y_latitude() {
    let text = "time,longitude[rad],latitude,height,roll,pitch,azimuth\n7,0.25,52.5,40,0,0,90";
    let parsed = parse(text).trajectory;
    assert_eq!(parsed.horizontal, Horizontal::Geographic);
    let r = parsed.records[0];
    assert_eq!((r.x, r.y, r.z), (0.25f64.to_degrees(), 52.5, 40.0));
    assert_eq!(r.attitude.heading, FRAC_PI_2);
}

#[test]
fn extra_columns_are_ignored_and_reported() {
    let text = format!("speed[m/s],{HEADER},quality\n12,0,1,2,3,0,0,0,ok\n");
    let parsed = parse(&text);
    assert_eq!(parsed.trajectory.records.len(), 1);
    assert_eq!(
        parsed.warnings,
        [
            r#"t.csv line 1: column "speed[m/s]" is not a trajectory column and is ignored"#,
            r#"t.csv line 1: column "quality" is not a trajectory column and is ignored"#,
        ]
    );
}

#[test]
fn novatel_convention_converts_roll_pitch_azimuth() {
    let text = "time,easting,northing,height,roll,pitch,azimuth\n0,1,2,3,8,6,-30";
    let applanix = parse(text).trajectory.records[0].attitude;
    let novatel =
        parse_csv(text.as_bytes(), "t.csv", AttitudeConvention::Novatel).unwrap().trajectory.records[0].attitude;
    let (roll, pitch, azimuth) = (8f64.to_radians(), 6f64.to_radians(), -30f64.to_radians());
    assert_eq!(applanix, Attitude::new(roll, pitch, azimuth));
    assert_eq!(novatel, NovatelAttitude { roll, pitch, azimuth }.to_canonical());
    assert!((0.0..TAU).contains(&novatel.heading), "{novatel:?}");
}

fn sample(horizontal: Horizontal) -> RawTrajectory {
    let std = PoseStd { east: 0.02, north: 0.03, height: 0.05, roll: 1e-4, pitch: 2e-4, heading: 3e-4 };
    let record = |i: u32| RawRecord {
        time: 345_600.0 + f64::from(i) * 0.005,
        x: 13.4 + f64::from(i) * 1e-7,
        y: 52.5,
        z: 40.0,
        attitude: Attitude::new(0.01, -0.02, 3.0),
        std: Some(std),
    };
    RawTrajectory { horizontal, records: (0..3).map(record).collect() }
}

#[test]
fn written_header_has_explicit_units() {
    let text = String::from_utf8(write_csv(&sample(Horizontal::Geographic))).unwrap();
    let header = text.lines().next().unwrap();
    assert_eq!(
        header,
        "time[s],latitude[deg],longitude[deg],height[m],roll[deg],pitch[deg],heading[deg],\
         std_easting[m],std_northing[m],std_height[m],std_roll[deg],std_pitch[deg],std_heading[deg]"
    );
    assert!(text.lines().nth(1).unwrap().starts_with("345600,52.5,13.4,40,0.5729577951,"), "{text}");
}

#[test]
fn extra_columns_are_written_after_the_trajectory() {
    let raw = sample(Horizontal::Projected);
    let corrections = [0.1, -0.25, 1e-9];
    let bytes = write_csv_with_columns(&raw, &[("correction_east[m]", &corrections)]).unwrap();
    let text = String::from_utf8(bytes.clone()).unwrap();
    assert!(text.lines().next().unwrap().ends_with(",std_heading[deg],correction_east[m]"));
    assert!(text.lines().nth(3).unwrap().ends_with(",0.000000001"), "{text}");
    let parsed = parse_csv(&bytes, "t.csv", APPLANIX).unwrap();
    assert_eq!(write_csv(&parsed.trajectory), write_csv(&raw));
    assert_eq!(parsed.warnings.len(), 1);

    let err = write_csv_with_columns(&raw, &[("c[m]", &corrections[..2])]).unwrap_err();
    assert_eq!(err.to_string(), "extra column \"c[m]\" has 2 values for 3 records");
    assert!(matches!(write_csv_with_columns(&raw, &[("a,b", &corrections)]), Err(FormatError::BadColumnName { .. })));
}

fn std_strategy() -> impl Strategy<Value = PoseStd> {
    (0.0..10.0f64, 0.0..10.0f64, 0.0..10.0f64, 0.0..0.1f64, 0.0..0.1f64, 0.0..0.1f64)
        .prop_map(|(east, north, height, roll, pitch, heading)| PoseStd { east, north, height, roll, pitch, heading })
}

fn record_strategy(horizontal: Horizontal, with_std: bool) -> impl Strategy<Value = RawRecord> {
    let (x, y) = match horizontal {
        Horizontal::Projected => (-1e7..1e7f64, -1e7..1e7f64),
        Horizontal::Geographic => (-180.0..180.0f64, -90.0..90.0f64),
    };
    let attitude = (-PI..PI, -FRAC_PI_2..FRAC_PI_2, 0.0..TAU).prop_map(|(r, p, h)| Attitude::new(r, p, h));
    (0.0..1e6f64, x, y, -500.0..9000.0f64, attitude, std_strategy()).prop_map(move |(time, x, y, z, attitude, std)| {
        RawRecord { time, x, y, z, attitude, std: with_std.then_some(std) }
    })
}

fn trajectory_strategy() -> impl Strategy<Value = RawTrajectory> {
    let horizontal = prop_oneof![Just(Horizontal::Projected), Just(Horizontal::Geographic)];
    (horizontal, any::<bool>()).prop_flat_map(|(horizontal, with_std)| {
        prop::collection::vec(record_strategy(horizontal, with_std), 1..8)
            .prop_map(move |records| RawTrajectory { horizontal, records })
    })
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-11
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(5), ..ProptestConfig::default() })]

    #[test]
    fn csv_round_trip(raw in trajectory_strategy()) {
        let bytes = write_csv(&raw);
        let parsed = parse_csv(&bytes, "p.csv", APPLANIX).unwrap();
        prop_assert!(parsed.warnings.is_empty());
        prop_assert_eq!(&write_csv(&parsed.trajectory), &bytes);
        prop_assert_eq!(parsed.trajectory.horizontal, raw.horizontal);
        for (p, r) in parsed.trajectory.records.iter().zip(&raw.records) {
            prop_assert_eq!((p.time, p.x, p.y, p.z), (r.time, r.x, r.y, r.z));
            let (pa, ra) = (p.attitude, r.attitude);
            prop_assert!(close(pa.roll, ra.roll) && close(pa.pitch, ra.pitch) && close(pa.heading, ra.heading));
            match (p.std, r.std) {
                (Some(ps), Some(rs)) => {
                    prop_assert_eq!((ps.east, ps.north, ps.height), (rs.east, rs.north, rs.height));
                    prop_assert!(close(ps.roll, rs.roll) && close(ps.pitch, rs.pitch) && close(ps.heading, rs.heading));
                }
                (None, None) => {}
                other => prop_assert!(false, "std presence changed: {:?}", other),
            }
        }
    }
}

/// A parse either holds at most one record per 13 bytes (7 numbers and 6 separators) and per line, or its
/// error names the input.
fn check_parse(bytes: &[u8]) -> Result<(), TestCaseError> {
    for convention in [APPLANIX, AttitudeConvention::Novatel] {
        match parse_csv(bytes, "in.csv", convention) {
            Ok(parsed) => {
                let records = parsed.trajectory.records.len();
                let lines = bytes.iter().filter(|b| **b == b'\n').count() + 1;
                prop_assert!(records * 13 <= bytes.len() && records < lines, "{records} records");
            }
            Err(e) => prop_assert!(e.to_string().starts_with("in.csv"), "{e}"),
        }
    }
    Ok(())
}

/// CSV-like text: digits, signs, separators, brackets, letters of the column names, line ends.
fn csv_like() -> impl Strategy<Value = String> {
    let header =
        prop_oneof![Just(""), Just(HEADER), Just("time,latitude[rad],longitude,height,roll,pitch,azimuth[deg]")];
    (header, "[0-9eE.+\\-,; \\[\\]#\"a-z_\r\n\u{feff}]{0,4000}").prop_map(|(h, body)| format!("{h}\n{body}"))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(6), ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..4096)) {
        check_parse(&bytes)?;
    }

    #[test]
    fn arbitrary_csv_like_text_never_panics(text in csv_like()) {
        check_parse(text.as_bytes())?;
    }

    #[test]
    fn mutated_csv_parses_or_names_the_input(raw in trajectory_strategy(), edits in edits()) {
        check_parse(&mutate(write_csv(&raw), &edits))?;
    }
}
