//! Cloud-optimised point clouds (COPC 1.0) read node by node, and written (the simulator's COPC variant).
//!
//! A COPC file is a LAZ 1.4 file whose points are grouped by the nodes of an octree. Each node is one LAZ
//! chunk, and a hierarchy record at the file's end gives each node's key, file offset, size and point count.
//! A reader that needs one area decodes only the nodes whose cubes meet it, by range reads.
//!
//! [`CopcIndex::read`] checks the hierarchy against the file before anything is decoded: every node inside
//! the point data, its point count within the header's, the node keys inside the octree, and the chunk's
//! own layer sizes within the node's bytes. The `las` crate's COPC reader would allocate a node's
//! announced size unchecked, so the nodes are decoded here, in batches of bounded size.
//!
//! Points within a node are in the order they were written, not GPS-time order: a caller that needs time
//! order sorts what it selected.

use std::collections::{HashMap, HashSet};
use std::io::{Cursor, Read, Seek, SeekFrom, Write};

use laz::record::{LayeredPointRecordDecompressor, RecordDecompressor};
use laz::{LazItem, LazVlr};

use crate::las::{
    BATCH, LasEncoding, LasError, LasPoint, append, check_extents, las_header_of, layer_count, unpanicked, xyz_of,
};
use crate::las_header::LasHeader;

/// The deepest octree level accepted (a node's cube at level 24 of a 100 km root is 6 mm wide).
const MAX_LEVEL: i32 = 24;
/// Bytes of a hierarchy entry: key (4 × i32), offset (u64), byte size (i32), point count (i32).
const ENTRY_LEN: u64 = 32;

/// One octree node that holds points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CopcNode {
    /// Level, x, y, z of the node's key.
    pub key: [i32; 4],
    /// The node's cube: minimum and maximum corner (x, y, z), in the file's coordinates.
    pub min: [f64; 3],
    /// See `min`.
    pub max: [f64; 3],
    /// Points in the node.
    pub point_count: u64,
    offset: u64,
    byte_size: u64,
}

impl CopcNode {
    /// Whether the node's cube meets the horizontal box `[min x, min y, max x, max y]`.
    pub fn meets(&self, b: [f64; 4]) -> bool {
        self.min[0] <= b[2] && self.max[0] >= b[0] && self.min[1] <= b[3] && self.max[1] >= b[1]
    }

    /// Bytes of the node's LAZ chunk.
    pub fn byte_size(&self) -> u64 {
        self.byte_size
    }

    fn name(&self) -> String {
        key_name(self.key)
    }
}

/// A node key as errors name it: level-x-y-z.
fn key_name([l, x, y, z]: [i32; 4]) -> String {
    format!("{l}-{x}-{y}-{z}")
}

/// A COPC file's nodes, checked against the file (see the module).
#[derive(Debug)]
pub struct CopcIndex {
    header: las::Header,
    summary: LasHeader,
    items: Vec<LazItem>,
    nodes: Vec<CopcNode>,
}

