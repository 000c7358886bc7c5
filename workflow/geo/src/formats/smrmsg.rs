//! Applanix smrmsg: the one-sigma (RMS) errors that accompany an SBET, usually at a lower rate (e.g. 1 Hz).
//!
//! Binary, no header: records of 10 little-endian `f64` (80 bytes), in this order:
//!
//! | # | field | unit |
//! |---|---|---|
//! | 0 | time | s (GPS seconds of week) |
//! | 1–3 | north, east, down position σ | m |
//! | 4–6 | north, east, down velocity σ | m/s |
//! | 7–9 | roll, pitch, heading σ | **arc-minutes** |
//!
//! The arc-minute unit of the attitude σ follows Applanix POSPac's export description (also documented by
//! NOAA's `kluster` SBET/smrmsg reader); it is converted to radians only when the σ enter a
//! [`RawTrajectory`] (see [`crate::formats::sbet_to_raw`]).

use super::binary::{check_records, read_records, write_records};
use super::{FormatError, RawTrajectory};
use crate::trajectory::PoseStd;

/// Bytes of one smrmsg record.
pub const SMRMSG_RECORD_LEN: usize = 80;
const FIELDS: usize = 10;
const FORMAT: &str = "smrmsg";

/// One smrmsg epoch: one-sigma errors in the local level (north, east, down) frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SmrmsgRecord {
    /// Time, seconds.
    pub time: f64,
    /// North position σ, m.
    pub north: f64,
    /// East position σ, m.
    pub east: f64,
    /// Down position σ, m.
    pub down: f64,
    /// North velocity σ, m/s.
    pub velocity_north: f64,
    /// East velocity σ, m/s.
    pub velocity_east: f64,
    /// Down velocity σ, m/s.
    pub velocity_down: f64,
    /// Roll σ, arc-minutes.
    pub roll_arcmin: f64,
    /// Pitch σ, arc-minutes.
    pub pitch_arcmin: f64,
    /// Heading σ, arc-minutes.
    pub heading_arcmin: f64,
}

impl SmrmsgRecord {
    /// The fields in file order.
    pub fn to_array(&self) -> [f64; FIELDS] {
        [
            self.time,
            self.north,
            self.east,
            self.down,
            self.velocity_north,
            self.velocity_east,
            self.velocity_down,
            self.roll_arcmin,
            self.pitch_arcmin,
            self.heading_arcmin,
        ]
    }

    /// A record from the fields in file order.
    pub fn from_array(a: [f64; FIELDS]) -> Self {
        let [time, north, east, down, velocity_north, velocity_east, velocity_down, roll, pitch, heading] = a;
        Self {
            time,
            north,
            east,
            down,
            velocity_north,
            velocity_east,
            velocity_down,
            roll_arcmin: roll,
            pitch_arcmin: pitch,
            heading_arcmin: heading,
        }
    }

    /// The pose σ: east/north/height in metres, angles converted from arc-minutes to radians.
    pub fn pose_std(&self) -> PoseStd {
        PoseStd {
            east: self.east,
            north: self.north,
            height: self.down,
            roll: arcmin_to_rad(self.roll_arcmin),
            pitch: arcmin_to_rad(self.pitch_arcmin),
            heading: arcmin_to_rad(self.heading_arcmin),
        }
    }

    /// Field-wise linear interpolation, `w` in [0, 1].
    fn lerp(&self, other: &Self, w: f64) -> Self {
        let (a, b) = (self.to_array(), other.to_array());
        Self::from_array(std::array::from_fn(|i| a[i] + (b[i] - a[i]) * w))
    }
}

/// Parse an smrmsg file; a length that is not a multiple of 80 bytes is an error naming the offset, and so are
/// an empty file, a time that is not finite and a position or attitude σ that is not a finite non-negative
/// number (named by record and field).
pub fn parse_smrmsg(bytes: &[u8], source: &str) -> Result<Vec<SmrmsgRecord>, FormatError> {
    let records = read_records::<FIELDS>(bytes, source, FORMAT)?;
    let sigma: fn(f64) -> bool = |v| v.is_finite() && v >= 0.0;
    let not_sigma = "is not a standard deviation (NaN, infinite or negative)";
    check_records(
        &records,
        source,
        FORMAT,
        &[
            (0, "time", f64::is_finite, "is not finite"),
            (1, "north", sigma, not_sigma),
            (2, "east", sigma, not_sigma),
            (3, "down", sigma, not_sigma),
            (7, "roll_arcmin", sigma, not_sigma),
            (8, "pitch_arcmin", sigma, not_sigma),
            (9, "heading_arcmin", sigma, not_sigma),
        ],
    )?;
    Ok(records.into_iter().map(SmrmsgRecord::from_array).collect())
}

/// Encode smrmsg records.
pub fn write_smrmsg(records: &[SmrmsgRecord]) -> Vec<u8> {
    write_records(records.iter().map(SmrmsgRecord::to_array))
}

