//! The LAS/LAZ public header block (LAS 1.0–1.4; ASPRS LAS 1.4 R15 §2.4 and the VLRs of §2.5) from the first
//! bytes of a file, so that a point cloud can be checked without reading its points: the caller range-reads
//! [`LAS_PREFIX_BYTES`] and passes them with the file's length to [`parse_las_header`].
//!
//! Nothing is allocated from a count the header announces: VLRs are walked only as far as the given bytes
//! reach, and the only owned data (a WKT string) is a copy of some of those bytes.

/// Bytes a caller should read from the start of a file: the public header (at most 375 bytes) and, in usual
/// files, all VLRs (a WKT coordinate system is a few kilobytes). When [`LasHeader::crs`] is
/// [`LasCrs::NotRead`], reading [`LasHeader::offset_to_point_data`] bytes reaches every VLR.
pub const LAS_PREFIX_BYTES: usize = 64 * 1024;

/// Bytes of a VLR header: reserved (2), user id (16), record id (2), record length after header (2),
/// description (32).
const VLR_HEADER_LEN: u64 = 54;
/// The VLR user id of coordinate-system records.
const PROJECTION_USER_ID: &[u8] = b"LASF_Projection";
/// COPC 1.0's info VLR: user `copc`, record 1, always the first VLR.
const COPC_USER_ID: &[u8] = b"copc";
const COPC_INFO_RECORD: u16 = 1;
/// OGC coordinate-system WKT.
const WKT_RECORD: u16 = 2112;
/// GeoTIFF GeoKeyDirectoryTag.
const GEOKEYS_RECORD: u16 = 34735;
/// ProjectedCSTypeGeoKey.
const PROJECTED_CS_KEY: u16 = 3072;
/// GeographicTypeGeoKey.
const GEOGRAPHIC_CS_KEY: u16 = 2048;
/// VerticalUnitsGeoKey: the EPSG unit code of heights.
const VERTICAL_UNITS_KEY: u16 = 4099;
/// A GeoKey value meaning "user-defined" (no EPSG code).
const USER_DEFINED: u16 = 32767;
/// Seconds in a GPS week.
pub const GPS_WEEK_S: f64 = 604_800.0;
/// Global encoding bit 0: GPS time is adjusted standard GPS time (standard GPS time − 10⁹ s), not GPS week time.
const ADJUSTED_GPS_TIME_BIT: u16 = 1;
/// Global encoding bit 4 (LAS 1.4): the coordinate system is WKT, not GeoTIFF GeoKeys.
const WKT_BIT: u16 = 1 << 4;
/// Bits 7 and 6 of the point data format byte: LAZ-compressed (LASzip sets bit 7, early versions bit 6).
const COMPRESSED_BITS: u8 = 0x80 | 0x40;

/// Why a LAS/LAZ header was refused. Every message names the file and the header field.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LasHeaderError {
    /// The bytes end before a field of the header.
    #[error("{file}: header field `{field}`: the bytes end at {len}, before the field's end at byte {end}")]
    Short {
        /// The file.
        file: String,
        /// The field that could not be read.
        field: &'static str,
        /// Bytes given.
        len: usize,
        /// Byte offset just past the field.
        end: u64,
    },
    /// A field holds a value the LAS specification does not allow.
    #[error("{file}: header field `{field}`: {problem}")]
    Invalid {
        /// The file.
        file: String,
        /// The field.
        field: &'static str,
        /// What is wrong with its value.
        problem: String,
    },
    /// The file is shorter than the point records the header announces (uncompressed files).
    #[error(
        "{file}: header field `point_count`: {count} records of {record_length} bytes from byte {offset} end at \
         byte {end}, but the file has {file_len} bytes (truncated)"
    )]
    Truncated {
        /// The file.
        file: String,
        /// Point records announced.
        count: u64,
        /// Bytes per record.
        record_length: u16,
        /// Offset to point data.
        offset: u32,
        /// Byte offset just past the last announced record.
        end: u128,
        /// The file's length.
        file_len: u64,
    },
}

/// The coordinate reference system a LAS file declares in its VLRs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LasCrs {
    /// OGC WKT (VLR `LASF_Projection`, record 2112), trailing NULs removed.
    Wkt(String),
    /// GeoTIFF GeoKeys (VLR `LASF_Projection`, record 34735): the EPSG code of ProjectedCSTypeGeoKey (3072),
    /// or of GeographicTypeGeoKey (2048) when there is no projected key; `None` when user-defined or absent.
    GeoKeys {
        /// The EPSG code.
        epsg: Option<u32>,
        /// VerticalUnitsGeoKey (4099): the EPSG code of the heights' unit (9001 metre, 9002 foot, 9003 US
        /// survey foot), when given.
        height_unit: Option<u16>,
    },
    /// No coordinate-system VLR.
    Missing,
    /// Not known from the bytes given: they end before the VLRs that could hold the CRS, or the CRS may be in
    /// extended VLRs after the points (LAS 1.4).
    NotRead,
}

impl LasCrs {
    /// The EPSG code the record names; a WKT's through `of_wkt` (GDAL/PROJ, which this crate does not use).
    pub fn epsg(&self, of_wkt: impl FnOnce(&str) -> Option<u32>) -> Option<u32> {
        match self {
            Self::GeoKeys { epsg, .. } => *epsg,
            Self::Wkt(wkt) => of_wkt(wkt),
            Self::Missing | Self::NotRead => None,
        }
    }

