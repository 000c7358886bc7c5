//! GDAL VRT mosaics an agency supplies, confined before GDAL sees them.
//!
//! A VRT is XML telling GDAL which files to read: any path on the machine, `/vsicurl/` URLs, other VRTs,
//! pixel functions. An agency's VRT is therefore never handed to GDAL as it is. [`VrtMosaic::parse`] reads it
//! with an XML parser into what a mosaic needs — the dataset's size, CRS and geotransform, and per band its
//! type, no-data value and simple or complex sources, each a file *relative to the VRT and below its
//! directory* with its source and destination rectangles. Anything that would make GDAL read something else
//! (a derived or warped dataset, pixel functions, kernel filters, scaling tables, absolute or escaping source
//! paths, a DOCTYPE) is refused naming the element. [`VrtMosaic::to_xml`] then writes a fresh VRT with only
//! the sources the caller keeps, at locations the caller chose: GDAL's in-memory files, or local files it
//! resolved below the VRT's directory. `gdal_write::vrt` writes the simulator's mosaics with the same writer.

use std::borrow::Cow;

use quick_xml::events::{BytesStart, Event};

use crate::raster_common::{GdalReadError, MapBox};

/// Largest VRT read (a city mosaic of 10,000 tiles × 4 bands is about 10 MB).
pub const MAX_VRT_BYTES: usize = 32 << 20;
/// Deepest element nesting accepted (a mosaic needs 4).
const MAX_DEPTH: usize = 16;
/// Most elements accepted.
const MAX_ELEMENTS: usize = 2_000_000;
/// Largest dataset side, pixels.
const MAX_SIDE: usize = 10_000_000;
/// Pixel types a mosaic band may have (GDAL's names).
const DATA_TYPES: [&str; 7] = ["Byte", "UInt16", "Int16", "UInt32", "Int32", "Float32", "Float64"];
/// Elements read as nothing wherever they stand (descriptive only).
const IGNORED: [&str; 4] = ["Metadata", "Description", "Histograms", "CategoryNames"];

/// A rectangle in pixels (`xOff`, `yOff`, `xSize`, `ySize`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Left column.
    pub x: f64,
    /// Top row.
    pub y: f64,
    /// Width.
    pub w: f64,
    /// Height.
    pub h: f64,
}

/// A source's declared size and blocks (`SourceProperties`): lets GDAL open a source only when a read
/// touches it.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceProperties {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Pixel type (one of GDAL's names).
    pub data_type: String,
    /// Block width.
    pub block_width: usize,
    /// Block height.
    pub block_height: usize,
}

/// One source of a band: a file beside the VRT, copied (simple) or with a no-data value (complex).
#[derive(Clone, Debug, PartialEq)]
pub struct VrtSource {
    /// `ComplexSource` (true) or `SimpleSource`.
    pub complex: bool,
    /// The file, relative to the VRT and below its directory (forward slashes, checked).
    pub path: String,
    /// Band of the file.
    pub band: usize,
    /// Declared size and blocks, if given.
    pub properties: Option<SourceProperties>,
    /// The part of the file read (all of it when absent).
    pub src: Option<Rect>,
    /// Where it lands in the mosaic.
    pub dst: Rect,
    /// The file's no-data value (complex sources).
    pub nodata: Option<f64>,
}

/// One band of the mosaic.
#[derive(Clone, Debug, PartialEq)]
pub struct VrtBand {
    /// Pixel type (one of GDAL's names).
    pub data_type: String,
    /// Colour interpretation (`Red`, `Gray`, …), if given.
    pub colour: Option<String>,
    /// No-data value, if any (also what areas without a source read as).
    pub nodata: Option<f64>,
    /// The sources, in order.
    pub sources: Vec<VrtSource>,
}

/// A mosaic VRT, as far as plumbline reads one.
#[derive(Clone, Debug, PartialEq)]
pub struct VrtMosaic {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// The CRS as WKT (or any definition GDAL accepts), if given.
    pub srs: Option<String>,
    /// `dataAxisToSRSAxisMapping`, if given.
    pub axis_mapping: Option<String>,
    /// GDAL geotransform.
    pub geotransform: [f64; 6],
    /// The bands.
    pub bands: Vec<VrtBand>,
}

