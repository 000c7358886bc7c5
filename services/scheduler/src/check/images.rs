//! Image indexes and image headers: rows usable, names below the images prefix, times inside the drive,
//! and the first image of each index (and the vehicle mask) of the size the manifest says.

use plumbline_campaign::Location;
use plumbline_campaign::tables::{RowProblem, read_index};

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

/// Whether an index row's file name stays below the images prefix: relative, without `..`, no scheme.
pub(crate) fn stays_below(file: &str) -> bool {
    !(file.contains("://")
        || file.starts_with('/')
        || file.starts_with('\\')
        || file.get(1..2) == Some(":")
        || file.split(['/', '\\']).any(|part| part == ".."))
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
    let escaping: Vec<&str> = table.rows.iter().map(|r| r.file.as_str()).filter(|f| !stays_below(f)).collect();
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
    if let Some(first) = table.rows.iter().find(|r| stays_below(&r.file)) {
        first_image(c, &field, images, &first.file, expect).await;
    }
}

/// The header of one image named by an index row: decodable, and of the expected size and pixel type.
pub(crate) async fn first_image(c: &mut Checker<'_>, field: &str, images: &Location, file: &str, expect: Expect) {
    let Some(dir) = c.url(field, images) else { return };
    let dir = if dir.ends_with('/') { dir } else { format!("{dir}/") };
    let url = match plumbline_campaign::resolve(&dir, file) {
        Ok(url) => url,
        Err(e) => return c.problem(field, format!("row file `{file}`: {e}")),
    };
    let Some(bytes) = c.read(field, &url).await else { return };
    let header = match header(&bytes) {
        Ok(h) => h,
        Err(e) => return c.problem(field, format!("first image `{url}` is not a readable image: {e}")),
    };
    let size = (header.0, header.1);
    let wrong = |what: &str, expected: (u32, u32)| {
        format!(
            "first image `{url}` is {} × {} px; {what} says {} × {} px (every image of this size would be skipped)",
            size.0, size.1, expected.0, expected.1
        )
    };
    match expect {
        Expect::Panorama(Some(expected)) if size != expected => {
            c.problem(field, wrong("panoramas.width_px/height_px", expected));
        }
        Expect::Panorama(_) => {}
        Expect::Depth(w, h) => {
            if size != (w, h) {
                c.problem(field, wrong("the depth intrinsics", (w, h)));
            }
            if header.2 != image::ColorType::L16 {
                c.problem(field, format!("first image `{url}` is {:?}; depth images are 16-bit gray PNGs", header.2));
            }
        }
        Expect::Aerial(w, h) if size != (w, h) => c.problem(field, wrong("aerial.frames.interior", (w, h))),
        Expect::Aerial(..) => {}
    }
}

/// The vehicle mask: a readable image of the panoramas' size.
pub(crate) async fn vehicle_mask(c: &mut Checker<'_>, mask: &Location, expected: Option<(u32, u32)>) {
    let field = "panoramas.vehicle_mask";
    let Some(url) = c.url(field, mask) else { return };
    let Some(bytes) = c.read(field, &url).await else { return };
    match header(&bytes) {
        Ok((w, h, _)) => {
            if let Some(expected) = expected.filter(|e| *e != (w, h)) {
                c.problem(
                    field,
                    format!("`{url}` is {w} × {h} px; the panoramas are {} × {} px", expected.0, expected.1),
                );
            }
        }
        Err(e) => c.problem(field, format!("`{url}` is not a readable image: {e}")),
    }
}

/// Width, height and colour type from an image's header (no pixels decoded).
fn header(bytes: &[u8]) -> Result<(u32, u32, image::ColorType), String> {
    use image::ImageDecoder as _;
    let decoder = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?
        .into_decoder()
        .map_err(|e| e.to_string())?;
    let (w, h) = decoder.dimensions();
    Ok((w, h, decoder.color_type()))
}

#[cfg(test)]
mod tests {
    use super::stays_below;

    #[test]
    fn index_rows_must_name_files_below_the_prefix() {
        for ok in ["a.jpg", "day1/a.jpg", "a..b.jpg", "./a.jpg"] {
            assert!(stays_below(ok), "{ok}");
        }
        for bad in [
            "/etc/passwd",
            "s3://other/a.jpg",
            "file:///a.jpg",
            "../a.jpg",
            "x/../../a.jpg",
            "C:\\a.jpg",
            "\\\\host\\a",
        ] {
            assert!(!stays_below(bad), "{bad}");
        }
    }
}
