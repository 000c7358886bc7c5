//! Tests of the SBET reader and writer and of the SBET(+smrmsg) ↔ raw trajectory conversions.

// Tests panic on unexpected errors by design.

use proptest::prelude::*;

use super::*;
use crate::formats::{raw_to_smrmsg, write_smrmsg};
use plumbline_testkit::mutation::{edits, mutate};

/// Distinct, plausible values in the documented field order.
const FIELD_VALUES: [f64; 17] = [
    345_600.125, // time
    0.916,       // latitude
    0.233,       // longitude
    48.5,        // altitude
    1.25,        // velocity x
    -2.5,        // velocity y
    0.0625,      // velocity z
    0.011,       // roll
    -0.022,      // pitch
    1.2,         // platform heading
    0.3,         // wander angle
    0.1,         // specific force x
    0.2,         // specific force y
    -9.81,       // specific force z
    0.001,       // angular rate x
    0.002,       // angular rate y
    0.003,       // angular rate z
];

fn field_bytes() -> Vec<u8> {
    FIELD_VALUES.iter().flat_map(|v| v.to_le_bytes()).collect()
}

#[test]
fn fields_are_read_in_the_documented_order() {
    let r = parse_sbet(&field_bytes(), "sbet.out").unwrap()[0];
    assert_eq!((r.time, r.latitude, r.longitude, r.altitude), (345_600.125, 0.916, 0.233, 48.5));
    assert_eq!((r.velocity_x, r.velocity_y, r.velocity_z), (1.25, -2.5, 0.0625));
    assert_eq!((r.roll, r.pitch, r.platform_heading, r.wander_angle), (0.011, -0.022, 1.2, 0.3));
    assert_eq!((r.specific_force_x, r.specific_force_y, r.specific_force_z), (0.1, 0.2, -9.81));
    assert_eq!((r.angular_rate_x, r.angular_rate_y, r.angular_rate_z), (0.001, 0.002, 0.003));
    assert_eq!(write_sbet(&[r]), field_bytes());
}

#[test]
fn raw_trajectory_has_degrees_and_true_heading() {
    let sbet = parse_sbet(&field_bytes(), "sbet.out").unwrap();
    let raw = sbet_to_raw(&sbet, None);
    assert_eq!(raw.horizontal, Horizontal::Geographic);
    let r = raw.records[0];
    assert_eq!((r.time, r.x, r.y, r.z), (345_600.125, 0.233f64.to_degrees(), 0.916f64.to_degrees(), 48.5));
    assert_eq!(r.attitude, Attitude::new(0.011, -0.022, 1.2 - 0.3));
    assert_eq!(r.std, None);
}

#[test]
fn truncated_file_names_the_record_and_byte_offset() {
    let bytes = write_sbet(&[SbetRecord::default(); 2]);
    let mut cut = bytes.clone();
    cut.extend_from_slice(&[0u8; 20]);
    let err = parse_sbet(&cut, "day1_sbet.out").unwrap_err();
    assert_eq!(
        err.to_string(),
        "day1_sbet.out: truncated SBET record 2 at byte offset 272: 20 of its 136 bytes present"
    );
    let err = parse_sbet(&bytes[..135], "x").unwrap_err();
    assert!(matches!(err, FormatError::Truncated { index: 0, offset: 0, present: 135, .. }), "{err}");
}

#[test]
fn smrmsg_sigma_is_interpolated_onto_sbet_epochs() {
    let sbet: Vec<_> = [-0.5, 0.25, 1.5].iter().map(|&time| SbetRecord { time, ..SbetRecord::default() }).collect();
    let smrmsg = [
        SmrmsgRecord { time: 0.0, north: 0.1, east: 0.2, down: 0.3, heading_arcmin: 6.0, ..SmrmsgRecord::default() },
        SmrmsgRecord { time: 1.0, north: 0.5, east: 0.2, down: 0.3, heading_arcmin: 12.0, ..SmrmsgRecord::default() },
    ];
    let raw = sbet_to_raw(&sbet, Some(&smrmsg));
    let std: Vec<_> = raw.records.iter().map(|r| r.std.unwrap()).collect();
    assert_eq!((std[0].north, std[0].east, std[0].height), (0.1, 0.2, 0.3));
    assert!((std[0].heading - 0.1f64.to_radians()).abs() < 1e-18);
    assert!((std[1].north - 0.2).abs() < 1e-15);
    assert!((std[1].heading - 0.125f64.to_radians()).abs() < 1e-15);
    assert_eq!(std[2].north, 0.5);
    assert!((std[2].heading - 0.2f64.to_radians()).abs() < 1e-15);
}

