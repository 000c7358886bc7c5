//! LAS/LAZ point clouds (the usual mobile-laser-scanning product) from bytes: mapping-frame coordinates with
//! their GPS time. The coordinates are taken to be in the campaign CRS (the services check the file's CRS).

use std::io::{Cursor, Read, Seek, SeekFrom};

use las::Reader;

use crate::las_header::{LAS_PREFIX_BYTES, LasHeader, LasHeaderError, parse_las_header};

/// Points read per batch; a failing batch names its first record.
pub(crate) const BATCH: u64 = 65_536;
/// Bytes of an extended VLR's header: reserved (2), user id (16), record id (2), record length (8),
/// description (32).
const EVLR_HEADER_LEN: u64 = 60;

/// Why a point cloud could not be read.
#[derive(Debug, thiserror::Error)]
pub enum LasError {
    /// The header is not a LAS header, or announces what the file cannot hold (checked before the `las`
    /// crate reads it, which would allocate from the announced sizes).
    #[error("point cloud {0}")]
    HeaderField(LasHeaderError),
    /// A LAZ chunk table announces more chunks than the compressed points have room for (each chunk starts
    /// with one point stored whole).
    #[error(
        "point cloud {file}: LAZ chunk table at byte {table} announces {chunks} chunks, but the {room} bytes of \
         compressed points before it hold at most {max} of {record_length}-byte first points"
    )]
    ChunkTable {
        /// The file.
        file: String,
        /// Byte offset of the chunk table.
        table: u64,
        /// Chunks announced.
        chunks: u32,
        /// Bytes between the chunk-table offset field and the table.
        room: u64,
        /// Chunks that fit (one may be empty).
        max: u64,
        /// Bytes of one point record.
        record_length: u16,
    },
    /// The header cannot be read.
    #[error("point cloud {file}: header: {source}")]
    Header {
        /// The file.
        file: String,
        /// The reader's error.
        source: las::Error,
    },
    /// Point records cannot be read (truncated file, corrupt LAZ chunk).
    #[error("point cloud {file}: point records {first}–{last} (of {total}): {source}")]
    Records {
        /// The file.
        file: String,
        /// First record of the failing batch (0-based).
        first: u64,
        /// Last record of the failing batch.
        last: u64,
        /// Records the header announces.
        total: u64,
        /// The reader's error.
        source: las::Error,
    },
    /// The point format has no GPS time.
    #[error("point cloud {file}: point data record format {format} has no GPS time")]
    NoGpsTime {
        /// The file.
        file: String,
        /// The format number.
        format: u8,
    },
    /// The points cannot be transformed into the campaign's CRS (the caller's transformation failed).
    #[error("point cloud {file}: cannot be moved into the campaign's CRS: {problem}")]
    Reproject {
        /// The file.
        file: String,
        /// What the transformation said.
        problem: String,
    },
    /// A COPC file's own records (info, hierarchy, LAZ items) are not usable; checked before any node is
    /// decoded.
    #[error("point cloud {file}: COPC `{field}`: {problem}")]
    Copc {
        /// The file.
        file: String,
        /// The record or field.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// A COPC node cannot be decoded (corrupt or truncated chunk).
    #[error("point cloud {file}: COPC node {node}, points {first}–{last} of its {count}: {problem}")]
    Node {
        /// The file.
        file: String,
        /// The node's key, level-x-y-z.
        node: String,
        /// First point of the failing batch within the node (0-based).
        first: u64,
        /// Last point of the failing batch.
        last: u64,
        /// Points the node announces.
        count: u64,
        /// The decoder's error.
        problem: String,
    },
    /// A record's coordinate is not finite after scaling.
    #[error("point cloud {file}: point record {record}: field `{field}` is not finite")]
    NotFinite {
        /// The file.
        file: String,
        /// The record (0-based).
        record: u64,
        /// The field.
        field: &'static str,
    },
}

/// One point of a cloud.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LasPoint {
    /// Easting, northing, height, metres.
    pub position: [f64; 3],
    /// GPS time, seconds (the file's time scale).
    pub gps_time: f64,
}

/// A point cloud read from bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct LasPoints {
    /// The points in file order.
    pub points: Vec<LasPoint>,
    /// Whether the file was LAZ-compressed.
    pub compressed: bool,
}

