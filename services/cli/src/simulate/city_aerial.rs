//! The aerial products of the `city` preset, made leg by leg (`plumbline_synth::city_aerial`): the frames of the
//! city's endless block that see ground within [`FRAME_REACH_M`] of the leg's drive and were not made for an
//! earlier leg, rendered from a city window holding everything they show; their AT-reported and true
//! orientations appended to `aerial/exterior_orientation.csv` and `truth/aerial_orientation.csv`; orthophoto (COG) and
//! terrain GeoTIFF tiles (`aerial/orthophoto/{col}_{row}.tif`, `aerial/terrain/{col}_{row}.tif`, 1000 px of
//! the aerial GSD square) near the drive; at the end `aerial/orthophoto.vrt` and `aerial/terrain.vrt`, GDAL
//! VRT mosaics of all tiles, which the manifest names as the orthophoto and terrain model. Camera, GSD,
//! overlaps, AT errors, illumination, blur and noise are those of `tiny` and `district` (module `aerial`).

use std::collections::{BTreeSet, HashSet};

use anyhow::Context as _;
use plumbline_geo::camera::{MetricInterior, Pinhole};
use plumbline_runtime::gdal_write::{Mosaic, MosaicTile, MosaicType, cloud_optimized_geotiff, geotiff, vrt};
use plumbline_synth::aerial::{self, exterior_orientation_csv};
use plumbline_synth::city_aerial::{CityBlock, FrameKey, TileKey, TileLattice, key_seed, track_points, window_seeing};
use plumbline_synth::map::footprint;
use plumbline_synth::motion::Drive;
use plumbline_synth::ortho::{OrthoGrid, render_orthophoto};
use plumbline_synth::render::{AerialOptics, AtErrors, BlockSpec, Radiometry, Scene, encode_jpeg, render_aerial_with};
use plumbline_synth::world::WorldConfig;
use plumbline_synth::world::city::City;

use super::Sink;
use super::aerial::{FRAME_PX, TERRAIN_GSD_M, TERRAIN_NODATA, block_spec, ortho_raster, terrain_raster};

/// Frames are made that see ground this close to the drive, metres: the registration's ortho patch (14 m
/// half side, `MmConfig::default`) plus DG errors of metres and the search around them; the worker picks the
/// frames a panorama's recording location projects into (Jende et al. 2017 §3.7), all of them made.
const FRAME_REACH_M: f64 = 30.0;
/// Orthophoto and terrain tiles are made this close to the drive, metres.
const TILE_REACH_M: f64 = 30.0;
/// Pixels along a side of an orthophoto tile (at 12 cm GSD: 120 m).
const TILE_PX: u32 = 1000;
/// Spacing of the points along a leg's drive the reach is measured from, metres.
const ROUTE_STEP_M: f64 = 5.0;

/// The aerial block, orthophoto and terrain of a city campaign, leg by leg; remembers only which frames and
/// tiles exist (a few bytes each).
pub(crate) struct CityAerial {
    city: City,
    block: CityBlock,
    interior: MetricInterior,
    spec: BlockSpec,
    tiles: TileLattice,
    terrain_px: u32,
    epsg: u32,
    seed: u64,
    radiometry: Radiometry,
    frames_done: HashSet<FrameKey>,
    tiles_done: BTreeSet<TileKey>,
}

impl CityAerial {
    /// The block of the city of `config` flown at `gsd` (`--aerial-gsd`), its frames through `radiometry`.
    pub(crate) fn new(config: &WorldConfig, gsd: f64, radiometry: Radiometry) -> anyhow::Result<Self> {
        let spec = block_spec(gsd)?;
        let interior = aerial::small_format_distorted(FRAME_PX.0, FRAME_PX.1);
        let cam = Pinhole::from_metric(&interior).context("aerial camera")?;
        let tile_m = f64::from(TILE_PX) * spec.gsd;
        Ok(Self {
            city: City::new(config),
            block: CityBlock::new(config, cam, &spec),
            interior,
            spec,
            tiles: TileLattice { origin: [config.origin_east, config.origin_north], size: tile_m },
            terrain_px: (tile_m / TERRAIN_GSD_M).round().max(1.0) as u32,
            epsg: config.epsg,
            seed: config.seed,
            radiometry,
            frames_done: HashSet::new(),
            tiles_done: BTreeSet::new(),
        })
    }

    /// Make and hand to `sink` the frames and tiles near a leg's `drive` not made yet; returns the ground
    /// footprints of the frames made (for the map).
    pub(crate) fn leg(&mut self, drive: &Drive, sink: &Sink) -> anyhow::Result<Vec<[[f64; 2]; 4]>> {
        let positions = drive.trajectory.records().iter().map(|r| [r.position.x(), r.position.y()]);
        let points = track_points(positions, ROUTE_STEP_M);
        let frames: Vec<FrameKey> = self
            .block
            .frames_near(&points, FRAME_REACH_M)
            .into_iter()
            .filter(|k| !self.frames_done.contains(k))
            .collect();
        let tiles: Vec<TileKey> =
            self.tiles.tiles_near(&points, TILE_REACH_M).into_iter().filter(|k| !self.tiles_done.contains(k)).collect();
        let boxes = frames.iter().map(|&k| self.block.footprint(k)).chain(tiles.iter().map(|&k| self.tiles.bounds(k)));
        let Some(window) = window_seeing(&self.city, boxes) else { return Ok(Vec::new()) };
        let scene = Scene::aerial(&window.world);
        let footprints = self.write_frames(&scene, &frames, sink)?;
        for &key in &tiles {
            self.write_tile(&scene, key, sink)?;
        }
        self.frames_done.extend(frames.iter().copied());
        self.tiles_done.extend(tiles);
        Ok(footprints)
    }

