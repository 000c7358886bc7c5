//! Points bucketed by tile in temporary files, for a detection that must not hold a whole cloud (`plumbline
//! poles detect`): a pass over a cloud hands each point it keeps to [`TileSpill::push`], which buffers it for
//! every tile whose grown area holds it ([`Tiling`]) and appends the buffers to one file per tile when they
//! fill; a tile's points are then read back alone, a tile holding too many split into quarters first
//! ([`TileSpill::visit_tiles`]). What a detection holds at once is one tile's points and the buffers,
//! whatever the cloud's size. The files live in a temporary directory removed when the spill is dropped.

use std::collections::HashMap;
use std::fs::OpenOptions;
use std::io::{self, BufReader, Read as _, Write as _};
use std::path::{Path, PathBuf};

use plumbline_poles::Tiling;

/// Points buffered (all tiles together) before the buffers go to their files.
const BUFFERED_POINTS: usize = 1 << 21;

/// Points read from a tile file at a time when it is split.
const CHUNK_POINTS: usize = 1 << 16;

/// Bytes of one coordinate in a tile file (an f64, little-endian).
const VALUE_BYTES: usize = 8;

/// Points of `N` coordinates (x, y first) bucketed by tile on disk.
#[derive(Debug)]
pub struct TileSpill<const N: usize> {
    dir: tempfile::TempDir,
    tiling: Tiling,
    buffers: HashMap<(i64, i64), Vec<[f64; N]>>,
    /// Points written or buffered per tile.
    counts: HashMap<(i64, i64), u64>,
    buffered: usize,
    /// Points pushed (each once, however many tiles hold it).
    pushed: u64,
    /// Bytes written to the tile files.
    written: u64,
    /// The first write error, reported by [`TileSpill::check`].
    error: Option<io::Error>,
}

impl<const N: usize> TileSpill<N> {
    /// An empty spill in a new temporary directory under `parent` (the system's temporary directory
    /// without one).
    pub fn new(parent: Option<&Path>, tiling: Tiling) -> io::Result<Self> {
        let dir = match parent {
            Some(p) => tempfile::Builder::new().prefix("plumbline-spill-").tempdir_in(p)?,
            None => tempfile::Builder::new().prefix("plumbline-spill-").tempdir()?,
        };
        Ok(Self {
            dir,
            tiling,
            buffers: HashMap::new(),
            counts: HashMap::new(),
            buffered: 0,
            pushed: 0,
            written: 0,
            error: None,
        })
    }

    /// Keep `p` for every tile whose grown area holds it. A write error is kept for
    /// [`TileSpill::check`]; the points after it are dropped.
    pub fn push(&mut self, p: [f64; N]) {
        self.push_to(p, |_| true);
    }

    /// [`TileSpill::push`] to the tiles `keep` accepts only.
    fn push_to(&mut self, p: [f64; N], keep: impl Fn((i64, i64)) -> bool) {
        if self.error.is_some() {
            return;
        }
        self.pushed += 1;
        for tile in self.tiling.tiles_holding([p[0], p[1]]).filter(|t| keep(*t)) {
            self.buffers.entry(tile).or_default().push(p);
            *self.counts.entry(tile).or_default() += 1;
            self.buffered += 1;
        }
        if self.buffered >= BUFFERED_POINTS
            && let Err(e) = self.flush()
        {
            self.error = Some(e);
        }
    }

    /// The first write error, if any.
    pub fn check(&mut self) -> io::Result<()> {
        match self.error.take() {
            Some(e) => {
                Err(io::Error::new(e.kind(), format!("writing the tile files in {}: {e}", self.dir.path().display())))
            }
            None => Ok(()),
        }
    }

    fn path(&self, (i, j): (i64, i64)) -> PathBuf {
        self.dir.path().join(format!("{i}_{j}.bin"))
    }

    /// Append every buffer to its tile's file.
    fn flush(&mut self) -> io::Result<()> {
        let mut bytes: Vec<u8> = Vec::new();
        let tiles: Vec<(i64, i64)> = self.buffers.keys().copied().collect();
        for tile in tiles {
            let points = self.buffers.remove(&tile).unwrap_or_default();
            bytes.clear();
            bytes.extend(points.iter().flatten().flat_map(|v| v.to_le_bytes()));
            let mut file = OpenOptions::new().create(true).append(true).open(self.path(tile))?;
            file.write_all(&bytes)?;
            self.written += bytes.len() as u64;
        }
        self.buffered = 0;
        Ok(())
    }

