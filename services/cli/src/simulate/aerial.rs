//! The aerial products of a simulated campaign: frame images of a block at 12 cm GSD (`--aerial-gsd`) rendered with the TRUE
//! orientations of the aerial epoch, the AT-reported exterior orientations (`aerial/exterior_orientation.csv`;
//! the true ones in `truth/aerial_orientation.csv`), a true orthophoto (a cloud-optimised GeoTIFF with overviews) and a flat terrain model as GeoTIFFs
//! in the campaign CRS. The camera, block spec, rasters and `[aerial]` section are shared with the `city`
//! preset's tiled version (module `city_aerial`).

use anyhow::Context as _;
use plumbline_geo::camera::MetricInterior;
use plumbline_runtime::gdal_write::{Raster, RasterData, cloud_optimized_geotiff, geotiff, image_tiff};
use plumbline_synth::aerial;
use plumbline_synth::map::footprint;
use plumbline_synth::ortho::{OrthoGrid, render_orthophoto, terrain_model};
use plumbline_synth::render::{AerialOptics, AtErrors, BlockSpec, Radiometry, Scene, encode_jpeg, render_aerial_with};
use plumbline_synth::world::World;

use super::Sink;
use crate::exit::invalid;

/// Frame size, pixels (small format: keeps `tiny` quick; the GSD is what matters).
pub(crate) const FRAME_PX: (u32, u32) = (1000, 750);
/// Pixel size of the terrain model, metres.
pub(crate) const TERRAIN_GSD_M: f64 = 1.0;
/// No-data value of the terrain model.
pub(crate) const TERRAIN_NODATA: f64 = -9999.0;

/// Ground corners of each frame (for the campaign map).
pub(crate) type Footprints = Vec<[[f64; 2]; 4]>;

/// How the frames of `tiny` and `district` are made: GSD, size and file format.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FrameOptions {
    /// Ground sample distance, metres.
    pub gsd: f64,
    /// Width and height, pixels.
    pub size: (u32, u32),
    /// File format.
    pub format: FrameFormat,
    /// What the camera adds to the images (and the JPEG quality).
    pub radiometry: Radiometry,
}

impl FrameOptions {
    /// The options `simulate` was given.
    pub(crate) fn of(args: &super::Args) -> Self {
        Self {
            gsd: args.aerial_gsd,
            size: args.aerial_frame_px.unwrap_or(FRAME_PX),
            format: args.aerial_format,
            radiometry: args.realism.realism().aerial,
        }
    }

    /// The camera: the default small-format camera with its radial distortion, or at any other size a
    /// distortion-free virtual image with the same pixel pitch and focal length.
    fn interior(&self) -> MetricInterior {
        if self.size == FRAME_PX {
            aerial::small_format_distorted(FRAME_PX.0, FRAME_PX.1)
        } else {
            aerial::small_format(self.size.0, self.size.1)
        }
    }
}

/// File formats of the simulated frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FrameFormat {
    /// 8-bit RGB JPEG (quality 90; `--realism harsh`: 75).
    Jpeg,
    /// 16-bit 4-band (R, G, B, NIR) tiled GeoTIFF, deflate-compressed, 12-bit data, as large-format cameras
    /// deliver (no georeferencing: the frame is placed by its orientation).
    Tiff16,
}

impl FrameFormat {
    /// The frames' file extension.
    fn extension(self) -> &'static str {
        match self {
            Self::Jpeg => "jpg",
            Self::Tiff16 => "tif",
        }
    }
}

/// Write frames, orientations, orthophoto and terrain; returns the manifest's `[aerial]` and the footprints.
pub(crate) fn write(
    world: &World,
    options: &FrameOptions,
    seed: u64,
    sink: &Sink,
) -> anyhow::Result<(String, Footprints)> {
    let gsd = options.gsd;
    let spec = block_spec(gsd)?;
    let interior = options.interior();
    let (cam, frames) = aerial::block(world, &interior, &spec, &AtErrors::typical(), seed).context("aerial camera")?;
    let scene = Scene::aerial(world);
    let extension = options.format.extension();
    for (i, frame) in frames.iter().enumerate() {
        let optics = AerialOptics::typical(seed.wrapping_mul(7_919).wrapping_add(i as u64));
        let image = render_aerial_with(&scene, &cam, &frame.truth, &optics, &options.radiometry);
        let bytes = match options.format {
            FrameFormat::Jpeg => encode_jpeg(&image, options.radiometry.jpeg_quality)?,
            FrameFormat::Tiff16 => frame_tiff16(&image).with_context(|| format!("frame {} as GeoTIFF", frame.id))?,
        };
        drop(image);
        sink.put(format!("aerial/frames/{}.{extension}", frame.id), bytes)?;
    }
    sink.put("aerial/exterior_orientation.csv", aerial::exterior_orientation_csv_as(&frames, true, extension))?;
    sink.put("truth/aerial_orientation.csv", aerial::exterior_orientation_csv_as(&frames, false, extension))?;
    let epsg = world.config.epsg;
    let grid = OrthoGrid::covering(&scene, spec.gsd);
    let ortho = ortho_raster(&render_orthophoto(&scene, &grid), &grid, epsg);
    sink.put("aerial/orthophoto.tif", cloud_optimized_geotiff(&ortho).context("orthophoto COG")?)?;
    let terrain = terrain_raster(world, &OrthoGrid::covering(&scene, TERRAIN_GSD_M), epsg);
    sink.put("aerial/terrain.tif", geotiff(&terrain).context("terrain GeoTIFF")?)?;
    let footprints = frames.iter().map(|f| footprint(&f.truth, interior.width, interior.height, gsd)).collect();
    let section = section(&spec, &interior, "aerial/orthophoto.tif", "aerial/terrain.tif");
    Ok((section, footprints))
}

/// A rendered frame as a 16-bit 4-band tiled GeoTIFF: 8-bit values scaled to 12 bits above a dark level of
/// 256 (R, G, B), and a near-infrared band from red and green (vegetation is not modelled; the band only has
/// to be there and be ignored).
fn frame_tiff16(image: &image::RgbImage) -> anyhow::Result<Vec<u8>> {
    let deep = |v: u8| 256 + 16 * u16::from(v);
    let mut bands: Vec<Vec<u16>> = (0..3).map(|k| image.pixels().map(|p| deep(p[k])).collect()).collect();
    bands.push(image.pixels().map(|p| deep(((u16::from(p[0]) + u16::from(p[1])) / 2) as u8)).collect());
    let (width, height) = (image.width() as usize, image.height() as usize);
    Ok(image_tiff(width, height, &RasterData::U16(bands))?)
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

/// The terrain model of `world` over `grid` (`plumbline_synth::ortho::terrain_model`; no-data −9999).
pub(crate) fn terrain_raster(world: &World, grid: &OrthoGrid, epsg: u32) -> Raster {
    let heights = terrain_model(world, grid);
    Raster {
        width: grid.width as usize,
        height: grid.height as usize,
        geotransform: grid.geotransform(),
        epsg,
        data: RasterData::F32(vec![heights]),
        nodata: Some(TERRAIN_NODATA),
    }
}