    /// The unit of heights the record names, as its name and metres per unit: a WKT's vertical CRS's
    /// through `of_wkt`, the GeoKeys' VerticalUnitsGeoKey (an EPSG unit code this function knows, else an
    /// error naming it). `None` when the record names none: heights are then taken to be metres.
    pub fn height_unit(
        &self,
        of_wkt: impl FnOnce(&str) -> Option<(String, f64)>,
    ) -> Result<Option<(String, f64)>, String> {
        match self {
            Self::Wkt(wkt) => Ok(of_wkt(wkt)),
            Self::GeoKeys { height_unit: Some(code), .. } => {
                let (name, metres) = match code {
                    9001 => ("metre", 1.0),
                    9002 => ("foot", 0.3048),
                    9003 => ("US survey foot", 1200.0 / 3937.0),
                    9036 => ("kilometre", 1000.0),
                    9096 => ("yard", 0.9144),
                    _ => {
                        return Err(format!(
                            "VerticalUnitsGeoKey (4099) = {code}: not a unit this reader knows (metre 9001, foot \
                             9002, US survey foot 9003)"
                        ));
                    }
                };
                Ok(Some((name.to_owned(), metres)))
            }
            Self::GeoKeys { height_unit: None, .. } | Self::Missing | Self::NotRead => Ok(None),
        }
    }
}

/// The public header of a LAS or LAZ file, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct LasHeader {
    /// Version major, minor (1, 0–4).
    pub version: (u8, u8),
    /// Point data record format, 0–10 (the compression bits removed).
    pub point_format: u8,
    /// Whether the points are LAZ-compressed (bit 7 or 6 of the format byte).
    pub compressed: bool,
    /// Bytes per (uncompressed) point record, at least the format's minimum.
    pub point_record_length: u16,
    /// Point records: the 64-bit field of LAS 1.4, the legacy 32-bit field before.
    pub point_count: u64,
    /// The legacy 32-bit point count as written (0 in LAS 1.4 files that do not keep it).
    pub legacy_point_count: u32,
    /// Scale factors x, y, z (finite, non-zero).
    pub scale: [f64; 3],
    /// Offsets x, y, z (finite).
    pub offset: [f64; 3],
    /// Minimum x, y, z (finite when there are points; an empty file's are as written, e.g. +∞).
    pub min: [f64; 3],
    /// Maximum x, y, z (finite and ≥ `min` when there are points; an empty file's are as written).
    pub max: [f64; 3],
    /// The global encoding bits (0 before LAS 1.2, where the field was reserved).
    pub global_encoding: u16,
    /// Global encoding bit 0: GPS times are adjusted standard GPS time, not seconds of the GPS week.
    pub adjusted_standard_gps_time: bool,
    /// Bytes of the header block.
    pub header_size: u16,
    /// Byte offset of the first point record.
    pub offset_to_point_data: u32,
    /// VLRs announced.
    pub number_of_vlrs: u32,
    /// Byte offset of the first extended VLR (LAS 1.4; 0 before).
    pub start_of_first_evlr: u64,
    /// Extended VLRs announced (LAS 1.4; 0 before).
    pub number_of_evlrs: u32,
    /// The declared coordinate reference system.
    pub crs: LasCrs,
    /// A cloud-optimised point cloud (COPC 1.0: the first VLR is `copc` record 1): its points are stored by
    /// octree node, not in GPS-time order.
    pub copc: bool,
}

impl LasHeader {
    /// Whether the point format records GPS time (formats 1, 3, 4, 5 and 6–10).
    pub fn has_gps_time(&self) -> bool {
        matches!(self.point_format, 1 | 3..=10)
    }
}

/// The minimum point record length of a point format (LAS 1.4 R15 §2.6–2.16), `None` for no LAS format.
fn min_record_length(format: u8) -> Option<u16> {
    Some(match format {
        0 => 20,
        1 => 28,
        2 => 26,
        3 => 34,
        4 => 57,
        5 => 63,
        6 => 30,
        7 => 36,
        8 => 38,
        9 => 59,
        10 => 67,
        _ => return None,
    })
}

/// Parse and check the public header of a LAS/LAZ file from its first bytes (`prefix`; read
/// [`LAS_PREFIX_BYTES`] or the whole file if shorter). `name` names the file in errors. With `file_len`, an
/// uncompressed file must hold every point record the header announces.
///
/// Checks: signature `LASF`, version 1.0–1.4, header size ≥ the version's, offset to point data ≥ header
/// size, point format 0–10, record length ≥ the format's, a LAS 1.4 legacy count of 0 or equal to the
/// 64-bit count, scales finite and non-zero, offsets finite, bounds finite with min ≤ max when there are points,
/// VLRs within the header-to-points gap, and the file length.
pub fn parse_las_header(name: &str, prefix: &[u8], file_len: Option<u64>) -> Result<LasHeader, LasHeaderError> {
    let h = Fields { file: name, bytes: prefix };
    let signature: [u8; 4] = h.array("file_signature", 0)?;
    if &signature != b"LASF" {
        let found = signature.escape_ascii();
        return Err(h.invalid("file_signature", format!("\"{found}\" is not \"LASF\" (not a LAS or LAZ file)")));
    }
    let version = (h.u8("version_major", 24)?, h.u8("version_minor", 25)?);
    let min_header_size: u16 = match version {
        (1, 0..=2) => 227,
        (1, 3) => 235,
        (1, 4) => 375,
        (major, minor) => {
            let problem = format!("{major}.{minor} is not a LAS version this reader knows (1.0–1.4)");
            return Err(h.invalid("version", problem));
        }
    };
    let global_encoding = if version.1 >= 2 { h.u16("global_encoding", 6)? } else { 0 };
    let header_size = h.u16("header_size", 94)?;
    if header_size < min_header_size {
        let (major, minor) = version;
        let problem = format!("{header_size} bytes, but a LAS {major}.{minor} header has at least {min_header_size}");
        return Err(h.invalid("header_size", problem));
    }
    let offset_to_point_data = h.u32("offset_to_point_data", 96)?;
    if offset_to_point_data < u32::from(header_size) {
        let problem = format!("{offset_to_point_data} lies inside the {header_size}-byte header");
        return Err(h.invalid("offset_to_point_data", problem));
    }
    let number_of_vlrs = h.u32("number_of_vlrs", 100)?;
    let format_byte = h.u8("point_data_format", 104)?;
    let point_format = format_byte & !COMPRESSED_BITS;
    let compressed = format_byte & COMPRESSED_BITS != 0;
    let Some(min_length) = min_record_length(point_format) else {
        let laz = if compressed { "; LAZ adds 128" } else { "" };
        return Err(h.invalid("point_data_format", format!("{format_byte} is not a LAS point format (0–10{laz})")));
    };
    let point_record_length = h.u16("point_data_record_length", 105)?;
    if point_record_length < min_length {
        let problem =
            format!("{point_record_length} bytes, but point format {point_format} records have at least {min_length}");
        return Err(h.invalid("point_data_record_length", problem));
    }
    let legacy_point_count = h.u32("legacy_point_count", 107)?;
    let scale = [h.f64("x_scale", 131)?, h.f64("y_scale", 139)?, h.f64("z_scale", 147)?];
    let offset = [h.f64("x_offset", 155)?, h.f64("y_offset", 163)?, h.f64("z_offset", 171)?];
    let max = [h.f64("max_x", 179)?, h.f64("max_y", 195)?, h.f64("max_z", 211)?];
    let min = [h.f64("min_x", 187)?, h.f64("min_y", 203)?, h.f64("min_z", 219)?];
    let (start_of_first_evlr, number_of_evlrs, point_count) = if version.1 >= 4 {
        (h.u64("start_of_first_evlr", 235)?, h.u32("number_of_evlrs", 243)?, h.u64("point_count", 247)?)
    } else {
        (0, 0, u64::from(legacy_point_count))
    };
    // LAS 1.4 R15 §2.4: a non-zero legacy count that differs from the 64-bit one is a discrepancy to report.
    if legacy_point_count != 0 && u64::from(legacy_point_count) != point_count {
        let problem = format!("{legacy_point_count} disagrees with the 64-bit `point_count` {point_count}");
        return Err(h.invalid("legacy_point_count", problem));
    }
    h.check_axes(scale, offset, min, max, point_count)?;
    if let Some(file_len) = file_len {
        h.check_length(file_len, offset_to_point_data, compressed, point_count, point_record_length)?;
    }
    let vlrs = Gap { start: u64::from(header_size), end: u64::from(offset_to_point_data), count: number_of_vlrs };
    let found = h.scan_vlrs(&vlrs)?;
    let complete = found.complete && number_of_evlrs == 0;
    let copc = found.copc;
    let crs = found.crs(global_encoding & WKT_BIT != 0, complete);
    Ok(LasHeader {
        version,
        point_format,
        compressed,
        point_record_length,
        point_count,
        legacy_point_count,
        scale,
        offset,
        min,
        max,
        global_encoding,
        adjusted_standard_gps_time: global_encoding & ADJUSTED_GPS_TIME_BIT != 0,
        header_size,
        offset_to_point_data,
        number_of_vlrs,
        start_of_first_evlr,
        number_of_evlrs,
        crs,
        copc,
    })
}