/// Whether bytes look like XML (after a byte-order mark and white space): a VRT, or something posing as a
/// raster that is none.
pub fn is_xml(bytes: &[u8]) -> bool {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    bytes.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'<')
}

/// An element as parsed: name, attributes, text and children.
#[derive(Debug, Default)]
struct Node {
    name: String,
    attributes: Vec<(String, String)>,
    text: String,
    children: Vec<Node>,
}

impl Node {
    fn attribute(&self, key: &str) -> Option<&str> {
        self.attributes.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }
}

impl VrtMosaic {
    /// Parse a VRT; `name` (its URL) is used in errors.
    pub fn parse(name: &str, bytes: &[u8]) -> Result<Self, GdalReadError> {
        let unusable = |problem: String| GdalReadError::Unusable { name: name.to_owned(), problem };
        if bytes.len() > MAX_VRT_BYTES {
            return Err(unusable(format!("is a VRT of {} bytes; at most {MAX_VRT_BYTES} are read", bytes.len())));
        }
        let text = std::str::from_utf8(bytes).map_err(|e| unusable(format!("is not UTF-8 XML: {e}")))?;
        let root = tree(text).map_err(|e| unusable(format!("is not a readable VRT: {e}")))?;
        mosaic(&root).map_err(unusable)
    }

    /// The source files (each once, in order) holding pixels of `area`, given in the mosaic's CRS.
    pub fn files_over(&self, area: &MapBox) -> Vec<String> {
        let [x0, dx, _, y0, _, dy] = self.geotransform;
        let (c0, c1) = ((area.min_e - x0) / dx, (area.max_e - x0) / dx);
        let (r0, r1) = ((area.max_n - y0) / dy, (area.min_n - y0) / dy);
        let (c0, c1, r0, r1) = (c0.min(c1), c0.max(c1), r0.min(r1), r0.max(r1));
        let (width, height) = (self.width as f64, self.height as f64);
        let mut seen = std::collections::HashSet::new();
        let overlapping = self.bands.iter().flat_map(|b| &b.sources).filter(|s| {
            let d = s.dst;
            c0 < d.x + d.w && c1 > d.x && r0 < d.y + d.h && r1 > d.y && d.x < width && d.y < height
        });
        overlapping.filter(|s| seen.insert(s.path.as_str())).map(|s| s.path.clone()).collect()
    }

    /// The VRT XML with the sources `locate` keeps: for a source's checked relative path it returns the file
    /// name to write and whether that name is relative to the VRT, or `None` to leave the source out.
    pub fn to_xml(&self, locate: impl Fn(&str) -> Option<(String, bool)>) -> Vec<u8> {
        let mut xml = format!("<VRTDataset rasterXSize=\"{}\" rasterYSize=\"{}\">\n", self.width, self.height);
        if let Some(srs) = &self.srs {
            match &self.axis_mapping {
                Some(m) => xml += &format!("  <SRS dataAxisToSRSAxisMapping=\"{}\">", escape(m)),
                None => xml += "  <SRS>",
            }
            xml += &format!("{}</SRS>\n", escape(srs));
        }
        let gt = self.geotransform.map(|v| format!("{v:?}")).join(", ");
        xml += &format!("  <GeoTransform>{gt}</GeoTransform>\n");
        for (i, band) in self.bands.iter().enumerate() {
            xml += &format!("  <VRTRasterBand dataType=\"{}\" band=\"{}\">\n", band.data_type, i + 1);
            if let Some(colour) = &band.colour {
                xml += &format!("    <ColorInterp>{}</ColorInterp>\n", escape(colour));
            }
            if let Some(nodata) = band.nodata {
                xml += &format!("    <NoDataValue>{}</NoDataValue>\n", number(nodata));
            }
            for s in &band.sources {
                let Some((file, relative)) = locate(&s.path) else { continue };
                let tag = if s.complex { "ComplexSource" } else { "SimpleSource" };
                xml += &format!(
                    "    <{tag}>\n      <SourceFilename relativeToVRT=\"{}\">{}</SourceFilename>\n      \
                     <SourceBand>{}</SourceBand>\n",
                    u8::from(relative),
                    escape(&file),
                    s.band
                );
                if let Some(p) = &s.properties {
                    xml += &format!(
                        "      <SourceProperties RasterXSize=\"{}\" RasterYSize=\"{}\" DataType=\"{}\" \
                         BlockXSize=\"{}\" BlockYSize=\"{}\"/>\n",
                        p.width, p.height, p.data_type, p.block_width, p.block_height
                    );
                }
                if let Some(r) = s.src {
                    xml += &format!("      <SrcRect {}/>\n", rect(&r));
                }
                xml += &format!("      <DstRect {}/>\n", rect(&s.dst));
                if let Some(nodata) = s.nodata.filter(|_| s.complex) {
                    xml += &format!("      <NODATA>{}</NODATA>\n", number(nodata));
                }
                xml += &format!("    </{tag}>\n");
            }
            xml += "  </VRTRasterBand>\n";
        }
        xml += "</VRTDataset>\n";
        xml.into_bytes()
    }
}