fn geographic(records: Vec<RawRecord>) -> RawTrajectory {
    RawTrajectory { horizontal: Horizontal::Geographic, records }
}

fn at(time: f64, lon_deg: f64, lat_deg: f64, h: f64) -> RawRecord {
    RawRecord { time, x: lon_deg, y: lat_deg, z: h, attitude: Attitude::new(0.01, -0.02, 2.0), std: None }
}

#[test]
fn velocities_come_from_positions_in_the_local_tangent_plane() {
    // At 45° on WGS 84 the meridian radius is 6 367 381.8 m and the prime-vertical one 6 388 838.3 m, so
    // 1 µrad/s of latitude is 6.3674 m/s north and 1 µrad/s of longitude 4.5175 m/s east.
    let step = 1e-6f64.to_degrees();
    let north: Vec<_> = (0..3).map(|i| at(f64::from(i), 10.0, 45.0 + f64::from(i) * step, 0.0)).collect();
    let sbet = raw_to_sbet(&geographic(north)).unwrap();
    for r in &sbet {
        assert!((r.velocity_x - 6.367_381_8).abs() < 1e-6 && r.velocity_y.abs() < 1e-12, "{r:?}");
    }
    let east: Vec<_> =
        (0..3).map(|i| at(f64::from(i), 10.0 + f64::from(i) * step, 45.0, 100.0 - f64::from(i))).collect();
    let sbet = raw_to_sbet(&geographic(east)).unwrap();
    let expected = (6_388_838.3 + 99.0) * 45f64.to_radians().cos() * 1e-6;
    assert!((sbet[1].velocity_y - expected).abs() < 1e-6, "{:?}", sbet[1]);
    assert_eq!(sbet[1].velocity_z, 1.0);
    assert_eq!(raw_to_sbet(&geographic(vec![at(0.0, 1.0, 2.0, 3.0)])).unwrap()[0].velocity_x, 0.0);
}

#[test]
fn longitude_steps_across_the_antimeridian_stay_small() {
    let records = vec![at(0.0, 179.999_99, 0.0, 0.0), at(1.0, -179.999_99, 0.0, 0.0)];
    let sbet = raw_to_sbet(&geographic(records)).unwrap();
    assert!(sbet[0].velocity_y > 2.0 && sbet[0].velocity_y < 2.5, "{:?}", sbet[0]);
}

#[test]
fn projected_trajectories_are_refused() {
    let raw = RawTrajectory { horizontal: Horizontal::Projected, records: vec![at(0.0, 1.0, 2.0, 3.0)] };
    let err = raw_to_sbet(&raw).unwrap_err();
    assert_eq!(
        err.to_string(),
        "SBET holds geographic coordinates (latitude/longitude), but the trajectory is projected"
    );
}

#[test]
fn raw_to_sbet_and_smrmsg_and_back_keeps_the_trajectory() {
    let std =
        crate::trajectory::PoseStd { east: 0.02, north: 0.03, height: 0.05, roll: 1e-4, pitch: 2e-4, heading: 3e-4 };
    let records: Vec<_> = (0..4).map(|i| RawRecord { std: Some(std), ..at(f64::from(i), 13.4, 52.5, 40.0) }).collect();
    let raw = geographic(records);
    let sbet = parse_sbet(&write_sbet(&raw_to_sbet(&raw).unwrap()), "s").unwrap();
    let smrmsg = parse_smrmsg_bytes(&write_smrmsg(&raw_to_smrmsg(&raw)));
    let back = sbet_to_raw(&sbet, Some(&smrmsg));
    for (b, r) in back.records.iter().zip(&raw.records) {
        assert!((b.x - r.x).abs() < 1e-12 && (b.y - r.y).abs() < 1e-12 && b.z == r.z);
        assert_eq!(b.attitude, r.attitude);
        let (bs, rs) = (b.std.unwrap(), r.std.unwrap());
        assert_eq!((bs.east, bs.north, bs.height), (rs.east, rs.north, rs.height));
        assert!((bs.heading - rs.heading).abs() < 1e-17);
    }
}