impl CopcIndex {
    /// Read and check the header and hierarchy of the `len`-byte COPC file `source`. `file` names it in
    /// errors.
    pub fn read<R: Read + Seek>(file: &str, source: &mut R, len: u64) -> Result<Self, LasError> {
        let io = |source| LasError::Header { file: file.to_owned(), source: las::Error::Io(source) };
        let summary = check_extents(file, len, |at, n| crate::las::read_at(source, at, n))?;
        let invalid = |field: &'static str, problem: String| LasError::Copc { file: file.to_owned(), field, problem };
        if !summary.copc {
            return Err(invalid("vlrs", "the first VLR is not COPC's info record (user `copc`, record 1)".into()));
        }
        source.seek(SeekFrom::Start(0)).map_err(io)?;
        let header = las_header_of(file, &mut *source)?;
        let info =
            header.copc_info_vlr().ok_or_else(|| invalid("copc_info", "COPC's info record cannot be read".into()))?;
        let hierarchy = header.copc_hierarchy_evlr().ok_or_else(|| {
            invalid("copc_hierarchy", "the hierarchy record is missing, or a page lies outside it".into())
        })?;
        let items = header
            .laz_vlr()
            .map_err(|e| invalid("laszip", format!("the LAZ record cannot be read: {e}")))?
            .items()
            .clone();
        let record_len = u64::from(summary.point_record_length);
        let items_len: u64 = items.iter().map(|i| u64::from(i.size())).sum();
        if items_len != record_len {
            let problem = format!("its items hold {items_len} bytes a point, the header says {record_len}");
            return Err(invalid("laszip", problem));
        }
        let layers = layer_count(&items)
            .ok_or_else(|| invalid("laszip", "COPC needs LAS 1.4 layered point items (formats 6 to 8)".to_owned()))?;
        let usable = [info.center_x, info.center_y, info.center_z, info.halfsize].iter().all(|v| v.is_finite());
        if !(usable && info.halfsize > 0.0) {
            let problem = format!("octree centre or half size not usable ({}, {})", info.center_x, info.halfsize);
            return Err(invalid("copc_info", problem));
        }
        let data_start = u64::from(summary.offset_to_point_data) + 8;
        // A node's chunk: its first point whole, the point count, one size per layer, then the layers.
        let least = record_len + 4 + 4 * layers;
        let mut nodes = Vec::new();
        let mut seen = HashSet::new();
        let mut total = 0u64;
        for entry in hierarchy.iter_entries() {
            let entry = entry.map_err(|e| invalid("copc_hierarchy", e.to_string()))?;
            let k = entry.key;
            let name = key_name([k.l, k.x, k.y, k.z]);
            let side = if (0..=MAX_LEVEL).contains(&k.l) { 1i64 << k.l } else { 0 };
            if ![k.x, k.y, k.z].iter().all(|&c| (0..side).contains(&i64::from(c))) {
                return Err(invalid("copc_hierarchy", format!("node {name} lies outside the octree")));
            }
            if !seen.insert([k.l, k.x, k.y, k.z]) {
                return Err(invalid("copc_hierarchy", format!("node {name} is listed twice")));
            }
            if entry.point_count < -1 {
                return Err(invalid("copc_hierarchy", format!("node {name}: point count {}", entry.point_count)));
            }
            let Ok(point_count) = u64::try_from(entry.point_count) else { continue };
            if point_count == 0 {
                continue;
            }
            let byte_size = u64::try_from(entry.byte_size).unwrap_or(0);
            let end = entry.offset.checked_add(byte_size);
            if entry.offset < data_start || byte_size < least || end.is_none_or(|e| e > len) {
                let problem = format!(
                    "node {name}: {byte_size} bytes at byte {} do not lie within the point data (bytes \
                     {data_start}–{len}) or cannot hold one point",
                    entry.offset
                );
                return Err(invalid("copc_hierarchy", problem));
            }
            total = total.saturating_add(point_count);
            if total > summary.point_count {
                let problem = format!("the nodes hold more points than the header's {}", summary.point_count);
                return Err(invalid("copc_hierarchy", problem));
            }
            let size = 2.0 * info.halfsize / (side as f64);
            let root = [info.center_x, info.center_y, info.center_z].map(|c| c - info.halfsize);
            let min = [0, 1, 2].map(|a| root[a] + size * f64::from([k.x, k.y, k.z][a]));
            nodes.push(CopcNode {
                key: [k.l, k.x, k.y, k.z],
                min,
                max: min.map(|v| v + size),
                point_count,
                offset: entry.offset,
                byte_size,
            });
        }
        nodes.sort_by_key(|n| n.offset);
        if nodes.windows(2).any(|w| w[0].offset + w[0].byte_size > w[1].offset) {
            return Err(invalid("copc_hierarchy", "two nodes' chunks overlap".into()));
        }
        Ok(Self { header, summary, items, nodes })
    }

    /// The header, as [`crate::parse_las_header`] reads it.
    pub fn header(&self) -> &LasHeader {
        &self.summary
    }

    /// The nodes holding points, in file order.
    pub fn nodes(&self) -> &[CopcNode] {
        &self.nodes
    }