    /// The tiles holding points, sorted.
    pub fn tiles(&self) -> Vec<(i64, i64)> {
        let mut tiles: Vec<(i64, i64)> = self.counts.keys().copied().collect();
        tiles.sort_unstable();
        tiles
    }

    /// Points pushed, each counted once.
    pub fn pushed(&self) -> u64 {
        self.pushed
    }

    /// Bytes written to the tile files so far.
    pub fn written(&self) -> u64 {
        self.written
    }

    /// Drop every point and remove the tile files (the counts pushed and written stay).
    pub fn clear(&mut self) -> io::Result<()> {
        for tile in self.tiles() {
            match std::fs::remove_file(self.path(tile)) {
                Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(e),
                _ => {}
            }
        }
        self.buffers = HashMap::new();
        self.counts = HashMap::new();
        self.buffered = 0;
        Ok(())
    }

    /// The points of `tile` (with its margin), in the order they were pushed.
    pub fn read(&mut self, tile: (i64, i64)) -> io::Result<Vec<[f64; N]>> {
        let count = self.counts.get(&tile).copied().unwrap_or(0);
        let mut points = Vec::with_capacity(usize::try_from(count).map_err(io::Error::other)?);
        self.read_chunks(tile, |chunk| {
            points.extend_from_slice(chunk);
            Ok(())
        })?;
        Ok(points)
    }

    /// The points of `tile` that `keep` accepts, in the order they were pushed.
    pub fn read_where(&mut self, tile: (i64, i64), keep: impl Fn(&[f64; N]) -> bool) -> io::Result<Vec<[f64; N]>> {
        let mut points = Vec::new();
        self.read_chunks(tile, |chunk| {
            points.extend(chunk.iter().filter(|p| keep(p)));
            Ok(())
        })?;
        Ok(points)
    }

    /// The points of `tile` in pushed order, handed to `visit` some thousands at a time.
    fn read_chunks(
        &mut self,
        tile: (i64, i64),
        mut visit: impl FnMut(&[[f64; N]]) -> io::Result<()>,
    ) -> io::Result<()> {
        if self.buffered > 0 {
            self.flush()?;
        }
        let count = self.counts.get(&tile).copied().unwrap_or(0);
        if count == 0 {
            return Ok(());
        }
        let path = self.path(tile);
        let file = std::fs::File::open(&path)?;
        let expected = count * (N * VALUE_BYTES) as u64;
        let len = file.metadata()?.len();
        if len != expected {
            return Err(io::Error::other(format!(
                "{} holds {len} bytes where {count} points of {N} values need {expected}",
                path.display()
            )));
        }
        let mut reader = BufReader::with_capacity(1 << 20, file);
        let mut record = [0u8; 64];
        let record = &mut record[..N * VALUE_BYTES];
        let mut chunk: Vec<[f64; N]> = Vec::with_capacity(CHUNK_POINTS);
        for k in 0..count {
            reader.read_exact(record)?;
            let mut p = [0.0; N];
            for (i, v) in p.iter_mut().enumerate() {
                let mut b = [0u8; VALUE_BYTES];
                b.copy_from_slice(&record[i * VALUE_BYTES..(i + 1) * VALUE_BYTES]);
                *v = f64::from_le_bytes(b);
            }
            chunk.push(p);
            if chunk.len() == CHUNK_POINTS || k + 1 == count {
                visit(&chunk)?;
                chunk.clear();
            }
        }
        Ok(())
    }

    /// Hand every tile `wanted` accepts to `visit` with the tiling it belongs to, one tile at a time, as a
    /// [`TileReader`] of its points. A tile holding more than `budget` points is first split into four
    /// tiles of half its side (its file read back into a spill of its own), again while one is over and half
    /// its side still holds the margin; a tile handed over may therefore be a quarter, sixteenth… of a tile of
    /// this spill (`wanted` is asked again for each).
    pub fn visit_tiles(
        &mut self,
        budget: u64,
        wanted: &dyn Fn(&Tiling, (i64, i64)) -> bool,
        visit: &mut TileVisitor<'_, N>,
    ) -> io::Result<()> {
        let tiling = self.tiling;
        for tile in self.tiles() {
            if !wanted(&tiling, tile) {
                continue;
            }
            let count = self.counts.get(&tile).copied().unwrap_or(0);
            if count <= budget || 0.5 * tiling.size_m < tiling.margin_m {
                visit(&tiling, tile, TileReader { spill: self, tile })?;
                continue;
            }
            let mut quarters = self.split(tile)?;
            quarters.visit_tiles(budget, wanted, visit)?;
        }
        Ok(())
    }

