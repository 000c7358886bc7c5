//! LAS/LAZ point clouds (the usual mobile-laser-scanning product) from bytes: mapping-frame coordinates with
//! their GPS time. The coordinates are taken to be in the campaign CRS (the services check the file's CRS).

use std::io::Cursor;

use las::Reader;

/// Points read per batch; a failing batch names its first record.
const BATCH: u64 = 65_536;

/// Why a point cloud could not be read.
#[derive(Debug, thiserror::Error)]
pub enum LasError {
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
pub fn read_las(file: &str, bytes: Vec<u8>) -> Result<LasPoints, LasError> {
    let mut reader =
        Reader::new(Cursor::new(bytes)).map_err(|source| LasError::Header { file: file.to_owned(), source })?;
    let format = *reader.header().point_format();
    if !format.has_gps_time {
        return Err(LasError::NoGpsTime { file: file.to_owned(), format: format.to_u8().unwrap_or(u8::MAX) });
    }
    let total = reader.header().number_of_points();
    let mut points = Vec::with_capacity(usize::try_from(total).unwrap_or(0).min(1 << 26));
    let mut first = 0u64;
    while first < total {
        let n = BATCH.min(total - first);
        let batch = reader.read_points(n).map_err(|source| LasError::Records {
            file: file.to_owned(),
            first,
            last: first + n - 1,
            total,
            source,
        })?;
        if (batch.len() as u64) < n {
            let missing = format!("{} records missing", n - batch.len() as u64);
            let source = las::Error::Io(std::io::Error::new(std::io::ErrorKind::UnexpectedEof, missing));
            return Err(LasError::Records { file: file.to_owned(), first, last: first + n - 1, total, source });
        }
        append(file, first, &batch, &mut points)?;
        first += n;
    }
    Ok(LasPoints { points, compressed: format.is_compressed })
}

fn append(file: &str, first: u64, batch: &las::PointData, out: &mut Vec<LasPoint>) -> Result<(), LasError> {
    let times: Vec<f64> = batch.gps_time().map(Iterator::collect).unwrap_or_default();
    for (i, ((x, y), z)) in batch.x().zip(batch.y()).zip(batch.z()).enumerate() {
        let record = first + i as u64;
        let gps_time = times.get(i).copied().unwrap_or(f64::NAN);
        for (field, v) in [("x", x), ("y", y), ("z", z), ("gps_time", gps_time)] {
            if !v.is_finite() {
                return Err(LasError::NotFinite { file: file.to_owned(), record, field });
            }
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