    /// Decode `nodes` (of this file, e.g. those meeting an area) from `source`, handing their points with
    /// GPS time to `visit` in batches; the point format must carry GPS time. Returns the points read.
    pub fn stream_points<R: Read + Seek>(
        &self,
        file: &str,
        source: &mut R,
        nodes: &[CopcNode],
        mut visit: impl FnMut(&[LasPoint]),
    ) -> Result<u64, LasError> {
        crate::las::time_present(file, self.header.point_format(), true)?;
        let mut points = Vec::new();
        self.decode(file, source, nodes, true, |first, batch| {
            points.clear();
            append(file, first, batch, &mut points)?;
            visit(&points);
            Ok(())
        })
    }

    /// [`Self::stream_points`] for coordinates alone (any point format).
    pub fn stream_xyz<R: Read + Seek>(
        &self,
        file: &str,
        source: &mut R,
        nodes: &[CopcNode],
        mut visit: impl FnMut(&[[f64; 3]]),
    ) -> Result<u64, LasError> {
        let mut xyz = Vec::new();
        self.decode(file, source, nodes, false, |first, batch| {
            xyz_of(file, first, batch, &mut xyz).map(|()| visit(&xyz))
        })
    }

    /// Decode the nodes in batches — coordinates, and GPS time when `need_time` (the other layers are skipped
    /// undecoded): `visit(number of points decoded before, batch)`.
    fn decode<R: Read + Seek>(
        &self,
        file: &str,
        source: &mut R,
        nodes: &[CopcNode],
        need_time: bool,
        mut visit: impl FnMut(u64, &las::PointData) -> Result<(), LasError>,
    ) -> Result<u64, LasError> {
        let selection = crate::las::decoded_fields(need_time);
        // One batch buffer for every node: fields not selected keep stale bytes, never read.
        let mut batch = las::PointDataBuilder::new().for_header(&self.header).build();
        let mut done = 0u64;
        for node in nodes {
            let failed = |first: u64, last: u64, problem: String| LasError::Node {
                file: file.to_owned(),
                node: node.name(),
                first,
                last,
                count: node.point_count,
                problem,
            };
            self.check_layers(source, node).map_err(|p| failed(0, 0, p))?;
            source.seek(SeekFrom::Start(node.offset)).map_err(|e| failed(0, 0, e.to_string()))?;
            let mut decompressor = LayeredPointRecordDecompressor::new(&mut *source);
            decompressor.set_fields_from(&self.items).map_err(|e| failed(0, 0, e.to_string()))?;
            decompressor.set_selection(selection);
            let mut first = 0u64;
            while first < node.point_count {
                let n = BATCH.min(node.point_count - first);
                let last = first + n - 1;
                // At most BATCH records, whatever the node announces.
                let bytes = batch.resize_for(usize::try_from(n).unwrap_or(0));
                unpanicked(|| decompressor.decompress_many(bytes).map_err(las::Error::Io))
                    .map_err(|e| failed(first, last, e.to_string()))?;
                visit(done + first, &batch)?;
                first += n;
            }
            done += node.point_count;
        }
        Ok(done)
    }

    /// The sizes a node's chunk announces for its layers, against the node's bytes (the decoder allocates
    /// them before reading).
    fn check_layers<R: Read + Seek>(&self, source: &mut R, node: &CopcNode) -> Result<(), String> {
        let record_len = u64::from(self.summary.point_record_length);
        let layers = layer_count(&self.items).unwrap_or(0);
        let at = node.offset + record_len + 4;
        let bytes =
            crate::las::read_at(source, at, usize::try_from(4 * layers).unwrap_or(0)).map_err(|e| e.to_string())?;
        let announced: u64 =
            bytes.chunks_exact(4).map(|b| u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))).sum();
        let room = node.byte_size - (record_len + 4 + 4 * layers);
        if (bytes.len() as u64) < 4 * layers || announced > room {
            return Err(format!("its layers announce {announced} bytes, its chunk holds {room}"));
        }
        Ok(())
    }
}

/// Octree cells per axis of a node: a point joins the first node on its way down whose cell it is alone in.
const GRID: f64 = 128.0;
/// The deepest level the writer makes (points past it stay in their level-10 node).
const WRITE_LEVELS: i32 = 10;
/// Fewest points of a node with children: a smaller subtree is written as one node.
const MIN_NODE_POINTS: usize = 20_000;

