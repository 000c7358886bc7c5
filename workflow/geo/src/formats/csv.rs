//! Header-driven trajectory CSV: tolerant of column order and extra columns, strict about units and values.
//!
//! # Columns
//! The first line that is neither blank nor a `#` comment is the header. Names are case-insensitive;
//! the unit goes in brackets after the name, and without one the default unit applies.
//!
//! | column | meaning | units (default first) |
//! |---|---|---|
//! | `time` | time, any continuous scale (e.g. GPS seconds of week) | `s` |
//! | `easting`, `northing`, `height` | projected position (heading from grid north) | `m` |
//! | or `latitude`, `longitude`, `height` | geographic position, ellipsoidal height (heading from true north) | `deg`, `rad`; `m` |
//! | `roll`, `pitch`, `heading` | attitude; `heading` may be spelled `azimuth` | `deg`, `rad` |
//! | `std_easting`, `std_northing`, `std_height` | one-sigma position σ (optional) | `m` |
//! | `std_roll`, `std_pitch`, `std_heading` | one-sigma attitude σ (optional; `std_azimuth` too) | `deg`, `rad` |
//!
//! e.g. `time[s],easting[m],northing[m],height[m],roll[deg],pitch[deg],heading[deg]`. The six σ columns
//! come all together or not at all. Columns with other names are ignored and reported as warnings. A unit
//! that is unknown or of the wrong quantity (`easting[deg]`, `roll[m]`) is an error naming the column.
//! Angles are read in the [`AttitudeConvention`] the caller names (NovAtel: roll, pitch, azimuth) and held
//! in the canonical Applanix convention.
//!
//! # Lines
//! The separator is `;` when the header contains one, else `,`. Fields are trimmed; CRLF line ends, a
//! UTF-8 byte-order mark, blank lines and `#` comment lines are accepted. Every value must parse as a
//! finite number; errors name the input, the 1-based line, the column and the text.
//!
//! # Writing
//! [`write_csv`] writes the header with explicit units, times, metres and geographic degrees in shortest
//! round-trip form (exact), and attitude angles in degrees with 10 decimals (1.7e-12 rad), so that
//! write → parse → write reproduces the bytes. Attitude is written in the canonical Applanix convention.

mod header;
#[cfg(test)]
mod tests;

use std::fmt::Write as _;

use header::{Column, Layout, Unit};

use super::{AttitudeConvention, FormatError, Horizontal, RawRecord, RawTrajectory};
use crate::attitude::Attitude;
use crate::trajectory::PoseStd;

/// A parsed CSV trajectory and what was ignored on the way.
#[derive(Clone, Debug, PartialEq)]
pub struct ParsedCsv {
    /// The records, in file order.
    pub trajectory: RawTrajectory,
    /// One message per ignored column.
    pub warnings: Vec<String>,
}

/// Parse a trajectory CSV; `source` labels the input in errors (e.g. the file name).
pub fn parse_csv(bytes: &[u8], source: &str, convention: AttitudeConvention) -> Result<ParsedCsv, FormatError> {
    let text = decode(bytes, source)?;
    let mut lines = data_lines(text);
    let (header_line, header) = lines.next().ok_or_else(|| FormatError::NoHeader { input: source.to_owned() })?;
    let separator = if header.contains(';') { ';' } else { ',' };
    let cells: Vec<&str> = header.split(separator).map(str::trim).collect();
    let (layout, warnings) = header::parse(&cells, header_line, source)?;
    let row = Row { layout: &layout, separator, source, convention };
    let records = lines.map(|(line, text)| row.parse(line, text)).collect::<Result<_, _>>()?;
    Ok(ParsedCsv { trajectory: RawTrajectory { horizontal: layout.horizontal, records }, warnings })
}

/// Write a trajectory as CSV (σ columns when every record has σ; otherwise none).
pub fn write_csv(trajectory: &RawTrajectory) -> Vec<u8> {
    write(trajectory, &[])
}

/// Write a trajectory as CSV with extra per-record columns, e.g. `("correction_east[m]", &values)`.
/// Each name is written as given (include the unit); values are written in shortest round-trip form.
/// Readers of the file ignore these columns (see [`parse_csv`]).
pub fn write_csv_with_columns(trajectory: &RawTrajectory, extra: &[(&str, &[f64])]) -> Result<Vec<u8>, FormatError> {
    for (name, values) in extra {
        if name.trim().is_empty() || name.contains([',', ';', '#', '\n', '\r']) {
            return Err(FormatError::BadColumnName { column: (*name).to_owned() });
        }
        if values.len() != trajectory.records.len() {
            let (expected, found) = (trajectory.records.len(), values.len());
            return Err(FormatError::ColumnLength { column: (*name).to_owned(), expected, found });
        }
    }
    Ok(write(trajectory, extra))
}

/// The text, or the line of the first invalid UTF-8 byte; a leading byte-order mark is dropped.
fn decode<'a>(bytes: &'a [u8], source: &str) -> Result<&'a str, FormatError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = 1 + bytes[..e.valid_up_to()].iter().filter(|b| **b == b'\n').count();
        FormatError::NotUtf8 { input: source.to_owned(), line }
    })?;
    Ok(text.strip_prefix('\u{feff}').unwrap_or(text))
}

/// Trimmed non-blank, non-comment lines with their 1-based numbers.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.split('\n')
        .map(str::trim)
        .enumerate()
        .map(|(i, l)| (i + 1, l))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