fn rect(r: &Rect) -> String {
    format!("xOff=\"{}\" yOff=\"{}\" xSize=\"{}\" ySize=\"{}\"", number(r.x), number(r.y), number(r.w), number(r.h))
}

/// A number as GDAL reads it back exactly (`nan` for NaN).
fn number(v: f64) -> String {
    if v.is_nan() { "nan".to_owned() } else { format!("{v:?}") }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The element tree of an XML document: no DOCTYPE, no processing instructions but the declaration, only the
/// five predefined entities and character references.
fn tree(text: &str) -> Result<Node, String> {
    let mut reader = quick_xml::Reader::from_str(text);
    let mut stack: Vec<Node> = Vec::new();
    let mut root: Option<Node> = None;
    let mut elements = 0usize;
    loop {
        let position = reader.buffer_position();
        let event = reader.read_event().map_err(|e| format!("XML error near byte {position}: {e}"))?;
        let mut open = |start: &BytesStart| -> Result<Node, String> {
            elements += 1;
            if elements > MAX_ELEMENTS || stack.len() >= MAX_DEPTH {
                return Err(format!("more than {MAX_ELEMENTS} elements or {MAX_DEPTH} levels"));
            }
            element(start)
        };
        match event {
            Event::Start(start) => {
                let node = open(&start)?;
                stack.push(node);
            }
            Event::Empty(start) => {
                let node = open(&start)?;
                close(&mut stack, &mut root, node)?;
            }
            Event::End(_) => {
                let node = stack.pop().ok_or("an end tag without its start")?;
                close(&mut stack, &mut root, node)?;
            }
            Event::Text(t) => push_text(&mut stack, &t.decode().map_err(|e| e.to_string())?)?,
            Event::CData(t) => push_text(&mut stack, &t.decode().map_err(|e| e.to_string())?)?,
            Event::GeneralRef(r) => {
                let resolved = match r.resolve_char_ref().map_err(|e| e.to_string())? {
                    Some(c) => c.to_string(),
                    None => predefined(&r.decode().map_err(|e| e.to_string())?)?.to_owned(),
                };
                push_text(&mut stack, &resolved)?;
            }
            Event::DocType(_) => return Err("it has a DOCTYPE (entities are not expanded)".into()),
            Event::PI(_) => return Err("it has a processing instruction".into()),
            Event::Decl(_) | Event::Comment(_) => {}
            Event::Eof => break,
        }
    }
    if !stack.is_empty() {
        return Err("the document ends inside an element".into());
    }
    root.ok_or_else(|| "it holds no element".into())
}

fn predefined(name: &str) -> Result<&'static str, String> {
    Ok(match name {
        "amp" => "&",
        "lt" => "<",
        "gt" => ">",
        "quot" => "\"",
        "apos" => "'",
        _ => return Err(format!("unknown entity &{name};")),
    })
}

