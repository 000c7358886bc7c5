//! Windows of the orthophoto and the terrain model through GDAL ([`RasterSource`]): local files are opened in
//! place (windowed reads, never the whole city), object-store files are fetched whole first — of a VRT mosaic,
//! only the tiles the window needs, and GDAL sees the mosaic rewritten to them (`plumbline_runtime::vrt`). GDAL handles are not `Send`, so each call opens
//! its source on the blocking thread that uses it.

use std::path::PathBuf;

use plumbline_campaign::SkipReason;
use plumbline_imaging::GrayImage;
use plumbline_imaging::radiometry::gray_from_bands;
use plumbline_registration::aerial::Terrain;
use plumbline_runtime::gdal_read::{MapBox, RasterSource, Tiles};
use plumbline_runtime::gdal_write::{Raster, RasterData};
use plumbline_runtime::vrt::{VrtMosaic, is_xml};
use plumbline_runtime::{Files, invalid};

use crate::fetch::{blocking, reason_of_store};

/// The local file behind a `file://` URL or a plain path; `None` for other schemes.
fn local_path(url: &str) -> Option<PathBuf> {
    match url.split_once("://") {
        Some(("file", rest)) => Some(PathBuf::from(rest)),
        Some(_) => None,
        None => Some(PathBuf::from(url)),
    }
}

/// Why a window could not be read: the store did not deliver a file, or GDAL could not read what it got.
#[derive(Debug, thiserror::Error)]
pub(crate) enum WindowError {
    /// Reading the raster (or one of its mosaic tiles) from its store failed.
    #[error("{0}")]
    Store(plumbline_runtime::Error),
    /// The bytes are not a raster GDAL can read, or the window cannot be cut from it.
    #[error("{0}")]
    Raster(plumbline_runtime::Error),
}

impl WindowError {
    /// How a skipped input reports it: a file the store says does not exist is missing, another store failure
    /// is a read failure (a later attempt may succeed), anything GDAL rejects is undecodable.
    pub(crate) fn reason(&self) -> SkipReason {
        match self {
            Self::Store(e) => reason_of_store(e),
            Self::Raster(_) => SkipReason::Decode,
        }
    }
}

/// Read the window of the raster at `url` covering `area` (`None`: the area lies outside the raster).
pub(crate) async fn read_window(
    files: &Files,
    url: &str,
    area: MapBox,
    crs: u32,
) -> Result<Option<Raster>, WindowError> {
    let local = local_path(url);
    if let Some(path) = local.as_ref().filter(|p| !p.exists()) {
        return Err(WindowError::Store(plumbline_runtime::Error::missing(format!("{}: no such file", path.display()))));
    }
    let bytes = match local {
        None => Some(files.read(url).await.map_err(WindowError::Store)?.to_vec()),
        Some(_) => None,
    };
    let tiles = match &bytes {
        Some(vrt) if is_xml(vrt) => Some(read_tiles(files, url, vrt, &area).await?),
        _ => None,
    };
    let url = url.to_owned();
    let window = blocking(move || -> plumbline_runtime::Result<Option<Raster>> {
        let source = match (local, bytes, tiles) {
            (Some(path), _, _) => RasterSource::open_local(&path, Tiles::Over(&area))?,
            (None, bytes, Some(tiles)) => RasterSource::open_mosaic_bytes(&url, &bytes.unwrap_or_default(), tiles)?,
            (None, bytes, None) => RasterSource::open_bytes(&url, bytes.unwrap_or_default())?,
        };
        // A raster in another CRS would only "miss" every tile: say what is wrong instead.
        if let Some(epsg) = source.epsg().filter(|&e| e != crs) {
            return Err(invalid(format!(
                "{url}: the raster is in EPSG:{epsg}, the campaign in EPSG:{crs}; reproject it"
            )));
        }
        Ok(source.window(&area)?)
    })
    .await
    .map_err(WindowError::Store)?;
    window.map_err(WindowError::Raster)
}