    /// Render and write the frames of `keys`; returns their ground footprints.
    fn write_frames(&self, scene: &Scene, keys: &[FrameKey], sink: &Sink) -> anyhow::Result<Vec<[[f64; 2]; 4]>> {
        if keys.is_empty() {
            return Ok(Vec::new());
        }
        let errors = AtErrors::typical();
        let frames: Vec<aerial::Frame> = keys.iter().map(|&k| self.block.frame(k, &errors, self.seed)).collect();
        for (key, frame) in keys.iter().zip(&frames) {
            let optics = AerialOptics::typical(key_seed(self.seed, key.strip, key.step, 0x0971_C5E5));
            let image = render_aerial_with(scene, self.block.camera(), &frame.truth, &optics, &self.radiometry);
            let jpeg = encode_jpeg(&image, self.radiometry.jpeg_quality)?;
            sink.put(format!("aerial/frames/{}.jpg", frame.id), jpeg)?;
        }
        let first = self.frames_done.is_empty();
        let csv = |bytes: Vec<u8>| if first { bytes } else { without_header(bytes) };
        sink.append("aerial/exterior_orientation.csv", csv(exterior_orientation_csv(&frames, true)))?;
        sink.append("truth/aerial_orientation.csv", csv(exterior_orientation_csv(&frames, false)))?;
        let (width, height) = (self.interior.width, self.interior.height);
        Ok(frames.iter().map(|f| footprint(&f.truth, width, height, self.spec.gsd)).collect())
    }

    fn write_tile(&self, scene: &Scene, key: TileKey, sink: &Sink) -> anyhow::Result<()> {
        let grid = self.tiles.grid(key, TILE_PX);
        let ortho = ortho_raster(&render_orthophoto(scene, &grid), &grid, self.epsg);
        let name = format!("{}_{}.tif", key.col, key.row);
        sink.put(format!("aerial/orthophoto/{name}"), cloud_optimized_geotiff(&ortho).context("orthophoto tile COG")?)?;
        let terrain = terrain_raster(scene.world, &self.tiles.grid(key, self.terrain_px), self.epsg);
        sink.put(format!("aerial/terrain/{name}"), geotiff(&terrain).context("terrain tile GeoTIFF")?)
    }

    /// Write the orthophoto and terrain mosaics; returns the manifest's `[aerial]`.
    pub(crate) fn finish(&self, sink: &Sink) -> anyhow::Result<String> {
        let ortho = self.mosaic("orthophoto", TILE_PX, MosaicType::U8, 3, None)?;
        sink.put("aerial/orthophoto.vrt", vrt(&ortho).context("orthophoto mosaic")?)?;
        let terrain = self.mosaic("terrain", self.terrain_px, MosaicType::F32, 1, Some(TERRAIN_NODATA))?;
        sink.put("aerial/terrain.vrt", vrt(&terrain).context("terrain mosaic")?)?;
        Ok(super::aerial::section(&self.spec, &self.interior, "aerial/orthophoto.vrt", "aerial/terrain.vrt"))
    }

    /// The mosaic of all tiles written under `aerial/{dir}/`, `pixels` square each.
    fn mosaic(
        &self,
        dir: &str,
        pixels: u32,
        data_type: MosaicType,
        bands: usize,
        nodata: Option<f64>,
    ) -> anyhow::Result<Mosaic> {
        let keys = &self.tiles_done;
        let (Some(c0), Some(c1)) = (keys.iter().map(|k| k.col).min(), keys.iter().map(|k| k.col).max()) else {
            anyhow::bail!("the city campaign made no orthophoto tile");
        };
        let (r0, r1) = (keys.iter().map(|k| k.row).min().unwrap_or(0), keys.iter().map(|k| k.row).max().unwrap_or(0));
        let px = pixels as usize;
        let tiles = keys
            .iter()
            .map(|k| MosaicTile {
                path: format!("{dir}/{}_{}.tif", k.col, k.row),
                col: (k.col - c0) as usize * px,
                row: (r1 - k.row) as usize * px,
            })
            .collect();
        // The mosaic's top-left corner is that of tile (c0, r1): its grid's geotransform.
        let corner: OrthoGrid = self.tiles.grid(TileKey { col: c0, row: r1 }, pixels);
        Ok(Mosaic {
            width: (c1 - c0 + 1) as usize * px,
            height: (r1 - r0 + 1) as usize * px,
            geotransform: corner.geotransform(),
            epsg: self.epsg,
            bands,
            data_type,
            tile_size: (px, px),
            nodata,
            tiles,
        })
    }
}

/// The bytes after the first line (the CSV header, written by the first leg only).
fn without_header(bytes: Vec<u8>) -> Vec<u8> {
    let cut = bytes.iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| i + 1);
    bytes[cut..].to_vec()
}