/// The `N` bytes of `bytes` from `at`, if present.
pub(crate) fn take<const N: usize>(bytes: &[u8], at: u64) -> Option<[u8; N]> {
    let start = usize::try_from(at).ok()?;
    let slice = bytes.get(start..start.checked_add(N)?)?;
    slice.try_into().ok()
}

/// `len` bytes of `bytes` from `at`, if present.
fn span(bytes: &[u8], at: u64, len: u64) -> Option<&[u8]> {
    let start = usize::try_from(at).ok()?;
    let end = start.checked_add(usize::try_from(len).ok()?)?;
    bytes.get(start..end)
}

/// The header bytes of one file, read field by field with errors naming the field.
struct Fields<'a> {
    file: &'a str,
    bytes: &'a [u8],
}

/// Where the VLRs lie: from the end of the header to the point data, and how many are announced.
struct Gap {
    start: u64,
    end: u64,
    count: u32,
}

/// The coordinate-system VLRs found.
#[derive(Default)]
struct FoundCrs {
    wkt: Option<String>,
    geokeys: Option<(Option<u32>, Option<u16>)>,
    /// The first VLR is COPC's info record.
    copc: bool,
    /// Every announced VLR was within the bytes given.
    complete: bool,
}

impl FoundCrs {
    /// The declared CRS: WKT first when global encoding says so (LAS 1.4), GeoKeys first otherwise.
    fn crs(self, wkt_flagged: bool, complete: bool) -> LasCrs {
        let wkt = self.wkt.map(LasCrs::Wkt);
        let geokeys = self.geokeys.map(|(epsg, height_unit)| LasCrs::GeoKeys { epsg, height_unit });
        let (first, second) = if wkt_flagged { (wkt, geokeys) } else { (geokeys, wkt) };
        match (first, complete) {
            (Some(crs), _) => crs,
            (None, false) => LasCrs::NotRead,
            (None, true) => second.unwrap_or(LasCrs::Missing),
        }
    }
}

