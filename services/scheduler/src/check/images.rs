//! Image indexes and image headers: rows usable, names below the images prefix, times inside the drive,
//! and the first image of each index (and the vehicle mask) of the size the manifest says.

use plumbline_campaign::Location;
use plumbline_campaign::tables::{RowProblem, read_index};
use plumbline_imaging::decode::{
    AERIAL_FRAME_PIXELS, Bounds, ColorType, DEPTH_PIXELS, ImageFormat, PANORAMA_PIXELS, header,
};
use plumbline_runtime::gdal_read::{MAGIC_BYTES, is_tiled_raster};

use super::Checker;

/// Skipped rows listed by name in a warning; the rest are counted.
const ROWS_LISTED: usize = 3;

/// What the first image of an index must be.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Expect {
    /// A panorama, of the manifest's size when it gives one.
    Panorama(Option<(u32, u32)>),
    /// A 16-bit gray depth PNG of the intrinsics' size.
    Depth(u32, u32),
    /// An aerial frame of the interior orientation's size.
    Aerial(u32, u32),
}

/// Rows a table reader skipped, as one warning.
pub(crate) fn skipped_rows(c: &mut Checker<'_>, field: &str, skipped: &[RowProblem]) {
    if skipped.is_empty() {
        return;
    }
    let listed: Vec<String> = skipped.iter().take(ROWS_LISTED).map(ToString::to_string).collect();
    let more = skipped.len().saturating_sub(ROWS_LISTED);
    let more = if more > 0 { format!("; and {more} more") } else { String::new() };
    c.warning(field, format!("{} row(s) will be skipped: {}{more}", skipped.len(), listed.join("; ")));
}

/// An image index: readable, with usable rows whose files stay below the prefix and whose times lie inside the
/// drive; the first row's image has the expected size.
pub(crate) async fn index(c: &mut Checker<'_>, input: &str, index: &Location, images: &Location, expect: Expect) {
    let field = format!("{input}.index");
    let Some(url) = c.url(&field, index) else { return };
    let Some(bytes) = c.read(&field, &url).await else { return };
    let table = match read_index(&url, &bytes) {
        Ok(table) => table,
        Err(e) => return c.problem(&field, e),
    };
    skipped_rows(c, &field, &table.skipped);
    if table.rows.is_empty() {
        return c.problem(&field, format!("`{url}` has no usable row"));
    }
    let Some(mut dir) = c.url(&format!("{input}.images"), images) else { return };
    if !dir.ends_with('/') {
        dir.push('/');
    }
    let below = |file: &str| plumbline_campaign::resolve_below(&dir, file).is_ok();
    let escaping: Vec<&str> = table.rows.iter().map(|r| r.file.as_str()).filter(|f| !below(f)).collect();
    if let Some(first) = escaping.first() {
        c.problem(
            &field,
            format!(
                "{} row(s) name a file outside `{input}.images` (an absolute path or URL, or `..`), e.g. `{first}`; \
                 index rows name files relative to the images prefix",
                escaping.len()
            ),
        );
    }
    if let Some(drive) = c.drive {
        let (t0, t1) = drive.span;
        let outside = table.rows.iter().filter(|r| !(t0..=t1).contains(&r.time)).count();
        let span = format!("the trajectory spans {t0:.3}–{t1:.3} s");
        if outside == table.rows.len() {
            c.problem(
                &field,
                format!("all {outside} rows have times outside the trajectory ({span}): another time system?"),
            );
        } else if outside > 0 {
            c.warning(
                &field,
                format!(
                    "{outside} of {} rows lie outside the trajectory ({span}) and will not be planned",
                    table.rows.len()
                ),
            );
        }
    }
    if let Some(first) = table.rows.iter().find(|r| below(&r.file)) {
        first_image(c, &field, images, &first.file, expect).await;
    }
}