    /// The points of `tile` in a new spill of tiles half its side (in a directory inside this one's),
    /// holding the four that make it up, each with its margin.
    fn split(&mut self, tile: (i64, i64)) -> io::Result<TileSpill<N>> {
        let half = Tiling { size_m: 0.5 * self.tiling.size_m, margin_m: self.tiling.margin_m };
        let mut quarters = TileSpill::<N>::new(Some(self.dir.path()), half)?;
        let within = |(i, j): (i64, i64)| i.div_euclid(2) == tile.0 && j.div_euclid(2) == tile.1;
        self.read_chunks(tile, |chunk| {
            for p in chunk {
                quarters.push_to(*p, within);
            }
            quarters.check()
        })?;
        quarters.check()?;
        Ok(quarters)
    }
}

/// What [`TileSpill::visit_tiles`] hands every tile to: its tiling, its key and a reader of its points.
pub type TileVisitor<'v, const N: usize> = dyn FnMut(&Tiling, (i64, i64), TileReader<'_, N>) -> io::Result<()> + 'v;

/// One tile of a [`TileSpill`] handed to [`TileSpill::visit_tiles`]'s visitor, to read as it needs.
#[derive(Debug)]
pub struct TileReader<'a, const N: usize> {
    spill: &'a mut TileSpill<N>,
    tile: (i64, i64),
}

impl<const N: usize> TileReader<'_, N> {
    /// All the tile's points (with its margin), in the order they were pushed.
    pub fn read(self) -> io::Result<Vec<[f64; N]>> {
        self.spill.read(self.tile)
    }

    /// The tile's points that `keep` accepts, in the order they were pushed.
    pub fn read_where(self, keep: impl Fn(&[f64; N]) -> bool) -> io::Result<Vec<[f64; N]>> {
        self.spill.read_where(self.tile, keep)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plumbline_poles::StemConfig;

    #[test]
    fn a_tile_reads_back_its_points_and_its_margin_in_order() {
        let tiling = Tiling::new(64.0, &StemConfig::default());
        let mut spill = TileSpill::<3>::new(None, tiling).unwrap();
        // 2.5 million points over 4 tiles, more than one buffer's worth.
        let points: Vec<[f64; 3]> =
            (0..2_500_000u32).map(|i| [f64::from(i % 1280) * 0.1, f64::from(i / 1280) * 0.04, f64::from(i)]).collect();
        for p in &points {
            spill.push(*p);
        }
        spill.check().unwrap();
        assert_eq!(spill.pushed(), 2_500_000);
        for tile in spill.tiles() {
            let got = spill.read(tile).unwrap();
            let want: Vec<[f64; 3]> =
                points.iter().copied().filter(|p| tiling.tiles_holding([p[0], p[1]]).any(|t| t == tile)).collect();
            assert!(got == want, "tile {tile:?}: {} points read, {} expected", got.len(), want.len());
        }
        assert!(spill.tiles().len() >= 4);
        assert!(spill.written() > 2_500_000 * 24, "the margins are written to the neighbours too");
        // Split down to tiles of at most 100,000 points: each one handed over holds exactly the points of its
        // own tile and margin, in order; only tiles too small to halve hold more.
        let mut sizes = Vec::new();
        type Tiles = HashMap<(i64, i64), Vec<[f64; 3]>>;
        let mut by_level: HashMap<u64, Tiles> = HashMap::new();
        for size in [64.0, 32.0, 16.0, 8.0] {
            let level = by_level.entry(size as u64).or_default();
            let tiling = Tiling { size_m: size, ..tiling };
            for p in &points {
                tiling.tiles_holding([p[0], p[1]]).for_each(|t| level.entry(t).or_default().push(*p));
            }
        }
        spill
            .visit_tiles(100_000, &|_, _| true, &mut |tiling, tile, reader| {
                let got = reader.read()?;
                assert!(got.len() <= 100_000 || tiling.size_m < 2.0 * tiling.margin_m, "{tiling:?}: {}", got.len());
                let want = &by_level[&(tiling.size_m as u64)][&tile];
                assert!(
                    got == *want,
                    "{} m tile {tile:?}: {} points, {} expected",
                    tiling.size_m,
                    got.len(),
                    want.len()
                );
                sizes.push(tiling.size_m);
                Ok(())
            })
            .unwrap();
        assert!(sizes.contains(&16.0) && sizes.contains(&64.0), "{sizes:?}");
    }
}