/// A cloud as a COPC 1.0 file (LAS 1.4 point format 6 at millimetre resolution with GPS time, one LAZ chunk
/// per octree node, as [`crate::encode_las`] writes LAZ otherwise): e.g. the simulator's COPC variant. Each
/// point goes down the octree from the root to the first node where its cell of a 128³ grid is still free,
/// so the upper levels hold a thinned cloud and the lower ones the detail; within a node the points keep
/// their order.
pub fn encode_copc(points: &[LasPoint], encoding: &LasEncoding) -> Result<Vec<u8>, las::Error> {
    let mut builder = crate::las::builder(points, encoding)?;
    builder.point_format.is_compressed = true;
    let items = laz::LazItemRecordBuilder::default_for_point_format_id(6, 0)?;
    let laz_vlr = laz::LazVlrBuilder::new(items).with_variable_chunk_size().build();
    let mut laz_data = Vec::new();
    laz_vlr.write_to(&mut laz_data)?;
    let laszip = las::Vlr {
        user_id: LazVlr::USER_ID.into(),
        record_id: LazVlr::RECORD_ID,
        description: LazVlr::DESCRIPTION.into(),
        data: laz_data,
    };
    let info = las::Vlr { user_id: "copc".into(), record_id: 1, description: "COPC info".into(), data: vec![0; 160] };
    builder.vlrs.insert(0, info);
    builder.vlrs.insert(1, laszip);
    let header = builder.into_header()?;
    let transforms = *header.transforms();
    let format = *header.point_format();

    let (min, max) = points.iter().fold(([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]), |(lo, hi), p| {
        ([0, 1, 2].map(|a| lo[a].min(p.position[a])), [0, 1, 2].map(|a| hi[a].max(p.position[a])))
    });
    let (centre, halfsize) = if points.is_empty() {
        ([0.0; 3], 1.0)
    } else {
        let half = (0..3).map(|a| 0.5 * (max[a] - min[a])).fold(0.0f64, f64::max) + 0.01;
        ([0, 1, 2].map(|a| 0.5 * (min[a] + max[a])), half)
    };
    let nodes = octree(points, centre, halfsize);

    let mut out = Cursor::new(Vec::new());
    let mut raw = header.clone().into_raw()?;
    header.write_to(&mut out)?;
    let data_start = u64::from(raw.offset_to_point_data);
    out.set_position(data_start);
    let mut compressor = laz::LasZipCompressor::new(out, laz_vlr)?;
    compressor.reserve_offset_to_chunk_table()?;
    let mut entries = Vec::with_capacity(nodes.len());
    let mut record = Vec::new();
    for (key, members) in &nodes {
        let start = compressor.get_mut().stream_position()?;
        for &i in members {
            let p = points[i];
            let [x, y, z] = p.position;
            let gps_time = Some(crate::las::time_of(p.gps_time, encoding));
            record.clear();
            las::Point { x, y, z, gps_time, ..Default::default() }
                .into_raw(&transforms)?
                .write_to(&mut record, &format)?;
            compressor.compress_one(&record)?;
        }
        compressor.finish_current_chunk()?;
        let end = compressor.get_mut().stream_position()?;
        entries.push((*key, start, end - start, members.len()));
    }
    compressor.done()?;
    let mut out = compressor.into_inner();
    let evlr_start = out.seek(SeekFrom::End(0))?;
    let page_len = entries.len() as u64 * ENTRY_LEN;
    let mut page = Vec::with_capacity(usize::try_from(page_len).unwrap_or(0));
    for (key, offset, size, count) in &entries {
        for v in key {
            page.extend_from_slice(&v.to_le_bytes());
        }
        page.extend_from_slice(&offset.to_le_bytes());
        page.extend_from_slice(&i32::try_from(*size)?.to_le_bytes());
        page.extend_from_slice(&i32::try_from(*count)?.to_le_bytes());
    }
    let hierarchy =
        las::Vlr { user_id: "copc".into(), record_id: 1000, description: "EPT hierarchy".into(), data: page };
    hierarchy.into_raw(true)?.write_to(&mut out)?;

    // The header again, now that counts, bounds and the hierarchy's place are known.
    let n = points.len() as u64;
    raw.number_of_point_records = 0;
    raw.number_of_points_by_return = [0; 5];
    raw.large_file = Some(las::raw::header::LargeFile {
        number_of_point_records: n,
        number_of_points_by_return: {
            let mut r = [0; 15];
            r[0] = n;
            r
        },
    });
    raw.evlr = Some(las::raw::header::Evlr { start_of_first_evlr: evlr_start, number_of_evlrs: 1 });
    if !points.is_empty() {
        [raw.min_x, raw.min_y, raw.min_z] = min;
        [raw.max_x, raw.max_y, raw.max_z] = max;
    }
    out.seek(SeekFrom::Start(0))?;
    raw.write_to(&mut out)?;
    // COPC's info record payload sits right after its 54-byte VLR header at byte 375.
    let times = points.iter().map(|p| crate::las::time_of(p.gps_time, encoding));
    let (t_min, t_max) = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| (a.min(t), b.max(t)));
    out.seek(SeekFrom::Start(375 + 54))?;
    for v in [centre[0], centre[1], centre[2], halfsize, 2.0 * halfsize / GRID] {
        out.write_all(&v.to_le_bytes())?;
    }
    out.write_all(&(evlr_start + 60).to_le_bytes())?;
    out.write_all(&page_len.to_le_bytes())?;
    let (t_min, t_max) = if points.is_empty() { (0.0, 0.0) } else { (t_min, t_max) };
    out.write_all(&t_min.to_le_bytes())?;
    out.write_all(&t_max.to_le_bytes())?;
    Ok(out.into_inner())
}