impl Fields<'_> {
    fn invalid(&self, field: &'static str, problem: String) -> LasHeaderError {
        LasHeaderError::Invalid { file: self.file.to_owned(), field, problem }
    }

    fn array<const N: usize>(&self, field: &'static str, at: u64) -> Result<[u8; N], LasHeaderError> {
        take(self.bytes, at).ok_or_else(|| LasHeaderError::Short {
            file: self.file.to_owned(),
            field,
            len: self.bytes.len(),
            end: at + N as u64,
        })
    }

    fn u8(&self, field: &'static str, at: u64) -> Result<u8, LasHeaderError> {
        self.array::<1>(field, at).map(|[b]| b)
    }

    fn u16(&self, field: &'static str, at: u64) -> Result<u16, LasHeaderError> {
        self.array(field, at).map(u16::from_le_bytes)
    }

    fn u32(&self, field: &'static str, at: u64) -> Result<u32, LasHeaderError> {
        self.array(field, at).map(u32::from_le_bytes)
    }

    fn u64(&self, field: &'static str, at: u64) -> Result<u64, LasHeaderError> {
        self.array(field, at).map(u64::from_le_bytes)
    }

    fn f64(&self, field: &'static str, at: u64) -> Result<f64, LasHeaderError> {
        self.array(field, at).map(f64::from_le_bytes)
    }

    /// Scales finite and non-zero, offsets finite; with points, bounds finite and min ≤ max.
    fn check_axes(
        &self,
        scale: [f64; 3],
        offset: [f64; 3],
        min: [f64; 3],
        max: [f64; 3],
        point_count: u64,
    ) -> Result<(), LasHeaderError> {
        const AXES: [[&str; 5]; 3] = [
            ["x_scale", "x_offset", "min_x", "max_x", "x"],
            ["y_scale", "y_offset", "min_y", "max_y", "y"],
            ["z_scale", "z_offset", "min_z", "max_z", "z"],
        ];
        for (i, [scale_field, offset_field, min_field, max_field, _]) in AXES.into_iter().enumerate() {
            let (s, o, lo, hi) = (scale[i], offset[i], min[i], max[i]);
            if !s.is_finite() || s == 0.0 {
                return Err(self.invalid(scale_field, format!("{s} is not a finite, non-zero scale")));
            }
            if !o.is_finite() {
                return Err(self.invalid(offset_field, format!("{o} is not finite")));
            }
            // An empty file bounds nothing: writers leave zeros or ±∞ there (the `las` crate writes +∞, −∞).
            if point_count == 0 {
                continue;
            }
            for (field, v) in [(min_field, lo), (max_field, hi)] {
                if !v.is_finite() {
                    return Err(self.invalid(field, format!("{v} is not finite")));
                }
            }
            if lo > hi {
                return Err(self.invalid(min_field, format!("{lo} is greater than `{max_field}` {hi}")));
            }
        }
        Ok(())
    }

    /// The point data starts within the file and, uncompressed, every announced record is in it.
    fn check_length(
        &self,
        file_len: u64,
        offset: u32,
        compressed: bool,
        count: u64,
        record_length: u16,
    ) -> Result<(), LasHeaderError> {
        if u64::from(offset) > file_len {
            let problem = format!("{offset} lies past the end of the file ({file_len} bytes)");
            return Err(self.invalid("offset_to_point_data", problem));
        }
        let end = u128::from(offset) + u128::from(count) * u128::from(record_length);
        if !compressed && end > u128::from(file_len) {
            let file = self.file.to_owned();
            return Err(LasHeaderError::Truncated { file, count, record_length, offset, end, file_len });
        }
        Ok(())
    }

    /// Walk the VLRs as far as the bytes reach; each must end before the point data.
    fn scan_vlrs(&self, gap: &Gap) -> Result<FoundCrs, LasHeaderError> {
        let mut found = FoundCrs::default();
        let mut at = gap.start;
        // Every VLR takes at least 54 bytes of the prefix, so this ends within prefix / 54 rounds.
        for index in 0..gap.count {
            // Without its header, whether the VLR fits before the point data is unknown: not read.
            let Some(header) = span(self.bytes, at, VLR_HEADER_LEN) else { return Ok(found) };
            let user_id = header.get(2..18).unwrap_or_default();
            let record_id = take::<2>(header, 18).map_or(0, u16::from_le_bytes);
            let length = take::<2>(header, 20).map_or(0, u16::from_le_bytes);
            let data_at = at + VLR_HEADER_LEN;
            let end = data_at + u64::from(length);
            if end > gap.end {
                let last = end - 1;
                let problem = format!("VLR {index} (bytes {at}–{last}) runs past the point data at byte {}", gap.end);
                return Err(self.invalid("number_of_vlrs", problem));
            }
            if index == 0 && until_nul(user_id) == COPC_USER_ID && record_id == COPC_INFO_RECORD {
                found.copc = true;
            }
            if is_projection(user_id) && matches!(record_id, WKT_RECORD | GEOKEYS_RECORD) {
                let Some(data) = span(self.bytes, data_at, u64::from(length)) else { return Ok(found) };
                if record_id == WKT_RECORD && found.wkt.is_none() {
                    found.wkt = wkt(data);
                } else if record_id == GEOKEYS_RECORD && found.geokeys.is_none() {
                    found.geokeys = Some(geokeys_crs(data));
                }
            }
            at = end;
        }
        found.complete = true;
        Ok(found)
    }
}

/// The text before the first NUL.
fn until_nul(bytes: &[u8]) -> &[u8] {
    bytes.split(|b| *b == 0).next().unwrap_or_default()
}

/// Whether a VLR user id (16 bytes, NUL-padded) is `LASF_Projection` (case-insensitive, as readers accept).
fn is_projection(user_id: &[u8]) -> bool {
    until_nul(user_id).eq_ignore_ascii_case(PROJECTION_USER_ID)
}

/// The WKT of a record-2112 VLR (NUL-terminated text); `None` when empty.
fn wkt(data: &[u8]) -> Option<String> {
    let text = String::from_utf8_lossy(until_nul(data));
    let text = text.trim();
    (!text.is_empty()).then(|| text.to_owned())
}