/// The tiles of the VRT mosaic at `url` that hold pixels of `area`, fetched from beside it (their paths are
/// relative to the VRT and below its directory: `VrtMosaic::parse` refuses others).
async fn read_tiles(
    files: &Files,
    url: &str,
    vrt: &[u8],
    area: &MapBox,
) -> Result<Vec<(String, Vec<u8>)>, WindowError> {
    let dir = url.rsplit_once('/').map_or("", |(dir, _)| dir);
    let mut tiles = Vec::new();
    let mosaic = VrtMosaic::parse(url, vrt).map_err(|e| WindowError::Raster(e.into()))?;
    for tile in mosaic.files_over(area) {
        let tile_url = if dir.is_empty() { tile.clone() } else { format!("{dir}/{tile}") };
        tiles.push((tile, files.read(&tile_url).await.map_err(WindowError::Store)?.to_vec()));
    }
    Ok(tiles)
}

/// The gray value of every pixel (`plumbline_imaging::radiometry`): band 1 for one band, the luma of bands 1–3
/// for colour; 8-bit values as they are, deeper data stretched to 0–255.
pub(crate) fn gray(raster: &Raster) -> plumbline_runtime::Result<GrayImage> {
    let (bands, eight_bit): (Vec<Vec<f32>>, bool) = match &raster.data {
        RasterData::U8(b) => (b.iter().map(|v| v.iter().map(|&x| f32::from(x)).collect()).collect(), true),
        RasterData::U16(b) => (b.iter().map(|v| v.iter().map(|&x| f32::from(x)).collect()).collect(), false),
        RasterData::F32(b) => (b.clone(), false),
    };
    gray_from_bands(raster.width, raster.height, &bands, eight_bit).map_err(|e| invalid(e.to_string()))
}

/// Band 1 as terrain heights, no-data values as NaN.
pub(crate) fn terrain(raster: &Raster) -> plumbline_runtime::Result<Terrain> {
    let heights: Vec<f32> = match &raster.data {
        RasterData::F32(b) => b.first().cloned().unwrap_or_default(),
        RasterData::U8(b) => b.first().map(|band| band.iter().map(|&v| f32::from(v)).collect()).unwrap_or_default(),
        RasterData::U16(b) => b.first().map(|band| band.iter().map(|&v| f32::from(v)).collect()).unwrap_or_default(),
    };
    if heights.len() != raster.width * raster.height {
        return Err(invalid("the terrain window has no band"));
    }
    let nodata = raster.nodata;
    let heights = heights.into_iter().map(|v| if nodata == Some(f64::from(v)) { f32::NAN } else { v }).collect();
    Ok(Terrain { heights, width: raster.width, height: raster.height, geotransform: raster.geotransform })
}

/// The terrain height in the pixel containing (e, n), if it holds data.
pub(crate) fn height_at(terrain: &Terrain, e: f64, n: f64) -> Option<f64> {
    let g = &terrain.geotransform;
    let (c, r) = (((e - g[0]) / g[1]).floor(), ((n - g[3]) / g[5]).floor());
    if !(c >= 0.0 && r >= 0.0 && (c as usize) < terrain.width && (r as usize) < terrain.height) {
        return None;
    }
    let v = *terrain.heights.get(r as usize * terrain.width + c as usize)?;
    v.is_finite().then_some(f64::from(v))
}