/// The header of one image named by an index row: within its pixel budget, and of the expected size and pixel
/// type — read through the same bounded decoder the run uses, so what passes here decodes there.
pub(crate) async fn first_image(c: &mut Checker<'_>, field: &str, images: &Location, file: &str, expect: Expect) {
    let Some(dir) = c.url(field, images) else { return };
    let dir = if dir.ends_with('/') { dir } else { format!("{dir}/") };
    let url = match plumbline_campaign::resolve_below(&dir, file) {
        Ok(url) => url,
        Err(e) => return c.problem(field, format!("row file `{file}`: {e}")),
    };
    if let Expect::Aerial(w, h) = expect {
        match c.files.read_prefix(&url, MAGIC_BYTES).await {
            Ok((head, _)) if is_tiled_raster(&head) => return tiled_frame(c, field, &url, (w, h)).await,
            Ok(_) => {}
            Err(e) => return c.problem(field, format!("`{url}`: {e:#}")),
        }
    }
    let Some(bytes) = c.read(field, &url).await else { return };
    let (bounds, what) = match expect {
        Expect::Panorama(size) => {
            let bounds = Bounds::budget(PANORAMA_PIXELS);
            (size.map_or(bounds, |(w, h)| bounds.expecting(w, h)), "panoramas.width_px/height_px")
        }
        Expect::Depth(w, h) => {
            (Bounds::budget(DEPTH_PIXELS).expecting(w, h).only(ImageFormat::Png), "depth intrinsics")
        }
        Expect::Aerial(w, h) => (Bounds::budget(AERIAL_FRAME_PIXELS).expecting(w, h), "aerial.frames.interior"),
    };
    match header(&url, &bytes, &bounds) {
        Ok(h) if matches!(expect, Expect::Depth(..)) && h.color != ColorType::L16 => {
            c.problem(field, format!("first image `{url}` is {:?}; depth images are 16-bit gray PNGs", h.color));
        }
        Ok(_) => {}
        Err(e) => {
            let hint =
                if e.is_size() { format!(" ({what}; every such image would be skipped)") } else { String::new() };
            c.problem(field, format!("first image: {e}{hint}"));
        }
    }
}

/// A tiled raster frame (TIFF, JPEG 2000) opened as the run opens it, through GDAL without fetching it whole:
/// the interior orientation's size, 1–4 bands.
async fn tiled_frame(c: &mut Checker<'_>, field: &str, url: &str, (w, h): (u32, u32)) {
    let input = match c.files.pixel_input(url).await {
        Ok(input) => input,
        Err(e) => return c.problem(field, format!("`{url}`: {e:#}")),
    };
    let name = url.to_owned();
    let opened = tokio::task::spawn_blocking(move || {
        let source = input.open(&name)?;
        Ok::<_, plumbline_runtime::gdal_read::GdalReadError>((source.size(), source.band_count(), source.pixel_type()?))
    })
    .await;
    match opened {
        Ok(Ok(((width, height), bands, pixel))) => {
            if (width, height) != (w as usize, h as usize) {
                c.problem(
                    field,
                    format!(
                        "first image `{url}` is {width} × {height} px, expected {w} × {h} px (aerial.frames.interior; \
                         every such frame would be skipped)"
                    ),
                );
            }
            if !(1..=4).contains(&bands) {
                c.warning(field, format!("first image `{url}` has {bands} bands; bands 1–3 are used ({pixel})"));
            }
        }
        Ok(Err(e)) => c.problem(field, format!("first image: {e}")),
        Err(e) => c.problem(field, format!("first image `{url}`: the check failed: {e}")),
    }
}

/// The vehicle mask: a readable image of the panoramas' size.
pub(crate) async fn vehicle_mask(c: &mut Checker<'_>, mask: &Location, expected: Option<(u32, u32)>) {
    let field = "panoramas.vehicle_mask";
    let Some(url) = c.url(field, mask) else { return };
    let Some(bytes) = c.read(field, &url).await else { return };
    let bounds = Bounds::budget(PANORAMA_PIXELS);
    let bounds = expected.map_or(bounds, |(w, h)| bounds.expecting(w, h));
    if let Err(e) = header(&url, &bytes, &bounds) {
        c.problem(field, format!("{e} (the panoramas' size)"));
    }
}