/// Everything needed to turn one data line into a record.
struct Row<'a> {
    layout: &'a Layout,
    separator: char,
    source: &'a str,
    convention: AttitudeConvention,
}

/// The trimmed fields of one data line.
struct Fields<'t> {
    line: usize,
    values: Vec<&'t str>,
}

impl Row<'_> {
    fn parse(&self, line: usize, text: &str) -> Result<RawRecord, FormatError> {
        let fields = self.split(line, text)?;
        let l = self.layout;
        let horizontal_unit = match l.horizontal {
            Horizontal::Projected => Unit::Metre,
            Horizontal::Geographic => Unit::Degree,
        };
        Ok(RawRecord {
            time: self.value(&fields, &l.time, Unit::Second)?,
            x: self.value(&fields, &l.x, horizontal_unit)?,
            y: self.value(&fields, &l.y, horizontal_unit)?,
            z: self.value(&fields, &l.height, Unit::Metre)?,
            attitude: self.attitude(&fields)?,
            std: self.std(&fields)?,
        })
    }

    fn split<'t>(&self, line: usize, text: &'t str) -> Result<Fields<'t>, FormatError> {
        let values: Vec<&str> = text.split(self.separator).map(str::trim).collect();
        if values.len() != self.layout.width {
            let (input, expected, found) = (self.source.to_owned(), self.layout.width, values.len());
            return Err(FormatError::FieldCount { input, line, expected, found });
        }
        Ok(Fields { line, values })
    }

    fn attitude(&self, fields: &Fields) -> Result<Attitude, FormatError> {
        let [roll, pitch, heading] = &self.layout.attitude;
        let angle = |column| self.value(fields, column, Unit::Radian);
        Ok(self.convention.to_canonical(angle(roll)?, angle(pitch)?, angle(heading)?))
    }

    fn std(&self, fields: &Fields) -> Result<Option<PoseStd>, FormatError> {
        let Some([e, n, h, r, p, y]) = &self.layout.std else { return Ok(None) };
        let metres = |column| self.value(fields, column, Unit::Metre);
        let radians = |column| self.value(fields, column, Unit::Radian);
        Ok(Some(PoseStd {
            east: metres(e)?,
            north: metres(n)?,
            height: metres(h)?,
            roll: radians(r)?,
            pitch: radians(p)?,
            heading: radians(y)?,
        }))
    }

    /// The finite number in `column`, converted to `to`.
    fn value(&self, fields: &Fields, column: &Column, to: Unit) -> Result<f64, FormatError> {
        // `split` checked the width, and every column index is below it.
        let text = fields.values[column.index];
        let parsed = text.parse::<f64>().map(|v| column.unit.convert(v, to));
        if let Ok(value) = parsed
            && value.is_finite()
        {
            return Ok(value);
        }
        let (input, line, column, text) = (self.source.to_owned(), fields.line, column.name.clone(), text.to_owned());
        Err(match parsed {
            Ok(_) => FormatError::NotFinite { input, line, column, text },
            Err(_) => FormatError::NotANumber { input, line, column, text },
        })
    }
}

/// The CSV text of a trajectory and extra columns (already checked for length).
fn write(trajectory: &RawTrajectory, extra: &[(&str, &[f64])]) -> Vec<u8> {
    let records = &trajectory.records;
    let with_std = !records.is_empty() && records.iter().all(|r| r.std.is_some());
    let mut out = header_line(trajectory.horizontal, with_std, extra);
    for (i, r) in records.iter().enumerate() {
        write_record(&mut out, trajectory.horizontal, r, with_std);
        for (_, values) in extra {
            // Infallible: writing to a String.
            let _ = write!(out, ",{}", values[i]);
        }
        out.push('\n');
    }
    out.into_bytes()
}

fn header_line(horizontal: Horizontal, with_std: bool, extra: &[(&str, &[f64])]) -> String {
    let position = match horizontal {
        Horizontal::Projected => "easting[m],northing[m]",
        Horizontal::Geographic => "latitude[deg],longitude[deg]",
    };
    let mut line = format!("time[s],{position},height[m],roll[deg],pitch[deg],heading[deg]");
    if with_std {
        line.push_str(",std_easting[m],std_northing[m],std_height[m],std_roll[deg],std_pitch[deg],std_heading[deg]");
    }
    for (name, _) in extra {
        line.push(',');
        line.push_str(name.trim());
    }
    line.push('\n');
    line
}

fn write_record(out: &mut String, horizontal: Horizontal, r: &RawRecord, with_std: bool) {
    // Geographic files list latitude first; RawRecord keeps x = longitude.
    let (first, second) = match horizontal {
        Horizontal::Projected => (r.x, r.y),
        Horizontal::Geographic => (r.y, r.x),
    };
    let _ = write!(out, "{},{first},{second},{},{}", r.time, r.z, angles(&r.attitude));
    if let (true, Some(s)) = (with_std, &r.std) {
        let a = angles(&Attitude::new(s.roll, s.pitch, s.heading));
        let _ = write!(out, ",{},{},{},{a}", s.east, s.north, s.height);
    }
}

/// Roll, pitch, heading in degrees with 10 decimals: after one parse the value is that decimal within a
/// few ulp, far from a rounding boundary, so writing it again gives the same text.
fn angles(a: &Attitude) -> String {
    format!("{:.10},{:.10},{:.10}", a.roll.to_degrees(), a.pitch.to_degrees(), a.heading.to_degrees())
}