fn element(start: &BytesStart) -> Result<Node, String> {
    let name = String::from_utf8_lossy(start.name().as_ref()).into_owned();
    let mut attributes = Vec::new();
    for a in start.attributes() {
        let a = a.map_err(|e| format!("<{name}>: {e}"))?;
        let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let value =
            a.normalized_value(quick_xml::XmlVersion::Implicit1_0).map_err(|e| format!("<{name} {key}>: {e}"))?;
        attributes.push((key, Cow::into_owned(value)));
    }
    Ok(Node { name, attributes, ..Node::default() })
}

fn close(stack: &mut [Node], root: &mut Option<Node>, node: Node) -> Result<(), String> {
    match stack.last_mut() {
        Some(parent) => parent.children.push(node),
        None if root.is_none() => *root = Some(node),
        None => return Err("more than one root element".into()),
    }
    Ok(())
}

fn push_text(stack: &mut [Node], text: &str) -> Result<(), String> {
    match stack.last_mut() {
        Some(node) => node.text.push_str(text),
        None if text.trim().is_empty() => {}
        None => return Err("text outside the root element".into()),
    }
    Ok(())
}

/// The mosaic an element tree describes, or what keeps it from being one.
fn mosaic(root: &Node) -> Result<VrtMosaic, String> {
    if root.name != "VRTDataset" {
        return Err(format!("the root element is <{}>, not <VRTDataset>", root.name));
    }
    if let Some(class) = root.attribute("subClass") {
        return Err(format!("is a {class}; only a mosaic of sources is read"));
    }
    let side = |key: &str| -> Result<usize, String> {
        let v = root.attribute(key).ok_or_else(|| format!("<VRTDataset> has no {key}"))?;
        v.trim()
            .parse()
            .ok()
            .filter(|&n| (1..=MAX_SIDE).contains(&n))
            .ok_or_else(|| format!("<VRTDataset {key}=\"{v}\"> is not a size of 1 to {MAX_SIDE} pixels"))
    };
    let (width, height) = (side("rasterXSize")?, side("rasterYSize")?);
    let (mut srs, mut axis_mapping, mut geotransform, mut bands) = (None, None, None, Vec::new());
    for child in &root.children {
        match child.name.as_str() {
            "SRS" => {
                srs = Some(child.text.trim().to_owned()).filter(|s| !s.is_empty());
                axis_mapping = child.attribute("dataAxisToSRSAxisMapping").map(str::to_owned);
                if let Some(m) = &axis_mapping
                    && !m.chars().all(|c| c.is_ascii_digit() || c == ',' || c == '-')
                {
                    return Err(format!("<SRS dataAxisToSRSAxisMapping=\"{m}\"> is not a list of axis numbers"));
                }
            }
            "GeoTransform" => {
                let values: Vec<f64> = child.text.split(',').filter_map(|v| v.trim().parse().ok()).collect();
                match values[..] {
                    [a, b, c, d, e, f] if values.iter().all(|v| v.is_finite()) => {
                        geotransform = Some([a, b, c, d, e, f]);
                    }
                    _ => return Err(format!("<GeoTransform>{}</GeoTransform> is not six numbers", child.text.trim())),
                }
            }
            "VRTRasterBand" => bands.push(band(child, bands.len() + 1)?),
            name if IGNORED.contains(&name) => {}
            name => return Err(format!("<{name}> in <VRTDataset> is not read; only a mosaic of sources is")),
        }
    }
    let geotransform = geotransform.ok_or("<VRTDataset> has no <GeoTransform>")?;
    if bands.is_empty() {
        return Err("<VRTDataset> has no <VRTRasterBand>".into());
    }
    Ok(VrtMosaic { width, height, srs, axis_mapping, geotransform, bands })
}