fn parse_smrmsg_bytes(bytes: &[u8]) -> Vec<SmrmsgRecord> {
    crate::formats::parse_smrmsg(bytes, "smrmsg").unwrap()
}

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![-1e7f64..1e7, any::<f64>().prop_filter("finite", |v| v.is_finite())]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(11), ..ProptestConfig::default() })]

    #[test]
    fn sbet_bytes_round_trip(values in prop::collection::vec(prop::array::uniform17(any_f64()), 1..8)) {
        // Latitudes within ±π/2 and longitudes within ±2π: the parser refuses others.
        let valid = |mut a: [f64; 17]| { a[1] %= 1.5; a[2] %= 6.0; a };
        let records: Vec<_> = values.into_iter().map(|a| SbetRecord::from_array(valid(a))).collect();
        let bytes = write_sbet(&records);
        prop_assert_eq!(bytes.len(), records.len() * SBET_RECORD_LEN);
        let parsed = parse_sbet(&bytes, "p").unwrap();
        prop_assert_eq!(&parsed, &records);
        prop_assert_eq!(write_sbet(&parsed), bytes);
    }

    #[test]
    fn smrmsg_bytes_round_trip(values in prop::collection::vec(prop::array::uniform10(any_f64()), 1..8)) {
        // Position and attitude σ are non-negative: the parser refuses others.
        let valid = |mut a: [f64; 10]| { for i in [1, 2, 3, 7, 8, 9] { a[i] = a[i].abs(); } a };
        let records: Vec<_> = values.into_iter().map(|a| SmrmsgRecord::from_array(valid(a))).collect();
        let bytes = write_smrmsg(&records);
        let parsed = crate::formats::parse_smrmsg(&bytes, "p").unwrap();
        prop_assert_eq!(&parsed, &records);
        prop_assert_eq!(write_smrmsg(&parsed), bytes);
    }
}

/// A binary parse either holds exactly the records the length allows, or names the input.
fn check_binary<R>(bytes: &[u8], record_len: usize, outcome: Result<Vec<R>, FormatError>) -> Result<(), TestCaseError> {
    match outcome {
        Ok(records) => {
            prop_assert!(bytes.len().is_multiple_of(record_len) && records.len() == bytes.len() / record_len)
        }
        Err(e) if !bytes.len().is_multiple_of(record_len) => {
            prop_assert!(e.to_string().starts_with("in.bin: truncated"), "{e}");
        }
        // Whole records, but none, or one with a value its field cannot hold: named by record and field.
        Err(e) => prop_assert!(
            matches!(e, FormatError::Empty { .. } | FormatError::BadValue { .. })
                && e.to_string().starts_with("in.bin: "),
            "{e}"
        ),
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(12), ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic_sbet_or_smrmsg(bytes in prop::collection::vec(any::<u8>(), 0..4096)) {
        check_binary(&bytes, SBET_RECORD_LEN, parse_sbet(&bytes, "in.bin"))?;
        check_binary(&bytes, crate::formats::smrmsg::SMRMSG_RECORD_LEN, crate::formats::parse_smrmsg(&bytes, "in.bin"))?;
    }

    #[test]
    fn mutated_sbet_and_smrmsg_parse_or_name_the_input(n in 0usize..6, edits in edits()) {
        let sbet = mutate(write_sbet(&vec![SbetRecord::from_array(FIELD_VALUES); n]), &edits);
        check_binary(&sbet, SBET_RECORD_LEN, parse_sbet(&sbet, "in.bin"))?;
        let smrmsg = write_smrmsg(&vec![SmrmsgRecord::from_array([0.5; 10]); n]);
        let smrmsg = mutate(smrmsg, &edits);
        check_binary(&smrmsg, crate::formats::smrmsg::SMRMSG_RECORD_LEN, crate::formats::parse_smrmsg(&smrmsg, "in.bin"))?;
    }
}

#[test]
fn empty_files_and_impossible_values_are_named_by_record_and_field() {
    use crate::formats::parse_smrmsg;
    let e = parse_sbet(&[], "dg.sbet").unwrap_err();
    assert_eq!(e.to_string(), "dg.sbet: empty (0 bytes): no SBET record");
    let e = parse_smrmsg(&[], "dg.smrmsg").unwrap_err();
    assert_eq!(e.to_string(), "dg.smrmsg: empty (0 bytes): no smrmsg record");
    let good = SbetRecord { latitude: 0.9, longitude: 0.17, ..SbetRecord::default() };
    let mut records = vec![good; 4];
    records[2].latitude = f64::NAN;
    let e = parse_sbet(&write_sbet(&records), "dg.sbet").unwrap_err();
    assert!(e.to_string().starts_with("dg.sbet: SBET record 2, field `latitude`: NaN"), "{e}");
    records[2].latitude = 2.0;
    assert!(parse_sbet(&write_sbet(&records), "dg.sbet").is_err(), "beyond ±π/2");
    let mut sigmas = vec![SmrmsgRecord { north: 0.02, ..SmrmsgRecord::default() }; 3];
    sigmas[1].east = -0.1;
    let e = parse_smrmsg(&write_smrmsg(&sigmas), "dg.smrmsg").unwrap_err();
    assert!(
        e.to_string().starts_with("dg.smrmsg: smrmsg record 1, field `east`: -0.1 is not a standard deviation"),
        "{e}"
    );
}