/// One smrmsg record per trajectory record that has σ: east/north/height σ as north/east/down, attitude
/// σ in arc-minutes. The velocity σ are unknown to a trajectory and written as 0.
pub fn raw_to_smrmsg(trajectory: &RawTrajectory) -> Vec<SmrmsgRecord> {
    let convert = |(time, s): (f64, PoseStd)| SmrmsgRecord {
        time,
        north: s.north,
        east: s.east,
        down: s.height,
        roll_arcmin: rad_to_arcmin(s.roll),
        pitch_arcmin: rad_to_arcmin(s.pitch),
        heading_arcmin: rad_to_arcmin(s.heading),
        ..SmrmsgRecord::default()
    };
    trajectory.records.iter().filter_map(|r| Some((r.time, r.std?))).map(convert).collect()
}

fn arcmin_to_rad(arcmin: f64) -> f64 {
    (arcmin / 60.0).to_radians()
}

fn rad_to_arcmin(rad: f64) -> f64 {
    rad.to_degrees() * 60.0
}

/// smrmsg records sorted by time, for looking up σ at SBET epochs.
#[derive(Clone, Debug)]
pub(crate) struct StdTrack {
    records: Vec<SmrmsgRecord>,
}

impl StdTrack {
    /// Sort a copy by time (smrmsg exports are not always in order); `None` when there are no records.
    pub(crate) fn new(records: &[SmrmsgRecord]) -> Option<Self> {
        let mut records = records.to_vec();
        records.sort_by(|a, b| a.time.total_cmp(&b.time));
        (!records.is_empty()).then_some(Self { records })
    }

    /// σ at time `t`, linear in time between neighbouring records, clamped to the first/last record.
    pub(crate) fn at(&self, t: f64) -> PoseStd {
        let upper = self.records.partition_point(|r| r.time <= t);
        // `records` is never empty (see `new`).
        if upper == 0 || upper == self.records.len() {
            let end = if upper == 0 { 0 } else { upper - 1 };
            return self.records[end].pose_std();
        }
        let (a, b) = (&self.records[upper - 1], &self.records[upper]);
        let w = (t - a.time) / (b.time - a.time);
        a.lerp(b, w).pose_std()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Attitude;
    use crate::formats::{Horizontal, RawRecord};

    fn sample(time: f64, north: f64, heading_arcmin: f64) -> SmrmsgRecord {
        SmrmsgRecord { time, north, heading_arcmin, ..SmrmsgRecord::default() }
    }

    #[test]
    fn fields_are_read_in_the_documented_order() {
        let values: [f64; 10] = [100.5, 0.01, 0.02, 0.03, 0.004, 0.005, 0.006, 0.7, 0.8, 2.5];
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let r = parse_smrmsg(&bytes, "s.out").unwrap()[0];
        assert_eq!((r.time, r.north, r.east, r.down), (100.5, 0.01, 0.02, 0.03));
        assert_eq!((r.velocity_north, r.velocity_east, r.velocity_down), (0.004, 0.005, 0.006));
        assert_eq!((r.roll_arcmin, r.pitch_arcmin, r.heading_arcmin), (0.7, 0.8, 2.5));
        assert_eq!(write_smrmsg(&[r]), bytes);
        // 6 arc-minutes are 0.1°.
        let s = SmrmsgRecord { heading_arcmin: 6.0, ..r }.pose_std();
        assert!((s.heading - 0.1f64.to_radians()).abs() < 1e-18);
        assert_eq!((s.east, s.north, s.height), (0.02, 0.01, 0.03));
    }

    #[test]
    fn truncated_file_names_the_record_and_offset() {
        let bytes = write_smrmsg(&[sample(0.0, 0.1, 1.0); 3]);
        let err = parse_smrmsg(&bytes[..2 * 80 + 79], "run_smrmsg.out").unwrap_err();
        assert_eq!(
            err.to_string(),
            "run_smrmsg.out: truncated smrmsg record 2 at byte offset 160: 79 of its 80 bytes present"
        );
    }

    #[test]
    fn sigma_interpolates_linearly_and_clamps_at_the_ends() {
        // Out of order on purpose: the track sorts.
        let track = StdTrack::new(&[sample(1.0, 0.3, 12.0), sample(0.0, 0.1, 6.0)]).unwrap();
        let quarter = track.at(0.25);
        assert!((quarter.north - 0.15).abs() < 1e-15);
        assert!((quarter.heading - (7.5f64 / 60.0).to_radians()).abs() < 1e-15);
        assert_eq!(track.at(-5.0).north, 0.1);
        assert_eq!(track.at(1.0).north, 0.3);
        assert_eq!(track.at(9.0).north, 0.3);
        assert!(StdTrack::new(&[]).is_none());
    }

    #[test]
    fn trajectory_sigma_is_written_in_arc_minutes() {
        let std =
            PoseStd { east: 0.02, north: 0.01, height: 0.05, roll: 0.0, pitch: 0.0, heading: 0.1f64.to_radians() };
        let record =
            |time, std| RawRecord { time, x: 0.0, y: 0.0, z: 0.0, attitude: Attitude::new(0.0, 0.0, 0.0), std };
        let raw = RawTrajectory {
            horizontal: Horizontal::Geographic,
            records: vec![record(1.0, Some(std)), record(2.0, None)],
        };
        let out = raw_to_smrmsg(&raw);
        assert_eq!(out.len(), 1);
        assert!((out[0].heading_arcmin - 6.0).abs() < 1e-12);
        assert_eq!((out[0].north, out[0].east, out[0].down), (0.01, 0.02, 0.05));
    }
}