/// Read a LAS or LAZ file from memory. `file` names it in errors.
///
/// The header, the first extended VLR and a LAZ chunk table are checked against the file's length first, so
/// that a corrupt count is an error rather than a huge allocation in the `las` or `laz` crate. The `laz`
/// decoder can panic on corrupt compressed data (laz-rs issue #43: a division by zero, and debug assertions);
/// such a panic becomes the error of the header or the batch of records being read.
pub fn read_las(file: &str, bytes: Vec<u8>) -> Result<LasPoints, LasError> {
    let len = bytes.len() as u64;
    let checked = check_extents(file, len, |at, n| Ok(slice_at(&bytes, at, n)))?;
    // Never more than the bytes hold uncompressed (LAZ grows the vector as points arrive).
    let capacity = (bytes.len() as u64 / u64::from(checked.point_record_length)).min(checked.point_count);
    let mut points = Vec::with_capacity(usize::try_from(capacity).unwrap_or(0));
    stream_las_points(file, bytes, |batch| points.extend_from_slice(batch))?;
    Ok(LasPoints { points, compressed: checked.compressed })
}

/// Stream a LAS or LAZ file's points with their GPS times from memory in batches of up to 65 536, checked as
/// in [`read_las`]. Returns the header and the points read. A format without GPS time is an error, and so is
/// a record whose coordinates or time are not finite, naming it.
pub fn stream_las_points<B: AsRef<[u8]> + Send + Sync + 'static>(
    file: &str,
    bytes: B,
    visit: impl FnMut(&[LasPoint]),
) -> Result<(LasHeader, u64), LasError> {
    let len = bytes.as_ref().len() as u64;
    stream_las_points_from(file, Cursor::new(bytes), len, visit)
}

/// Stream a LAS or LAZ file's coordinates from memory in batches of up to 65 536 points, checked as in
/// [`read_las`] (header and extents before anything is allocated, a decoder panic turned into an error); GPS
/// time is not needed. Returns the header and the points read. A record whose coordinates are not finite is
/// an error naming it.
pub fn stream_las_xyz<B: AsRef<[u8]> + Send + Sync + 'static>(
    file: &str,
    bytes: B,
    visit: impl FnMut(&[[f64; 3]]),
) -> Result<(LasHeader, u64), LasError> {
    let len = bytes.as_ref().len() as u64;
    stream_las_xyz_from(file, Cursor::new(bytes), len, visit)
}

/// Stream a LAS or LAZ file's points with their GPS times from any seekable source of `len` bytes (a file, or
/// an object read by range requests), as [`stream_las_points`] does from memory: the header, the first
/// extended VLR and a LAZ chunk table are checked by reading just those bytes, then the points are decoded
/// as the source delivers them, so memory holds what the source buffers and one batch.
pub fn stream_las_points_from<R: Read + Seek + Send + Sync + 'static>(
    file: &str,
    source: R,
    len: u64,
    mut visit: impl FnMut(&[LasPoint]),
) -> Result<(LasHeader, u64), LasError> {
    let mut points = Vec::new();
    stream_batches(file, source, len, true, |first, batch| {
        points.clear();
        append(file, first, batch, &mut points)?;
        visit(&points);
        Ok(())
    })
}

/// [`stream_las_xyz`] from any seekable source of `len` bytes (see [`stream_las_points_from`]).
pub fn stream_las_xyz_from<R: Read + Seek + Send + Sync + 'static>(
    file: &str,
    source: R,
    len: u64,
    mut visit: impl FnMut(&[[f64; 3]]),
) -> Result<(LasHeader, u64), LasError> {
    let mut xyz: Vec<[f64; 3]> = Vec::new();
    stream_batches(file, source, len, false, |first, batch| xyz_of(file, first, batch, &mut xyz).map(|()| visit(&xyz)))
}

