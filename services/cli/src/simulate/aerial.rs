//! The aerial products of a simulated campaign: frame images of a block at 12 cm GSD (`--aerial-gsd`) rendered with the TRUE
//! orientations of the aerial epoch, the AT-reported exterior orientations (`aerial/exterior_orientation.csv`;
//! the true ones in `truth/aerial_orientation.csv`), a true orthophoto and a flat terrain model as GeoTIFFs
//! in the campaign CRS. The camera, block spec, rasters and `[aerial]` section are shared with the `city`
//! preset's tiled version (module `city_aerial`).

use anyhow::Context as _;
use plumbline_geo::camera::MetricInterior;
use plumbline_runtime::gdal_write::{Raster, RasterData, geotiff};
use plumbline_synth::aerial::{self, exterior_orientation_csv};
use plumbline_synth::map::footprint;
use plumbline_synth::ortho::{OrthoGrid, render_orthophoto};
use plumbline_synth::render::{AerialOptics, AtErrors, BlockSpec, Scene, encode_jpeg, render_aerial};
use plumbline_synth::world::World;

use super::Sink;
use crate::exit::invalid;

/// JPEG quality of the frames.
pub(crate) const JPEG_QUALITY: u8 = 90;
/// Frame size, pixels (small format: keeps `tiny` quick; the GSD is what matters).
pub(crate) const FRAME_PX: (u32, u32) = (1000, 750);
/// Pixel size of the terrain model, metres.
pub(crate) const TERRAIN_GSD_M: f64 = 1.0;
/// No-data value of the terrain model.
pub(crate) const TERRAIN_NODATA: f64 = -9999.0;

/// Ground corners of each frame (for the campaign map).
pub(crate) type Footprints = Vec<[[f64; 2]; 4]>;

/// Write frames, orientations, orthophoto and terrain; returns the manifest's `[aerial]` and the footprints.
pub(crate) fn write(world: &World, gsd: f64, seed: u64, sink: &Sink) -> anyhow::Result<(String, Footprints)> {
    let spec = block_spec(gsd)?;
    let interior = aerial::small_format_distorted(FRAME_PX.0, FRAME_PX.1);
    let (cam, frames) = aerial::block(world, &interior, &spec, &AtErrors::typical(), seed).context("aerial camera")?;
    let scene = Scene::aerial(world);
    for (i, frame) in frames.iter().enumerate() {
        let optics = AerialOptics::typical(seed.wrapping_mul(7_919).wrapping_add(i as u64));
        let image = render_aerial(&scene, &cam, &frame.truth, &optics);
        sink.put(format!("aerial/frames/{}.jpg", frame.id), encode_jpeg(&image, JPEG_QUALITY)?)?;
    }
    sink.put("aerial/exterior_orientation.csv", exterior_orientation_csv(&frames, true))?;
    sink.put("truth/aerial_orientation.csv", exterior_orientation_csv(&frames, false))?;
    let epsg = world.config.epsg;
    let grid = OrthoGrid::covering(&scene, spec.gsd);
    let ortho = ortho_raster(&render_orthophoto(&scene, &grid), &grid, epsg);
    sink.put("aerial/orthophoto.tif", geotiff(&ortho).context("orthophoto GeoTIFF")?)?;
    let terrain = flat_terrain(&OrthoGrid::covering(&scene, TERRAIN_GSD_M), world.config.ground_height, epsg);
    sink.put("aerial/terrain.tif", geotiff(&terrain).context("terrain GeoTIFF")?)?;
    let footprints = frames.iter().map(|f| footprint(&f.truth, interior.width, interior.height, gsd)).collect();
    let section = section(&spec, &interior, "aerial/orthophoto.tif", "aerial/terrain.tif");
    Ok((section, footprints))
}

/// The block flown at `gsd` (`--aerial-gsd`, checked), with the standard overlaps.
pub(crate) fn block_spec(gsd: f64) -> anyhow::Result<BlockSpec> {
    if !(gsd.is_finite() && (0.02..=1.0).contains(&gsd)) {
        return Err(invalid(format!("--aerial-gsd {gsd}: expected 0.02–1 m")));
    }
    Ok(BlockSpec { gsd, ..BlockSpec::standard() })
}

/// The manifest's `[aerial]`: frames under `aerial/frames/` indexed by `aerial/exterior_orientation.csv`, and
/// the orthophoto and terrain files named.
pub(crate) fn section(spec: &BlockSpec, interior: &MetricInterior, orthophoto: &str, terrain: &str) -> String {
    format!(
        "[aerial.frames]\nindex = \"aerial/exterior_orientation.csv\"\nimages = \"aerial/frames/\"\ngsd_m = {:?}\n\n\
         [aerial.frames.interior]\nfocal_length_mm = {:?}\nprincipal_point_mm = [{:?}, {:?}]\npixel_size_mm = {:?}\n\
         k1 = {:?}\nk2 = {:?}\nwidth_px = {}\nheight_px = {}\n\n\
         [aerial.orthophoto]\nimage = \"{orthophoto}\"\nterrain = \"{terrain}\"\n",
        spec.gsd,
        interior.focal_mm,
        interior.xp_mm,
        interior.yp_mm,
        interior.pixel_mm,
        interior.k1,
        interior.k2,
        interior.width,
        interior.height
    )
}

/// An RGB orthophoto of `grid` as a raster in CRS `epsg`.
pub(crate) fn ortho_raster(image: &image::RgbImage, grid: &OrthoGrid, epsg: u32) -> Raster {
    let bands = (0..3).map(|k| image.pixels().map(|p| p[k]).collect()).collect();
    let (width, height) = (grid.width as usize, grid.height as usize);
    Raster { width, height, geotransform: grid.geotransform(), epsg, data: RasterData::U8(bands), nodata: None }
}

/// A terrain model of `grid` at the flat ground height (no-data −9999).
pub(crate) fn flat_terrain(grid: &OrthoGrid, ground_height: f64, epsg: u32) -> Raster {
    let heights = vec![ground_height as f32; grid.width as usize * grid.height as usize];
    Raster {
        width: grid.width as usize,
        height: grid.height as usize,
        geotransform: grid.geotransform(),
        epsg,
        data: RasterData::F32(vec![heights]),
        nodata: Some(TERRAIN_NODATA),
    }
}