fn band(node: &Node, number: usize) -> Result<VrtBand, String> {
    let at = format!("band {number}");
    if let Some(class) = node.attribute("subClass") {
        return Err(format!("{at} is a {class}; only sources are read"));
    }
    let data_type = data_type(node.attribute("dataType"), &at)?;
    let (mut colour, mut nodata, mut sources) = (None, None, Vec::new());
    for child in &node.children {
        match child.name.as_str() {
            "ColorInterp" => {
                let c = child.text.trim();
                colour = c.chars().all(|c| c.is_ascii_alphanumeric()).then(|| c.to_owned()).filter(|c| !c.is_empty());
            }
            "NoDataValue" => nodata = Some(value(&child.text, &format!("{at} <NoDataValue>"))?),
            "SimpleSource" | "ComplexSource" => {
                let at = format!("{at}, source {}", sources.len() + 1);
                sources.push(source(child, &at)?);
            }
            name if IGNORED.contains(&name) => {}
            name => return Err(format!("<{name}> in {at} is not read; only simple and complex sources are")),
        }
    }
    Ok(VrtBand { data_type, colour, nodata, sources })
}

fn source(node: &Node, at: &str) -> Result<VrtSource, String> {
    let complex = node.name == "ComplexSource";
    let (mut path, mut band, mut properties, mut src, mut dst, mut nodata) = (None, None, None, None, None, None);
    for child in &node.children {
        match child.name.as_str() {
            "SourceFilename" => {
                let file = child.text.trim();
                if child.attribute("relativeToVRT").map(str::trim) != Some("1") {
                    return Err(format!("{at}: `{file}` is not relative to the VRT; only files beside it are read"));
                }
                path = Some(relative_below(file).map_err(|e| format!("{at}: `{file}` {e}"))?);
            }
            "SourceBand" => {
                let b = child.text.trim();
                band = Some(b.parse::<usize>().ok().filter(|&b| b >= 1).ok_or_else(|| {
                    format!("{at}: <SourceBand>{b}</SourceBand> is not a band number (masks are not read)")
                })?);
            }
            "SourceProperties" => properties = Some(source_properties(child, at)?),
            "SrcRect" => src = Some(rectangle(child, at)?),
            "DstRect" => dst = Some(rectangle(child, at)?),
            "NODATA" if complex => nodata = Some(value(&child.text, &format!("{at} <NODATA>"))?),
            name if IGNORED.contains(&name) => {}
            name => return Err(format!("<{name}> in {at} is not read; a source is copied as it is")),
        }
    }
    Ok(VrtSource {
        complex,
        path: path.ok_or_else(|| format!("{at} has no <SourceFilename>"))?,
        band: band.unwrap_or(1),
        properties,
        src,
        dst: dst.ok_or_else(|| format!("{at} has no <DstRect>"))?,
        nodata,
    })
}

/// A path below the VRT's directory: relative, no `..`, no scheme or GDAL prefix, no back slashes.
pub(crate) fn relative_below(path: &str) -> Result<String, &'static str> {
    if path.is_empty() || path.len() > 1024 {
        return Err("is not a file name of 1 to 1024 bytes");
    }
    if path.starts_with('/') || path.contains(['\\', ':']) || path.chars().any(char::is_control) {
        return Err("is not a plain relative path (no leading /, \\, : or control characters)");
    }
    if path.split('/').any(|s| s.is_empty() || s == "." || s == "..") {
        return Err("has an empty, `.` or `..` segment; only files below the VRT's directory are read");
    }
    Ok(path.to_owned())
}

fn data_type(v: Option<&str>, at: &str) -> Result<String, String> {
    let v = v.map(str::trim).ok_or_else(|| format!("{at} has no dataType"))?;
    DATA_TYPES
        .iter()
        .find(|t| **t == v)
        .map(|t| (*t).to_owned())
        .ok_or_else(|| format!("{at}: dataType \"{v}\" is not one of {}", DATA_TYPES.join(", ")))
}

fn value(text: &str, at: &str) -> Result<f64, String> {
    let t = text.trim();
    t.parse::<f64>().map_err(|_| format!("{at}: `{t}` is not a number"))
}