/// The checked reading loop behind the streams: `visit(first record, batch)`.
fn stream_batches<R: Read + Seek + Send + Sync + 'static>(
    file: &str,
    mut source: R,
    len: u64,
    need_time: bool,
    mut visit: impl FnMut(u64, &las::PointData) -> Result<(), LasError>,
) -> Result<(LasHeader, u64), LasError> {
    let io = |source| LasError::Header { file: file.to_owned(), source: las::Error::Io(source) };
    let header = check_extents(file, len, |at, n| read_at(&mut source, at, n))?;
    source.seek(SeekFrom::Start(0)).map_err(io)?;
    if header.compressed {
        return stream_laz(file, source, header, need_time, visit);
    }
    let mut reader =
        unpanicked(|| Reader::new(source)).map_err(|source| LasError::Header { file: file.to_owned(), source })?;
    let format = *reader.header().point_format();
    time_present(file, &format, need_time)?;
    let total = reader.header().number_of_points();
    let mut first = 0u64;
    while first < total {
        let n = BATCH.min(total - first);
        let records = |source| LasError::Records { file: file.to_owned(), first, last: first + n - 1, total, source };
        let batch = unpanicked(|| reader.read_points(n)).map_err(records)?;
        if (batch.len() as u64) < n {
            let missing = format!("{} records missing", n - batch.len() as u64);
            return Err(records(las::Error::Io(std::io::Error::new(std::io::ErrorKind::UnexpectedEof, missing))));
        }
        visit(first, &batch)?;
        first += n;
    }
    Ok((header, total))
}

/// An error when GPS time is needed and the point format has none.
pub(crate) fn time_present(file: &str, format: &las::point::Format, need_time: bool) -> Result<(), LasError> {
    if need_time && !format.has_gps_time {
        return Err(LasError::NoGpsTime { file: file.to_owned(), format: format.to_u8().unwrap_or(u8::MAX) });
    }
    Ok(())
}

/// The LAZ fields decoded: coordinates, and GPS time when `need_time`.
pub(crate) fn decoded_fields(need_time: bool) -> laz::DecompressionSelection {
    let coordinates = laz::DecompressionSelection::xy_returns_channel().decompress_z();
    if need_time { coordinates.decompress_gps_time() } else { coordinates }
}

/// The LAZ side of [`stream_batches`], decoding only the fields used: coordinates, and GPS time when
/// `need_time` (LAS 1.4 formats store the others in layers of their own, which are then skipped undecoded).
fn stream_laz<R: Read + Seek + Send + Sync + 'static>(
    file: &str,
    mut source: R,
    checked: LasHeader,
    need_time: bool,
    mut visit: impl FnMut(u64, &las::PointData) -> Result<(), LasError>,
) -> Result<(LasHeader, u64), LasError> {
    let header = las_header_of(file, &mut source)?;
    let format = *header.point_format();
    time_present(file, &format, need_time)?;
    let at_header = |source| LasError::Header { file: file.to_owned(), source };
    let vlr = header.laz_vlr().map_err(at_header)?;
    let selection = decoded_fields(need_time);
    let start = u64::from(checked.offset_to_point_data);
    let record_len = usize::from(format.len());
    source.seek(SeekFrom::Start(start)).map_err(|e| at_header(e.into()))?;
    let mut source = LayerGuard::new(source, &vlr, start, record_len as u64).map_err(at_header)?;
    source.seek(SeekFrom::Start(start)).map_err(|e| at_header(e.into()))?;
    let mut decompressor =
        unpanicked(|| Ok(laz::LasZipDecompressor::selective(source, vlr, selection)?)).map_err(at_header)?;
    let total = header.number_of_points();
    // One batch buffer, decoded into again and again: fields not selected keep stale bytes, never read.
    let mut batch = las::PointDataBuilder::new().for_header(&header).build();
    let mut first = 0u64;
    while first < total {
        let n = BATCH.min(total - first);
        let records = |source| LasError::Records { file: file.to_owned(), first, last: first + n - 1, total, source };
        let bytes = batch.resize_for(usize::try_from(n).unwrap_or(0));
        unpanicked(|| Ok(laz::LazDecompressor::decompress_many(&mut decompressor, bytes)?)).map_err(records)?;
        visit(first, &batch)?;
        first += n;
    }
    Ok((checked, total))
}

/// The number of layer sizes a chunk of these items carries; `None` for items that are not layered.
pub(crate) fn layer_count(items: &[laz::LazItem]) -> Option<u64> {
    items
        .iter()
        .map(|item| match item.item_type() {
            laz::LazItemType::Point14 => Some(9),
            laz::LazItemType::RGB14 | laz::LazItemType::WavePacket14 => Some(1),
            laz::LazItemType::RGBNIR14 => Some(2),
            laz::LazItemType::Byte14(n) => Some(u64::from(n)),
            _ => None,
        })
        .sum()
}