/// The octree nodes of `points` (indices, in the points' order), in level order. A subtree holding fewer
/// than [`MIN_NODE_POINTS`] points is one node (decoding many nodes of a few points each costs a decoder
/// set-up apiece).
fn octree(points: &[LasPoint], centre: [f64; 3], halfsize: f64) -> Vec<([i32; 4], Vec<usize>)> {
    let mut home: Vec<[i32; 4]> = Vec::with_capacity(points.len());
    let mut taken: HashSet<([i32; 4], [i32; 3])> = HashSet::new();
    let root = centre.map(|c| c - halfsize);
    for p in points {
        let mut key = [0, 0, 0, 0];
        loop {
            let size = 2.0 * halfsize / f64::from(1 << key[0]);
            let local = [0, 1, 2].map(|a| (p.position[a] - root[a]) / size - f64::from(key[a + 1]));
            let cell = local.map(|u| ((u * GRID).floor() as i32).clamp(0, GRID as i32 - 1));
            if key[0] == WRITE_LEVELS || taken.insert((key, cell)) {
                home.push(key);
                break;
            }
            let half = local.map(|u| i32::from(u >= 0.5));
            key = [key[0] + 1, 2 * key[1] + half[0], 2 * key[2] + half[1], 2 * key[3] + half[2]];
        }
    }
    // Points in each subtree, then each point to the highest node on its way whose subtree is small.
    let ancestor = |k: [i32; 4], l: i32| {
        let d = k[0] - l;
        [l, k[1] >> d, k[2] >> d, k[3] >> d]
    };
    let mut subtree: HashMap<[i32; 4], usize> = HashMap::new();
    for k in &home {
        for l in 0..=k[0] {
            *subtree.entry(ancestor(*k, l)).or_default() += 1;
        }
    }
    let mut nodes: HashMap<[i32; 4], Vec<usize>> = HashMap::new();
    for (i, k) in home.iter().enumerate() {
        let small = |l: i32| subtree.get(&ancestor(*k, l)).is_some_and(|&n| n < MIN_NODE_POINTS);
        let level = (0..=k[0]).find(|&l| small(l)).unwrap_or(k[0]);
        nodes.entry(ancestor(*k, level)).or_default().push(i);
    }
    let mut nodes: Vec<_> = nodes.into_iter().collect();
    nodes.sort_by_key(|(k, _)| *k);
    nodes
}