/// The EPSG code and the heights' unit code of a GeoKeyDirectoryTag (u16 words: version, revision, minor
/// revision, number of keys, then per key: id, TIFF tag location, count, value; location 0 holds the value
/// inline). The projected key wins; the geographic key counts only without one (a user-defined projection's
/// datum is not the CRS).
fn geokeys_crs(data: &[u8]) -> (Option<u32>, Option<u16>) {
    let word = |i: usize| take::<2>(data, 2 * i as u64).map(u16::from_le_bytes);
    let Some(keys) = word(3) else { return (None, None) };
    let (mut projected, mut geographic, mut height_unit) = (None, None, None);
    for k in 0..usize::from(keys) {
        let entry = 4 + 4 * k;
        let (Some(id), Some(location), Some(value)) = (word(entry), word(entry + 1), word(entry + 3)) else { break };
        if location != 0 {
            continue;
        }
        match id {
            PROJECTED_CS_KEY => projected = projected.or(Some(value)),
            GEOGRAPHIC_CS_KEY => geographic = geographic.or(Some(value)),
            VERTICAL_UNITS_KEY => height_unit = height_unit.or(Some(value)),
            _ => {}
        }
    }
    let epsg = projected.or(geographic).filter(|&code| code != 0 && code != USER_DEFINED).map(u32::from);
    (epsg, height_unit.filter(|&code| code != 0 && code != USER_DEFINED))
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use proptest::prelude::*;

    use super::*;

    /// A header to write: the fields the tests vary.
    #[derive(Clone, Debug)]
    struct Spec {
        version: (u8, u8),
        format_byte: u8,
        record_length: u16,
        legacy_count: u32,
        count: u64,
        scale: [f64; 3],
        offset: [f64; 3],
        min: [f64; 3],
        max: [f64; 3],
        global_encoding: u16,
        vlrs: Vec<(&'static str, u16, Vec<u8>)>,
    }

    impl Default for Spec {
        fn default() -> Self {
            Self {
                version: (1, 2),
                format_byte: 1,
                record_length: 28,
                legacy_count: 3,
                count: 3,
                scale: [0.001; 3],
                offset: [565_000.0, 5_933_000.0, 0.0],
                min: [565_000.5, 5_933_000.25, 7.5],
                max: [565_010.5, 5_933_020.25, 9.5],
                global_encoding: 1,
                vlrs: Vec::new(),
            }
        }
    }

    impl Spec {
        fn header_size(&self) -> u16 {
            match self.version.1 {
                0..=2 => 227,
                3 => 235,
                _ => 375,
            }
        }

        /// The header, its VLRs and `count` zeroed point records: a whole file.
        fn file(&self) -> Vec<u8> {
            let mut b = self.header();
            let points = usize::try_from(self.count).unwrap() * usize::from(self.record_length);
            b.resize(b.len() + points, 0);
            b
        }

        /// The header and its VLRs.
        fn header(&self) -> Vec<u8> {
            let header_size = self.header_size();
            let vlr_bytes: usize = self.vlrs.iter().map(|(_, _, data)| 54 + data.len()).sum();
            let offset_to_points = u32::from(header_size) + u32::try_from(vlr_bytes).unwrap();
            let mut b = Vec::new();
            b.extend_from_slice(b"LASF");
            b.extend_from_slice(&0u16.to_le_bytes()); // file source id
            b.extend_from_slice(&self.global_encoding.to_le_bytes());
            b.extend_from_slice(&[0; 16]); // GUID
            b.extend_from_slice(&[self.version.0, self.version.1]);
            b.extend_from_slice(&[b'p'; 32]); // system identifier
            b.extend_from_slice(&[b'q'; 32]); // generating software
            b.extend_from_slice(&[1, 0, 0xe8, 0x07]); // day 1 of 2024
            b.extend_from_slice(&header_size.to_le_bytes());
            b.extend_from_slice(&offset_to_points.to_le_bytes());
            b.extend_from_slice(&u32::try_from(self.vlrs.len()).unwrap().to_le_bytes());
            b.push(self.format_byte);
            b.extend_from_slice(&self.record_length.to_le_bytes());
            b.extend_from_slice(&self.legacy_count.to_le_bytes());
            b.extend_from_slice(&[0; 20]); // points by return
            let bounds = (0..3).flat_map(|i| [self.max[i], self.min[i]]);
            for v in self.scale.into_iter().chain(self.offset).chain(bounds) {
                b.extend_from_slice(&v.to_le_bytes());
            }
            assert_eq!(b.len(), 227);
            if self.version.1 >= 3 {
                b.extend_from_slice(&0u64.to_le_bytes()); // start of waveform data
            }
            if self.version.1 >= 4 {
                b.extend_from_slice(&0u64.to_le_bytes()); // start of first EVLR
                b.extend_from_slice(&0u32.to_le_bytes()); // number of EVLRs
                b.extend_from_slice(&self.count.to_le_bytes());
                b.extend_from_slice(&[0; 120]); // points by return
            }
            assert_eq!(b.len(), usize::from(header_size));
            for (user_id, record_id, data) in &self.vlrs {
                b.extend_from_slice(&0u16.to_le_bytes());
                let mut id = [0u8; 16];
                id[..user_id.len()].copy_from_slice(user_id.as_bytes());
                b.extend_from_slice(&id);
                b.extend_from_slice(&record_id.to_le_bytes());
                b.extend_from_slice(&u16::try_from(data.len()).unwrap().to_le_bytes());
                b.extend_from_slice(&[0; 32]); // description
                b.extend_from_slice(data);
            }
            b
        }
    }

    const WKT_25832: &str = r#"PROJCS["ETRS89 / UTM zone 32N",GEOGCS["ETRS89"],AUTHORITY["EPSG","25832"]]"#;

    /// A GeoKeyDirectoryTag: header (1, 1, 0, n) and (id, location 0, count 1, value) per key.
    fn geokeys(keys: &[(u16, u16)]) -> Vec<u8> {
        let n = u16::try_from(keys.len()).unwrap();
        let words = [1, 1, 0, n].into_iter().chain(keys.iter().flat_map(|&(id, value)| [id, 0, 1, value]));
        words.flat_map(u16::to_le_bytes).collect()
    }

    fn wkt_vlr(text: &str) -> (&'static str, u16, Vec<u8>) {
        let mut data = text.as_bytes().to_vec();
        data.push(0);
        ("LASF_Projection", 2112, data)
    }

    fn parse(name: &str, bytes: &[u8]) -> Result<LasHeader, LasHeaderError> {
        parse_las_header(name, bytes, Some(bytes.len() as u64))
    }

    #[test]
    fn las_1_2_format_1() {
        let spec = Spec::default();
        let h = parse("a.las", &spec.file()).unwrap();
        assert_eq!((h.version, h.point_format, h.compressed, h.point_record_length), ((1, 2), 1, false, 28));
        assert_eq!((h.point_count, h.legacy_point_count), (3, 3));
        assert_eq!((h.scale, h.offset, h.min, h.max), (spec.scale, spec.offset, spec.min, spec.max));
        assert_eq!((h.global_encoding, h.adjusted_standard_gps_time), (1, true));
        assert_eq!((h.header_size, h.offset_to_point_data, h.number_of_vlrs, h.number_of_evlrs), (227, 227, 0, 0));
        assert!(h.has_gps_time());
        assert_eq!(h.crs, LasCrs::Missing);
        // Format 0 has no GPS time; the LAZ bit (either) is recognised.
        for (byte, format, compressed, gps) in [(0, 0, false, false), (0x81, 1, true, true), (0x43, 3, true, true)] {
            let spec = Spec { format_byte: byte, record_length: 34, ..Spec::default() };
            let h = parse("b.laz", &spec.file()).unwrap();
            assert_eq!((h.point_format, h.compressed, h.has_gps_time()), (format, compressed, gps), "{byte}");
        }
        // LAS 1.0 had no global encoding (reserved bytes).
        let h = parse("old.las", &Spec { version: (1, 0), ..Spec::default() }.file()).unwrap();
        assert_eq!((h.global_encoding, h.adjusted_standard_gps_time), (0, false));
    }

    #[test]
    fn las_1_4_format_6_with_wkt() {
        let spec = Spec {
            version: (1, 4),
            format_byte: 6,
            record_length: 30,
            legacy_count: 0,
            count: 5,
            global_encoding: 0x11,
            vlrs: vec![("other", 7, vec![1; 100]), wkt_vlr(WKT_25832)],
            ..Spec::default()
        };
        let bytes = spec.file();
        let h = parse("b.las", &bytes).unwrap();
        assert_eq!((h.version, h.point_format, h.point_record_length), ((1, 4), 6, 30));
        assert_eq!((h.point_count, h.legacy_point_count, h.number_of_vlrs), (5, 0, 2));
        assert_eq!(h.offset_to_point_data, 375 + 54 + 100 + 54 + 75);
        assert_eq!(h.crs, LasCrs::Wkt(WKT_25832.to_owned()));
        assert!(h.has_gps_time());
        // A prefix that ends inside the VLRs: the header is read, the CRS is not.
        let h = parse_las_header("b.las", &bytes[..500], Some(bytes.len() as u64)).unwrap();
        assert_eq!((h.point_count, h.crs), (5, LasCrs::NotRead));
        // Neither is a file whose CRS may be in an EVLR after the points.
        let mut evlr = Spec { vlrs: Vec::new(), ..spec }.file();
        evlr[243..247].copy_from_slice(&1u32.to_le_bytes());
        assert_eq!(parse("c.las", &evlr).unwrap().crs, LasCrs::NotRead);
    }

    #[test]
    fn a_copc_cloud_is_told_by_its_first_vlr() {
        let copc = Spec { vlrs: vec![("copc", 1, vec![0; 160])], ..Spec::default() };
        assert!(parse("c.copc.laz", &copc.file()).unwrap().copc);
        // The record anywhere but first, or another record of that user, is not COPC.
        let second = Spec { vlrs: vec![wkt_vlr(WKT_25832), ("copc", 1, vec![0; 160])], ..Spec::default() };
        assert!(!parse("c.laz", &second.file()).unwrap().copc);
        let other = Spec { vlrs: vec![("copc", 1000, vec![0; 32])], ..Spec::default() };
        assert!(!parse("c.laz", &other.file()).unwrap().copc);
        assert!(!parse("c.las", &Spec::default().file()).unwrap().copc);
    }

    #[test]
    fn geokeys_give_the_epsg_code() {
        let with = |keys: &[(u16, u16)]| {
            let spec = Spec { vlrs: vec![("LASF_Projection", 34735, geokeys(keys))], ..Spec::default() };
            parse("g.las", &spec.file()).unwrap().crs
        };
        assert_eq!(
            with(&[(1024, 1), (3072, 25832), (4096, 5783)]),
            LasCrs::GeoKeys { epsg: Some(25832), height_unit: None }
        );
        assert_eq!(with(&[(2048, 4326)]), LasCrs::GeoKeys { epsg: Some(4326), height_unit: None });
        // A user-defined projection on a known datum is not that datum's geographic CRS.
        assert_eq!(with(&[(2048, 4258), (3072, 32767)]), LasCrs::GeoKeys { epsg: None, height_unit: None });
        assert_eq!(with(&[]), LasCrs::GeoKeys { epsg: None, height_unit: None });
        // A key count larger than the record stops at the record's end.
        let mut keys = geokeys(&[(3072, 25832)]);
        keys[6..8].copy_from_slice(&u16::MAX.to_le_bytes());
        let spec = Spec { vlrs: vec![("LASF_Projection", 34735, keys)], ..Spec::default() };
        assert_eq!(parse("g.las", &spec.file()).unwrap().crs, LasCrs::GeoKeys { epsg: Some(25832), height_unit: None });
        // Global encoding's WKT bit decides which of both is the CRS.
        let both = vec![("LASF_Projection", 34735, geokeys(&[(3072, 25833)])), wkt_vlr(WKT_25832)];
        let spec = Spec { vlrs: both, ..Spec::default() };
        assert_eq!(parse("g.las", &spec.file()).unwrap().crs, LasCrs::GeoKeys { epsg: Some(25833), height_unit: None });
        let spec = Spec { version: (1, 4), global_encoding: 0x10, ..spec };
        assert_eq!(parse("g.las", &spec.file()).unwrap().crs, LasCrs::Wkt(WKT_25832.to_owned()));
    }

    #[test]
    fn geokeys_give_the_unit_of_heights() {
        let with = |keys: &[(u16, u16)]| {
            let spec = Spec { vlrs: vec![("LASF_Projection", 34735, geokeys(keys))], ..Spec::default() };
            parse("g.las", &spec.file()).unwrap().crs
        };
        let feet = with(&[(3072, 2264), (4096, 6360), (4099, 9003)]);
        assert_eq!(feet, LasCrs::GeoKeys { epsg: Some(2264), height_unit: Some(9003) });
        let unit = feet.height_unit(|_| None).unwrap().unwrap();
        assert_eq!(unit.0, "US survey foot");
        assert!((unit.1 - 0.304_800_609_601_219).abs() < 1e-15);
        assert_eq!(with(&[(3072, 25832)]).height_unit(|_| None), Ok(None));
        let odd = with(&[(3072, 25832), (4099, 9999)]).height_unit(|_| None).unwrap_err();
        assert!(odd.contains("4099") && odd.contains("9999"), "{odd}");
        // A WKT's unit comes from the function given.
        let wkt = LasCrs::Wkt("x".to_owned());
        assert_eq!(wkt.height_unit(|_| Some(("foot".to_owned(), 0.3048))), Ok(Some(("foot".to_owned(), 0.3048))));
    }

    /// A file written by the `las` crate.
    fn las_file(version: (u8, u8), format: u8, compressed: bool, n: usize) -> Vec<u8> {
        use las::{Builder, Color, Point, Transform, Vector, Writer, point::Format};
        let mut builder = Builder::from(version);
        builder.point_format = Format::new(format).unwrap();
        builder.point_format.is_compressed = compressed;
        builder.transforms = Vector {
            x: Transform { scale: 0.001, offset: 565_000.0 },
            y: Transform { scale: 0.002, offset: 5_933_000.0 },
            z: Transform { scale: 0.01, offset: -10.0 },
        };
        let mut header = builder.into_header().unwrap();
        if version == (1, 4) {
            header.set_wkt_crs(WKT_25832.as_bytes().to_vec()).unwrap();
        }
        let mut writer = Writer::new(Cursor::new(Vec::new()), header).unwrap();
        for i in 0..n {
            let f = i as f64;
            let kind = Format::new(format).unwrap();
            let (gps_time, color) = (kind.has_gps_time.then_some(f), kind.has_color.then_some(Color::default()));
            let p = Point {
                x: 565_000.0 + f,
                y: 5_933_000.0 - 2.0 * f,
                z: 8.0 + 0.5 * f,
                gps_time,
                color,
                ..Point::default()
            };
            writer.write_point(p).unwrap();
        }
        writer.into_inner().unwrap().into_inner()
    }

    #[test]
    fn agrees_with_the_las_crate() {
        let cases = [((1, 2), 1, false), ((1, 2), 1, true), ((1, 2), 3, false), ((1, 4), 6, false), ((1, 4), 7, true)];
        for (version, format, compressed) in cases {
            let bytes = las_file(version, format, compressed, 50);
            let ours = parse("w.las", &bytes).unwrap_or_else(|e| panic!("{version:?} {format}: {e}"));
            let theirs = las::Reader::new(Cursor::new(bytes)).unwrap();
            let theirs = theirs.header();
            let v = theirs.version();
            assert_eq!(ours.version, (v.major, v.minor));
            assert_eq!((ours.point_format, ours.compressed), (theirs.point_format().to_u8().unwrap(), compressed));
            assert_eq!(ours.point_count, theirs.number_of_points());
            assert_eq!(ours.point_record_length, theirs.point_format().len());
            let (b, t) = (theirs.bounds(), theirs.transforms());
            assert_eq!((ours.min, ours.max), ([b.min.x, b.min.y, b.min.z], [b.max.x, b.max.y, b.max.z]));
            assert_eq!((ours.min, ours.max), ([565_000.0, 5_932_902.0, 8.0], [565_049.0, 5_933_000.0, 32.5]));
            assert_eq!(ours.scale, [t.x.scale, t.y.scale, t.z.scale]);
            assert_eq!(ours.offset, [t.x.offset, t.y.offset, t.z.offset]);
            assert_eq!(ours.number_of_vlrs as usize, theirs.vlrs().len());
            let crs = if version == (1, 4) { LasCrs::Wkt(WKT_25832.to_owned()) } else { LasCrs::Missing };
            assert_eq!(ours.crs, crs, "{version:?} {format}");
        }
        // The `las` crate writes +∞ / −∞ bounds into an empty file: accepted.
        let empty = parse("e.las", &las_file((1, 2), 1, false, 0)).unwrap();
        assert_eq!((empty.point_count, empty.min[0], empty.max[0]), (0, f64::INFINITY, f64::NEG_INFINITY));
    }

    #[test]
    fn minimum_record_lengths_are_the_las_crates() {
        for n in 0..=10 {
            assert_eq!(min_record_length(n), Some(las::point::Format::new(n).unwrap().len()), "format {n}");
        }
        assert_eq!(min_record_length(11), None);
    }

    /// The error message for `bytes`.
    fn error(bytes: &[u8]) -> String {
        match parse("cloud.laz", bytes) {
            Ok(h) => panic!("expected an error, parsed {h:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn errors_name_the_file_and_the_field() {
        let good = Spec::default().file();
        assert_eq!(
            error(&good[..100]),
            "cloud.laz: header field `number_of_vlrs`: the bytes end at 100, before the field's end at byte 104"
        );
        assert_eq!(
            error(b""),
            "cloud.laz: header field `file_signature`: the bytes end at 0, before the field's end at byte 4"
        );
        let mut bad = good.clone();
        bad[..4].copy_from_slice(b"LAS\0");
        assert_eq!(
            error(&bad),
            r#"cloud.laz: header field `file_signature`: "LAS\x00" is not "LASF" (not a LAS or LAZ file)"#
        );
        let cases: [(Spec, &str); 10] = [
            (
                Spec { format_byte: 42, ..Spec::default() },
                "cloud.laz: header field `point_data_format`: 42 is not a LAS point format (0–10)",
            ),
            (
                Spec { format_byte: 0x8b, ..Spec::default() },
                "cloud.laz: header field `point_data_format`: 139 is not a LAS point format (0–10; LAZ adds 128)",
            ),
            (
                Spec { version: (1, 5), ..Spec::default() },
                "cloud.laz: header field `version`: 1.5 is not a LAS version this reader knows (1.0–1.4)",
            ),
            (
                Spec { min: [f64::NAN, 0.0, 0.0], ..Spec::default() },
                "cloud.laz: header field `min_x`: NaN is not finite",
            ),
            (
                Spec { max: [1e9, 1e9, f64::INFINITY], ..Spec::default() },
                "cloud.laz: header field `max_z`: inf is not finite",
            ),
            (
                Spec { min: [0.0, 10.0, 0.0], max: [1.0, 5.0, 1.0], ..Spec::default() },
                "cloud.laz: header field `min_y`: 10 is greater than `max_y` 5",
            ),
            (
                Spec { scale: [0.001, 0.0, 0.001], ..Spec::default() },
                "cloud.laz: header field `y_scale`: 0 is not a finite, non-zero scale",
            ),
            (
                Spec { offset: [0.0, 0.0, f64::NAN], ..Spec::default() },
                "cloud.laz: header field `z_offset`: NaN is not finite",
            ),
            (
                Spec { format_byte: 3, record_length: 28, ..Spec::default() },
                "cloud.laz: header field `point_data_record_length`: 28 bytes, but point format 3 records have at least 34",
            ),
            (
                Spec { version: (1, 4), legacy_count: 3, count: 4, ..Spec::default() },
                "cloud.laz: header field `legacy_point_count`: 3 disagrees with the 64-bit `point_count` 4",
            ),
        ];
        for (spec, expect) in cases {
            assert_eq!(error(&spec.file()), expect);
        }
        // An empty file bounds nothing: inverted or infinite bounds are what writers leave there.
        let empty = Spec { legacy_count: 0, count: 0, min: [1.0; 3], max: [0.0; 3], ..Spec::default() };
        assert_eq!(parse("cloud.laz", &empty.file()).unwrap().point_count, 0);
        let empty = Spec { min: [f64::INFINITY; 3], max: [f64::NEG_INFINITY; 3], ..empty };
        assert_eq!(parse("cloud.laz", &empty.file()).unwrap().point_count, 0);
    }

    #[test]
    fn sizes_and_offsets_are_checked() {
        let good = Spec::default().file();
        let with = |at: usize, bytes: &[u8]| {
            let mut b = good.clone();
            b[at..at + bytes.len()].copy_from_slice(bytes);
            error(&b)
        };
        assert_eq!(
            with(94, &200u16.to_le_bytes()),
            "cloud.laz: header field `header_size`: 200 bytes, but a LAS 1.2 header has at least 227"
        );
        assert_eq!(
            with(96, &100u32.to_le_bytes()),
            "cloud.laz: header field `offset_to_point_data`: 100 lies inside the 227-byte header"
        );
        assert_eq!(
            with(96, &10_000u32.to_le_bytes()),
            "cloud.laz: header field `offset_to_point_data`: 10000 lies past the end of the file (311 bytes)"
        );
        // A VLR announced in a file without room for it.
        assert_eq!(
            with(100, &1u32.to_le_bytes()),
            "cloud.laz: header field `number_of_vlrs`: VLR 0 (bytes 227–280) runs past the point data at byte 227"
        );
        // Truncated points: 3 × 28 bytes announced after 227, 20 missing. LAZ sizes are not known from the header.
        let cut = &good[..good.len() - 20];
        assert_eq!(
            parse("cloud.las", cut).unwrap_err().to_string(),
            "cloud.las: header field `point_count`: 3 records of 28 bytes from byte 227 end at byte 311, \
             but the file has 291 bytes (truncated)"
        );
        assert!(parse_las_header("cloud.las", cut, None).is_ok());
        let laz = Spec { format_byte: 0x81, ..Spec::default() }.file();
        assert!(parse("cloud.laz", &laz[..240]).is_ok());
        // A count beyond any file does not overflow.
        let huge = Spec { version: (1, 4), legacy_count: 0, count: u64::MAX, ..Spec::default() };
        let err = parse_las_header("big.las", &huge.header(), Some(1 << 40)).unwrap_err();
        assert!(matches!(err, LasHeaderError::Truncated { count: u64::MAX, .. }), "{err}");
    }

    use plumbline_testkit::mutation::{edits, mutate};

    /// Valid files of several kinds to mutate.
    fn valid_files() -> Vec<Vec<u8>> {
        let geo = Spec { vlrs: vec![("LASF_Projection", 34735, geokeys(&[(3072, 25832)]))], ..Spec::default() };
        let wkt = Spec {
            version: (1, 4),
            format_byte: 0x86,
            record_length: 30,
            legacy_count: 0,
            global_encoding: 0x11,
            vlrs: vec![wkt_vlr(WKT_25832)],
            ..Spec::default()
        };
        vec![Spec::default().file(), geo.file(), wkt.file(), las_file((1, 2), 1, false, 4)]
    }

    /// What a parse may return: a header whose owned text is bounded by the input, or an error naming the file.
    fn check_outcome(
        name: &str,
        bytes: &[u8],
        outcome: Result<LasHeader, LasHeaderError>,
    ) -> Result<(), TestCaseError> {
        match outcome {
            Ok(h) => {
                if let LasCrs::Wkt(text) = &h.crs {
                    // Lossy UTF-8 turns a byte into at most 3.
                    prop_assert!(text.len() <= 3 * bytes.len());
                }
                prop_assert!(min_record_length(h.point_format).is_some_and(|m| h.point_record_length >= m));
            }
            Err(e) => prop_assert!(e.to_string().starts_with(&format!("{name}: header field `")), "{e}"),
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 256,
            rng_seed: proptest::test_runner::RngSeed::Fixed(17),
            ..ProptestConfig::default()
        })]

        #[test]
        fn arbitrary_bytes_never_panic(
            bytes in prop::collection::vec(any::<u8>(), 0..4096),
            file_len in prop::option::of(any::<u64>()),
            version in prop::option::of(0u8..5),
        ) {
            // Most cases start with the signature and a known version, so that they reach past those checks.
            let mut bytes = bytes;
            if let (Some(minor), Some(start)) = (version, bytes.get_mut(..26)) {
                start[..4].copy_from_slice(b"LASF");
                start[24..].copy_from_slice(&[1, minor]);
            }
            let outcome = parse_las_header("any.las", &bytes, file_len);
            check_outcome("any.las", &bytes, outcome)?;
        }

        #[test]
        fn mutated_headers_parse_or_name_the_file(
            which in 0usize..4,
            edits in edits(),
            with_len in any::<bool>(),
        ) {
            let bytes = mutate(valid_files().swap_remove(which), &edits);
            let file_len = with_len.then_some(bytes.len() as u64);
            let outcome = parse_las_header("mutated.laz", &bytes, file_len);
            check_outcome("mutated.laz", &bytes, outcome)?;
        }
    }
}