/// A LAZ point section as the `laz` decoder reads it, refusing a layered chunk (LAS 1.4 formats 6–10) whose
/// layers announce more bytes than the chunk holds: the decoder reads every layer's size at the chunk's
/// start and then allocates each one it decodes, so the sizes are checked as they pass, before it can.
/// Sections of other formats (no layers) pass through untouched.
struct LayerGuard<R> {
    inner: R,
    pos: u64,
    /// Per layered chunk: where its layer sizes start, how many bytes they take, the bytes the chunk holds
    /// after them, and its index in the chunk table; sorted by start.
    windows: Vec<(u64, u64, u64, usize)>,
    /// The sizes of the window being read so far (a window may come in two reads).
    seen: Vec<u8>,
}

impl<R: Read + Seek> LayerGuard<R> {
    /// `source` positioned at the point data (`start`): the chunk table is read to find every chunk.
    fn new(mut source: R, vlr: &laz::LazVlr, start: u64, record_len: u64) -> las::Result<Self> {
        let layers = layer_count(vlr.items()).unwrap_or(0);
        let mut windows = Vec::new();
        if layers > 0 {
            let table = laz::laszip::ChunkTable::read_from(&mut source, vlr)
                .map_err(|e| las::Error::Io(std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string())))?;
            // The first chunk follows the 8-byte offset of the chunk table.
            let mut at = start + 8;
            let head = record_len + 4 + 4 * layers;
            for (k, entry) in table.as_ref().iter().enumerate() {
                // An empty chunk (no points, fewer bytes than a head) is never read as one.
                if entry.point_count > 0 && entry.byte_count >= head {
                    windows.push((at + record_len + 4, 4 * layers, entry.byte_count - head, k));
                }
                at = at.saturating_add(entry.byte_count);
            }
        }
        Ok(Self { inner: source, pos: 0, windows, seen: Vec::new() })
    }

    /// Check the bytes `bytes` read at `self.pos` against the window they fall in, if any.
    fn check(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let end = self.pos + bytes.len() as u64;
        let first = self.windows.partition_point(|w| w.0 + w.1 <= self.pos);
        for &(at, len, room, chunk) in self.windows[first..].iter().take_while(|w| w.0 < end) {
            let from = at.max(self.pos);
            let to = (at + len).min(end);
            if from == at {
                self.seen.clear();
            }
            let offset = usize::try_from(from - self.pos).unwrap_or(usize::MAX);
            let take = usize::try_from(to - from).unwrap_or(0);
            self.seen.extend_from_slice(bytes.get(offset..offset.saturating_add(take)).unwrap_or_default());
            if to == at + len {
                let announced: u64 =
                    self.seen.chunks_exact(4).map(|b| u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))).sum();
                if announced > room {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!("LAZ chunk {chunk}: its layers announce {announced} bytes, the chunk holds {room}"),
                    ));
                }
                self.seen.clear();
            }
        }
        Ok(())
    }
}

impl<R: Read + Seek> Read for LayerGuard<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        if !self.windows.is_empty() {
            self.check(&buf[..n])?;
        }
        self.pos += n as u64;
        Ok(n)
    }
}

impl<R: Read + Seek> Seek for LayerGuard<R> {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        self.pos = self.inner.seek(to)?;
        Ok(self.pos)
    }
}

/// `read`, with a panic inside (the `laz` decoder on corrupt data) turned into an error. The reader is not
/// used after a panic: its error ends the read.
pub(crate) fn unpanicked<T>(read: impl FnOnce() -> las::Result<T>) -> las::Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(read)).unwrap_or_else(|_| {
        let message = "corrupt compressed data: the LAZ decoder failed (panicked)";
        Err(las::Error::Io(std::io::Error::new(std::io::ErrorKind::InvalidData, message)))
    })
}