/// A square box of half-size `half` around (e, n).
pub(crate) fn around(e: f64, n: f64, half: f64) -> MapBox {
    MapBox { min_e: e - half, min_n: n - half, max_e: e + half, max_n: n + half }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raster(data: RasterData, nodata: Option<f64>) -> Raster {
        Raster { width: 3, height: 2, geotransform: [100.0, 2.0, 0.0, 50.0, 0.0, -2.0], epsg: 25832, data, nodata }
    }

    #[test]
    fn heights_are_looked_up_in_the_pixel_containing_the_point_and_nodata_is_none() {
        let t = terrain(&raster(RasterData::F32(vec![vec![1.0, 2.0, 3.0, 4.0, -9999.0, 6.0]]), Some(-9999.0))).unwrap();
        assert_eq!(height_at(&t, 100.5, 49.5), Some(1.0));
        assert_eq!(height_at(&t, 105.9, 47.9), Some(6.0)); // column 2, row 1
        assert_eq!(height_at(&t, 103.0, 47.0), None); // no data
        assert_eq!(height_at(&t, 99.0, 49.0), None); // outside
    }

    #[test]
    fn colour_windows_become_luma() {
        let bands = vec![vec![255; 6], vec![0; 6], vec![100; 6]];
        let g = gray(&raster(RasterData::U8(bands), None)).unwrap();
        assert!((g.get(2, 1) - (0.299 * 255.0 + 0.114 * 100.0)).abs() < 1e-3);
        assert_eq!(local_path("file:///a/b.tif"), Some(PathBuf::from("/a/b.tif")));
        assert_eq!(local_path("s3://bucket/b.tif"), None);
    }

    /// A 4×2-pixel tile of a two-tile mosaic at 1 m, every pixel `value`, its top-left at column `col`.
    fn tile(col: usize, value: f32) -> Vec<u8> {
        let gt = [500_000.0 + col as f64, 1.0, 0.0, 5_000_002.0, 0.0, -1.0];
        let data = RasterData::F32(vec![vec![value; 8]]);
        let raster = Raster { width: 4, height: 2, geotransform: gt, epsg: 25832, data, nodata: Some(-9999.0) };
        plumbline_runtime::gdal_write::geotiff(&raster).unwrap()
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_window_of_a_vrt_mosaic_on_an_object_store_reads_the_tiles_beside_it() {
        use plumbline_runtime::gdal_write::{Mosaic, MosaicTile, MosaicType, vrt};
        let moto = plumbline_testkit::MotoServer::start();
        moto.create_bucket("rasters");
        let s3 = plumbline_runtime::S3Options {
            endpoint: Some(moto.endpoint()),
            region: Some("eu-central-1".to_owned()),
            access_key_id: Some("plumbline-test".to_owned()),
            secret_access_key: Some(plumbline_runtime::Secret::new("plumbline-test-secret")),
            allow_http: false,
            virtual_hosted_style: false,
        };
        let files = Files::new(s3);
        let tiles = vec![
            MosaicTile { path: "terrain/0_0.tif".into(), col: 0, row: 0 },
            MosaicTile { path: "terrain/1_0.tif".into(), col: 4, row: 0 },
        ];
        let mosaic = Mosaic {
            width: 8,
            height: 2,
            geotransform: [500_000.0, 1.0, 0.0, 5_000_002.0, 0.0, -1.0],
            epsg: 25832,
            bands: 1,
            data_type: MosaicType::F32,
            tile_size: (4, 2),
            nodata: Some(-9999.0),
            tiles,
        };
        let base = "s3://rasters/campaign/aerial";
        files.write(&format!("{base}/terrain.vrt"), vrt(&mosaic).unwrap()).await.unwrap();
        files.write(&format!("{base}/terrain/0_0.tif"), tile(0, 10.0)).await.unwrap();
        files.write(&format!("{base}/terrain/1_0.tif"), tile(4, 20.0)).await.unwrap();

        // Across the border between the two tiles: both are fetched.
        let area = MapBox { min_e: 500_002.5, min_n: 5_000_000.5, max_e: 500_005.5, max_n: 5_000_001.5 };
        let window = read_window(&files, &format!("{base}/terrain.vrt"), area, 25832).await.unwrap().unwrap();
        let t = terrain(&window).unwrap();
        assert_eq!(height_at(&t, 500_003.5, 5_000_001.0), Some(10.0));
        assert_eq!(height_at(&t, 500_004.5, 5_000_001.0), Some(20.0));
        // Within the first tile only: the second is not needed, so a missing second tile does not matter.
        files.write(&format!("{base}/terrain/1_0.tif"), b"not a tiff".to_vec()).await.unwrap();
        let area = MapBox { min_e: 500_000.5, min_n: 5_000_000.5, max_e: 500_002.5, max_n: 5_000_001.5 };
        let window = read_window(&files, &format!("{base}/terrain.vrt"), area, 25832).await.unwrap().unwrap();
        assert_eq!(height_at(&terrain(&window).unwrap(), 500_001.5, 5_000_001.0), Some(10.0));
        // Across the border again: the broken tile is undecodable, a deleted one missing — neither retried.
        let area = MapBox { min_e: 500_002.5, min_n: 5_000_000.5, max_e: 500_005.5, max_n: 5_000_001.5 };
        let broken = read_window(&files, &format!("{base}/terrain.vrt"), area, 25832).await.unwrap_err();
        assert_eq!(broken.reason(), SkipReason::Decode, "{broken}");
        let lonely = "s3://rasters/campaign/no-tiles/terrain.vrt";
        files.write(lonely, vrt(&mosaic).unwrap()).await.unwrap();
        let missing = read_window(&files, lonely, area, 25832).await.unwrap_err();
        assert_eq!(missing.reason(), SkipReason::Missing, "{missing}");
        assert!(missing.to_string().contains("no-tiles/terrain/0_0.tif"), "{missing}");
        // Another agency's tile named from this one's VRT (single-quoted, behind a comment): refused before any
        // read, as the VRT's fault.
        let other = "s3://rasters/other-agency/terrain/0_0.tif";
        files.write(other, tile(0, 99.0)).await.unwrap();
        let xml = String::from_utf8(vrt(&mosaic).unwrap()).unwrap();
        let hostile =
            format!("<!-- x -->{}", xml.replace("\"1\">terrain/0_0.tif", "'1'>../../other-agency/terrain/0_0.tif"));
        assert!(hostile.contains("'1'>../../other-agency"), "{hostile}");
        files.write(&format!("{base}/hostile.vrt"), hostile.into_bytes()).await.unwrap();
        let refused = read_window(&files, &format!("{base}/hostile.vrt"), area, 25832).await.unwrap_err();
        assert_eq!(refused.reason(), SkipReason::Decode, "{refused}");
        assert!(refused.to_string().contains("`..` segment"), "{refused}");
    }

    /// A store that fails to deliver is a read failure (retried); one that says the file is not there, or
    /// bytes GDAL rejects, are the input's fault.
    #[tokio::test]
    async fn window_failures_say_whether_a_retry_can_help() {
        assert_eq!(
            WindowError::Store(plumbline_runtime::Error::transient("connection reset")).reason(),
            SkipReason::Read
        );
        // A scheme no store serves is refused for good, not retried as an outage.
        let files = Files::new(plumbline_runtime::S3Options::default());
        let e = files.read("gs://bucket/ortho.tif").await.unwrap_err();
        assert_eq!(WindowError::Store(e).reason(), SkipReason::Refused);
        assert!(!SkipReason::Refused.retryable());
        assert!(SkipReason::Read.retryable() && !SkipReason::Missing.retryable() && !SkipReason::Decode.retryable());
        let dir = tempfile::tempdir().unwrap();
        let files = Files::new(plumbline_runtime::S3Options::default());
        let area = around(500_000.0, 5_000_000.0, 1.0);
        let absent = dir.path().join("absent.tif").display().to_string();
        let e = read_window(&files, &absent, area, 25832).await.unwrap_err();
        assert_eq!(e.reason(), SkipReason::Missing, "{e}");
        assert!(e.to_string().contains("absent.tif"), "{e}");
        let junk = dir.path().join("junk.tif");
        std::fs::write(&junk, b"not a tiff").unwrap();
        let e = read_window(&files, &junk.display().to_string(), area, 25832).await.unwrap_err();
        assert_eq!(e.reason(), SkipReason::Decode, "{e}");
    }

    /// A raster in another CRS than the campaign's is named as such, not as one that misses every tile.
    #[tokio::test]
    async fn a_raster_in_another_crs_is_refused_naming_both() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ortho.tif");
        let data = RasterData::F32(vec![vec![1.0; 6]]);
        let raster = Raster {
            width: 3,
            height: 2,
            geotransform: [100.0, 2.0, 0.0, 50.0, 0.0, -2.0],
            epsg: 25832,
            data,
            nodata: None,
        };
        std::fs::write(&path, plumbline_runtime::gdal_write::geotiff(&raster).unwrap()).unwrap();
        let files = Files::new(plumbline_runtime::S3Options::default());
        let url = path.display().to_string();
        assert!(read_window(&files, &url, around(102.0, 48.0, 1.0), 25832).await.unwrap().is_some());
        let e = read_window(&files, &url, around(102.0, 48.0, 1.0), 25833).await.unwrap_err();
        assert_eq!(e.reason(), SkipReason::Decode);
        assert!(e.to_string().contains("the raster is in EPSG:25832, the campaign in EPSG:25833"), "{e}");
    }
}