fn rectangle(node: &Node, at: &str) -> Result<Rect, String> {
    let v = |key: &str| -> Result<f64, String> {
        let text = node.attribute(key).ok_or_else(|| format!("{at}: <{}> has no {key}", node.name))?;
        text.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && v.abs() <= MAX_SIDE as f64)
            .ok_or_else(|| format!("{at}: <{} {key}=\"{text}\"> is not a pixel position", node.name))
    };
    let r = Rect { x: v("xOff")?, y: v("yOff")?, w: v("xSize")?, h: v("ySize")? };
    if r.w <= 0.0 || r.h <= 0.0 {
        return Err(format!("{at}: <{}> is {} × {} pixels", node.name, r.w, r.h));
    }
    Ok(r)
}

fn source_properties(node: &Node, at: &str) -> Result<SourceProperties, String> {
    let v = |key: &str| -> Result<usize, String> {
        let text = node.attribute(key).ok_or_else(|| format!("{at}: <SourceProperties> has no {key}"))?;
        text.trim()
            .parse()
            .ok()
            .filter(|&n| (1..=MAX_SIDE).contains(&n))
            .ok_or_else(|| format!("{at}: <SourceProperties {key}=\"{text}\"> is not a size"))
    };
    Ok(SourceProperties {
        width: v("RasterXSize")?,
        height: v("RasterYSize")?,
        data_type: data_type(node.attribute("DataType"), at)?,
        block_width: v("BlockXSize")?,
        block_height: v("BlockYSize")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"<?xml version="1.0"?>
<!-- written by gdalbuildvrt -->
<VRTDataset rasterXSize="16" rasterYSize="8">
  <SRS dataAxisToSRSAxisMapping="1,2">PROJCS["ETRS89 / UTM zone 32N"]</SRS>
  <GeoTransform> 5.0e+05, 5.0e-01, 0.0, 5.000101e+06, 0.0, -5.0e-01</GeoTransform>
  <Metadata><MDI key="x">y</MDI></Metadata>
  <VRTRasterBand dataType="Float32" band="1">
    <NoDataValue>-9999</NoDataValue>
    <ColorInterp>Gray</ColorInterp>
    <ComplexSource>
      <SourceFilename relativeToVRT="1" shared="0">tiles/0_0.tif</SourceFilename>
      <SourceBand>1</SourceBand>
      <SourceProperties RasterXSize="8" RasterYSize="6" DataType="Float32" BlockXSize="8" BlockYSize="6"/>
      <SrcRect xOff="0" yOff="0" xSize="8" ySize="6"/>
      <DstRect xOff='0' yOff='2' xSize='8' ySize='6'/>
      <NODATA>-9999</NODATA>
    </ComplexSource>
    <SimpleSource>
      <SourceFilename relativeToVRT="1">tiles/a&amp;b.tif</SourceFilename>
      <DstRect xOff="8" yOff="2" xSize="8" ySize="6"/>
    </SimpleSource>
  </VRTRasterBand>
</VRTDataset>
"#;

    #[test]
    fn a_gdalbuildvrt_mosaic_parses_with_either_quote_and_entities() {
        let m = VrtMosaic::parse("m.vrt", GOOD.as_bytes()).unwrap();
        assert_eq!((m.width, m.height, m.bands.len()), (16, 8, 1));
        assert_eq!(m.geotransform, [500_000.0, 0.5, 0.0, 5_000_101.0, 0.0, -0.5]);
        let b = &m.bands[0];
        assert_eq!((b.nodata, b.colour.as_deref(), b.sources.len()), (Some(-9999.0), Some("Gray"), 2));
        assert_eq!(b.sources[0].dst, Rect { x: 0.0, y: 2.0, w: 8.0, h: 6.0 }, "single quotes are attributes too");
        assert_eq!((b.sources[0].nodata, b.sources[1].path.as_str()), (Some(-9999.0), "tiles/a&b.tif"));
        let west = MapBox { min_e: 500_000.5, min_n: 5_000_098.0, max_e: 500_003.5, max_n: 5_000_099.0 };
        let north = MapBox { min_e: 500_000.0, min_n: 5_000_100.5, max_e: 500_008.0, max_n: 5_000_101.0 };
        assert_eq!(m.files_over(&west), vec!["tiles/0_0.tif".to_owned()]);
        assert!(m.files_over(&north).is_empty(), "rows 0–1 hold no source");
        // Written again and parsed again: the same mosaic.
        let again = VrtMosaic::parse("again", &m.to_xml(|p| Some((p.to_owned(), true)))).unwrap();
        assert_eq!(again, m);
        let west_only = String::from_utf8(m.to_xml(|p| (p == "tiles/0_0.tif").then(|| ("/d/0.tif".into(), false))));
        let west_only = west_only.unwrap();
        assert!(west_only.contains("relativeToVRT=\"0\">/d/0.tif<") && !west_only.contains("a&amp;b"), "{west_only}");
    }

    const SRC: &str = "relativeToVRT=\"1\" shared=\"0\">tiles/0_0.tif";

    #[test]
    fn anything_that_reads_more_than_files_beside_the_vrt_is_refused_by_name() {
        let cases: [(&str, &str, &str); 11] = [
            (SRC, "relativeToVRT=\"0\">/etc/passwd", "not relative to the VRT"),
            (SRC, "relativeToVRT=\"1\">../../etc/passwd", "`..` segment"),
            (SRC, "relativeToVRT=\"1\">/vsicurl/http://127.0.0.1/x", "leading /"),
            (SRC, "relativeToVRT=\"1\">x:/y.tif", "plain relative path"),
            (SRC, "relativeToVRT=\"1\">tiles//0.tif", "empty"),
            ("SimpleSource>", "KernelFilteredSource>", "<KernelFilteredSource> in band 1"),
            ("</SimpleSource>", "</SimpleSource><PixelFunctionType>x</PixelFunctionType>", "<PixelFunctionType>"),
            ("<NODATA>-9999</NODATA>", "<LUT>0:0,1:255</LUT>", "<LUT> in band 1, source 1"),
            ("dataType=\"Float32\" band=\"1\"", "dataType=\"Float32\" subClass=\"VRTDerivedRasterBand\"", "Derived"),
            ("<VRTDataset ", "<VRTDataset subClass=\"VRTWarpedDataset\" ", "VRTWarpedDataset"),
            ("<SourceBand>1</SourceBand>", "<SourceBand>mask,1</SourceBand>", "not a band number"),
        ];
        for (from, to, expected) in cases {
            assert!(GOOD.contains(from), "{from}");
            let e = VrtMosaic::parse("s3://b/a/m.vrt", GOOD.replace(from, to).as_bytes()).unwrap_err();
            let e = e.to_string();
            assert!(e.starts_with("s3://b/a/m.vrt: ") && e.contains(expected), "{to}: {e}");
        }
        let doctype = format!("<!DOCTYPE x [<!ENTITY e SYSTEM \"file:///etc/passwd\">]>{}", &GOOD[22..]);
        assert!(VrtMosaic::parse("m", doctype.as_bytes()).unwrap_err().to_string().contains("DOCTYPE"));
        let entity = GOOD.replace("tiles/a&amp;b.tif", "&e;");
        assert!(VrtMosaic::parse("m", entity.as_bytes()).unwrap_err().to_string().contains("unknown entity &e;"));
        for bad in ["", "<a/>", "<VRTDataset/>", "<VRTDataset rasterXSize=\"1\"", "not xml", "<VRTDataset><x></y>"] {
            assert!(VrtMosaic::parse("m", bad.as_bytes()).is_err(), "{bad}");
        }
        let deep = format!("{}{}", "<a>".repeat(100), "</a>".repeat(100));
        assert!(VrtMosaic::parse("m", deep.as_bytes()).unwrap_err().to_string().contains("levels"));
    }

    #[test]
    fn xml_is_recognised_behind_a_bom_white_space_and_comments() {
        assert!(is_xml(b"\xEF\xBB\xBF  <!-- hi --><VRTDataset"));
        assert!(is_xml(b"\n<VRTDataset"));
        assert!(!is_xml(b"II*\0") && !is_xml(b"") && !is_xml(b"   "));
    }
}