/// The header checked, and what the `las` and `laz` crates would allocate from it bounded by the file:
/// the end of the point records representable, the first extended VLR inside the file, a LAZ chunk table's
/// count within what the compressed points can hold. A truncated point section is left to the reader, whose
/// error names the failing records. `at(offset, n)` gives up to `n` bytes of the `len`-byte file from
/// `offset` (fewer at its end).
pub(crate) fn check_extents(
    file: &str,
    len: u64,
    mut at: impl FnMut(u64, usize) -> std::io::Result<Vec<u8>>,
) -> Result<LasHeader, LasError> {
    let io = |source| LasError::Header { file: file.to_owned(), source: las::Error::Io(source) };
    let prefix_len = usize::try_from(len.min(LAS_PREFIX_BYTES as u64)).unwrap_or(LAS_PREFIX_BYTES);
    let prefix = at(0, prefix_len).map_err(io)?;
    let mut take8 = |offset: u64| -> Result<Option<[u8; 8]>, LasError> {
        let bytes = at(offset, 8).map_err(io)?;
        Ok(bytes.as_slice().try_into().ok())
    };
    // The length is left out: a point section cut short is the reader's error, which names the records.
    let header = parse_las_header(file, &prefix, None).map_err(LasError::HeaderField)?;
    let invalid =
        |field, problem| LasError::HeaderField(LasHeaderError::Invalid { file: file.to_owned(), field, problem });
    let offset = u64::from(header.offset_to_point_data);
    let record_length = u64::from(header.point_record_length);
    if header.point_count.checked_mul(record_length).and_then(|n| n.checked_add(offset)).is_none() {
        let problem = format!("{} records of {record_length} bytes end past any file", header.point_count);
        return Err(invalid("point_count", problem));
    }
    // The reader reads every EVLR, allocating each one's announced length: each must end within the file.
    let mut evlr = header.start_of_first_evlr;
    if evlr > 0 {
        for k in 0..header.number_of_evlrs {
            let data_len = match evlr.checked_add(20) {
                Some(field) => take8(field)?.map(u64::from_le_bytes),
                None => None,
            };
            let end =
                data_len.and_then(|n| evlr.checked_add(EVLR_HEADER_LEN)?.checked_add(n)).filter(|end| *end <= len);
            let Some(end) = end else {
                let problem = format!("extended VLR {k} at byte {evlr} does not end within the file ({len} bytes)");
                return Err(invalid("start_of_first_evlr", problem));
            };
            evlr = end;
        }
    }
    if header.compressed {
        check_chunk_table(file, len, &mut take8, offset, header.point_record_length)?;
    }
    Ok(header)
}

/// The LAZ chunk table's count against the compressed bytes before it. Its offset is the first 8 bytes of
/// the point data, or the file's last 8 when the writer could not go back (as the `laz` crate finds it); a
/// table the reader will not find is left to it.
fn check_chunk_table(
    file: &str,
    len: u64,
    take8: &mut impl FnMut(u64) -> Result<Option<[u8; 8]>, LasError>,
    data_start: u64,
    record_length: u16,
) -> Result<(), LasError> {
    // A negative offset counts as "not written", like one before the data.
    let mut offset_at = |at: u64| take8(at).map(|b| b.map(|b| u64::try_from(i64::from_le_bytes(b)).unwrap_or(0)));
    let Some(mut table) = offset_at(data_start)? else { return Ok(()) };
    if table <= data_start {
        let Some(at_end) = offset_at(len.saturating_sub(8))? else { return Ok(()) };
        table = at_end;
    }
    if table <= data_start {
        return Ok(());
    }
    // The table starts with its version (4 bytes) and its chunk count (4 bytes).
    let Some(chunks) = take8(table)?.map(|b| u32::from_le_bytes([b[4], b[5], b[6], b[7]])) else {
        let problem = format!(
            "announces the LAZ chunk table at byte {table}, past the end of the file ({len} bytes): the file is truncated"
        );
        return Err(LasError::HeaderField(LasHeaderError::Invalid {
            file: file.to_owned(),
            field: "laz_chunk_table_offset",
            problem,
        }));
    };
    // Every chunk but a last, empty one starts with its first point stored whole.
    let room = table.saturating_sub(data_start + 8);
    let max = room / u64::from(record_length) + 1;
    if u64::from(chunks) > max {
        return Err(LasError::ChunkTable { file: file.to_owned(), table, chunks, room, max, record_length });
    }
    Ok(())
}

/// Up to `n` bytes of `bytes` from `at` (fewer at the end, none past it).
fn slice_at(bytes: &[u8], at: u64, n: usize) -> Vec<u8> {
    let start = usize::try_from(at).unwrap_or(usize::MAX).min(bytes.len());
    bytes[start..start.saturating_add(n).min(bytes.len())].to_vec()
}

/// Up to `n` bytes of a seekable source from `at` (fewer at its end).
pub(crate) fn read_at<R: Read + Seek>(source: &mut R, at: u64, n: usize) -> std::io::Result<Vec<u8>> {
    source.seek(SeekFrom::Start(at))?;
    let mut out = Vec::with_capacity(n.min(LAS_PREFIX_BYTES));
    source.take(n as u64).read_to_end(&mut out)?;
    Ok(out)
}

/// A batch's coordinates into `out` (cleared first); a coordinate that is not finite is an error naming its
/// record.
pub(crate) fn xyz_of(file: &str, first: u64, batch: &las::PointData, out: &mut Vec<[f64; 3]>) -> Result<(), LasError> {
    out.clear();
    for (i, ((x, y), z)) in batch.x().zip(batch.y()).zip(batch.z()).enumerate() {
        for (field, v) in [("x", x), ("y", y), ("z", z)] {
            if !v.is_finite() {
                return Err(LasError::NotFinite { file: file.to_owned(), record: first + i as u64, field });
            }
        }
        out.push([x, y, z]);
    }
    Ok(())
}

pub(crate) fn append(file: &str, first: u64, batch: &las::PointData, out: &mut Vec<LasPoint>) -> Result<(), LasError> {
    // One pass over the records (the column iterators would walk them four times).
    let format = batch.format();
    let time_at = format.has_gps_time.then_some(if format.is_extended { 22 } else { 20 });
    let t = batch.transforms();
    let le_i32 = |r: &[u8], at: usize| i32::from_le_bytes([r[at], r[at + 1], r[at + 2], r[at + 3]]);
    out.reserve(batch.len());
    for (i, r) in batch.raw_bytes().chunks_exact(batch.record_len()).enumerate() {
        let (x, y, z) = (t.x.direct(le_i32(r, 0)), t.y.direct(le_i32(r, 4)), t.z.direct(le_i32(r, 8)));
        let gps_time = time_at.map_or(f64::NAN, |at| {
            f64::from_le_bytes([r[at], r[at + 1], r[at + 2], r[at + 3], r[at + 4], r[at + 5], r[at + 6], r[at + 7]])
        });
        if !(x.is_finite() && y.is_finite() && z.is_finite() && gps_time.is_finite()) {
            let record = first + i as u64;
            let field = [("x", x), ("y", y), ("z", z), ("gps_time", gps_time)]
                .into_iter()
                .find(|(_, v)| !v.is_finite())
                .map_or("gps_time", |(f, _)| f);
            return Err(LasError::NotFinite { file: file.to_owned(), record, field });
        }
        out.push(LasPoint { position: [x, y, z], gps_time });
    }
    Ok(())
}

/// How a point cloud is cut into frames for the detector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudSlicing {
    /// Length of a frame in GPS time, seconds.
    pub slice_s: f64,
    /// One-sigma range error of the scanner, metres.
    pub range_sigma_m: f64,
    /// Angular resolution of the detector's bearing bins, radians.
    pub angular_step: f64,
    /// Frames farther than this from their scanner position are cut off, metres.
    pub max_range_m: f64,
}

impl Default for CloudSlicing {
    fn default() -> Self {
        Self { slice_s: 1.0, range_sigma_m: 0.02, angular_step: 0.2f64.to_radians(), max_range_m: 30.0 }
    }
}

/// A point cloud cut into time slices, each seen from the scanner position at its middle time
/// (`origin_at(t)`, e.g. the trajectory's antenna-to-scanner position; `None` skips the slice). Each point's
/// error lies along the line from that position (the scanner's range error). Returns (middle time, frame).
pub fn cloud_frames(
    cloud: &LasPoints,
    slicing: &CloudSlicing,
    origin_at: impl Fn(f64) -> Option<[f64; 3]>,
) -> Vec<(f64, crate::points::FramePoints)> {
    let mut sorted: Vec<&LasPoint> = cloud.points.iter().collect();
    sorted.sort_by(|a, b| a.gps_time.total_cmp(&b.gps_time));
    let mut out = Vec::new();
    let step = slicing.slice_s.max(1e-3);
    for chunk in sorted.chunk_by(|a, b| (a.gps_time / step).floor() == (b.gps_time / step).floor()) {
        let t = ((chunk[0].gps_time / step).floor() + 0.5) * step;
        let Some(o) = origin_at(t) else { continue };
        let origin = nalgebra::Vector3::from(o);
        let points = chunk
            .iter()
            .filter_map(|p| {
                let position = nalgebra::Vector3::from(p.position);
                let d = position - origin;
                let n = d.norm();
                (n > 1e-6 && n <= slicing.max_range_m).then(|| crate::points::FramePoint {
                    position,
                    error: d / n * slicing.range_sigma_m,
                    row: None,
                })
            })
            .collect();
        let frame = crate::points::FramePoints {
            origin,
            angular_step: slicing.angular_step,
            reliable_range_m: slicing.max_range_m,
            points,
        };
        out.push((t, frame));
    }
    out
}

/// How [`encode_las`] writes a cloud.
#[derive(Clone, Debug, PartialEq)]
pub struct LasEncoding {
    /// LAZ-compressed.
    pub compressed: bool,
    /// OGC WKT of the CRS, written as a `LASF_Projection` record 2112 VLR (global-encoding WKT bit set).
    pub wkt: Option<String>,
    /// GPS times as adjusted standard GPS time (GPS seconds since 1980-01-06 minus 10⁹, global-encoding bit
    /// 0 set) instead of GPS week seconds; `gps_week` is the week of the points' week seconds.
    pub adjusted_standard_week: Option<u32>,
}

/// A cloud as LAS 1.4 point format 6 (coordinates at millimetre resolution, GPS time), e.g. a simulated
/// scanner strip. Fails when a coordinate does not fit the millimetre grid around the cloud's first point.
pub fn encode_las(points: &[LasPoint], encoding: &LasEncoding) -> Result<Vec<u8>, las::Error> {
    let mut builder = builder(points, encoding)?;
    builder.point_format.is_compressed = encoding.compressed;
    let mut writer = las::Writer::new(Cursor::new(Vec::new()), builder.into_header()?)?;
    for p in points {
        let [x, y, z] = p.position;
        writer.write_point(las::Point {
            x,
            y,
            z,
            gps_time: Some(time_of(p.gps_time, encoding)),
            ..Default::default()
        })?;
    }
    Ok(writer.into_inner()?.into_inner())
}

/// The header [`encode_las`] and `copc::encode_copc` start from: LAS 1.4 format 6, millimetre grid around
/// the first point, the CRS and time type of `encoding`.
pub(crate) fn builder(points: &[LasPoint], encoding: &LasEncoding) -> Result<las::Builder, las::Error> {
    let mut builder = las::Builder::from((1, 4));
    builder.point_format = las::point::Format::new(6)?;
    let origin = points.first().map_or([0.0; 3], |p| p.position.map(|v| (v / 1000.0).round() * 1000.0));
    let t = |offset| las::Transform { scale: 0.001, offset };
    builder.transforms = las::Vector { x: t(origin[0]), y: t(origin[1]), z: t(origin[2]) };
    if let Some(wkt) = &encoding.wkt {
        builder.vlrs.push(las::Vlr {
            user_id: "LASF_Projection".into(),
            record_id: 2112,
            description: "OGC WKT".into(),
            data: [wkt.as_bytes(), &[0]].concat(),
        });
        builder.has_wkt_crs = true;
    }
    if encoding.adjusted_standard_week.is_some() {
        builder.gps_time_type = las::GpsTimeType::Standard;
    }
    Ok(builder)
}

/// A point's week-second time as `encoding` writes it.
pub(crate) fn time_of(t: f64, encoding: &LasEncoding) -> f64 {
    match encoding.adjusted_standard_week {
        Some(week) => f64::from(week) * crate::las_header::GPS_WEEK_S + t - 1e9,
        None => t,
    }
}

/// The `las` crate's full header (VLRs and extended VLRs) from a source whose extents were checked
/// ([`check_extents`]); a decoder panic becomes the error.
pub(crate) fn las_header_of<R: Read + Seek>(file: &str, source: &mut R) -> Result<las::Header, LasError> {
    unpanicked(|| las::Header::new(&mut *source)).map_err(|source| LasError::Header { file: file.to_owned(), source })
}
