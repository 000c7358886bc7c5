//! The small CSV tables a manifest points at: image indexes (`image_id,time,file`, for panoramas and depth
//! images) and the aerial block's exterior orientations (`image_id,file,x,y,z,omega_deg,phi_deg,kappa_deg`).
//!
//! Columns are found by header name (order free, extra columns ignored). A bad row does not sink the table:
//! it is skipped and reported with its file, line and field; a missing column or an unreadable header is an
//! error for the whole table.

use std::collections::HashSet;
use std::fmt;

use serde::{Deserialize, Serialize};

/// One row of an image index: which file holds the image taken at which time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexRow {
    /// Campaign-unique image id.
    pub image_id: String,
    /// Exposure time, in the trajectory's time system (seconds).
    pub time: f64,
    /// File name relative to the manifest's `images` prefix.
    pub file: String,
}

/// One row of an aerial exterior-orientation table (omega-phi-kappa in degrees, ARCHITECTURE.md conventions).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExteriorRow {
    /// Aerial image id.
    pub image_id: String,
    /// File name relative to the block's `images` prefix.
    pub file: String,
    /// Projection centre: easting, northing, height, metres.
    pub centre: [f64; 3],
    /// Omega, phi, kappa, degrees.
    pub opk_deg: [f64; 3],
}

/// A row that was skipped, or a table that could not be read, with where and why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RowProblem {
    /// The table's name as the caller gave it (usually its URL).
    pub file: String,
    /// 1-based line number (1 = header).
    pub line: usize,
    /// The column concerned, when one is.
    pub field: Option<String>,
    /// What is wrong.
    pub problem: String,
}

impl fmt::Display for RowProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.field {
            Some(field) => write!(f, "{} line {} field {}: {}", self.file, self.line, field, self.problem),
            None => write!(f, "{} line {}: {}", self.file, self.line, self.problem),
        }
    }
}

impl std::error::Error for RowProblem {}

/// The rows read from a table and the rows skipped.
#[derive(Clone, Debug, PartialEq)]
pub struct Table<R> {
    /// The good rows, in file order.
    pub rows: Vec<R>,
    /// One entry per skipped row.
    pub skipped: Vec<RowProblem>,
}

/// Read an image index. Rows with a bad time, an empty id or file, or a duplicate id are skipped.
pub fn read_index(name: &str, bytes: &[u8]) -> Result<Table<IndexRow>, RowProblem> {
    let sheet = Sheet::parse(name, bytes, &["image_id", "time", "file"])?;
    let mut seen = HashSet::new();
    Ok(sheet.rows(|row| {
        let image_id = row.text("image_id")?;
        let time = row.number("time")?;
        let file = row.text("file")?;
        if !seen.insert(image_id.clone()) {
            return Err(row.problem(Some("image_id"), format!("duplicate image id {image_id:?}")));
        }
        Ok(IndexRow { image_id, time, file })
    }))
}

/// Read an aerial exterior-orientation table.
pub fn read_exterior(name: &str, bytes: &[u8]) -> Result<Table<ExteriorRow>, RowProblem> {
    const COLUMNS: [&str; 8] = ["image_id", "file", "x", "y", "z", "omega_deg", "phi_deg", "kappa_deg"];
    let sheet = Sheet::parse(name, bytes, &COLUMNS)?;
    let mut seen = HashSet::new();
    Ok(sheet.rows(|row| {
        let image_id = row.text("image_id")?;
        let file = row.text("file")?;
        let centre = [row.number("x")?, row.number("y")?, row.number("z")?];
        let opk_deg = [row.number("omega_deg")?, row.number("phi_deg")?, row.number("kappa_deg")?];
        if !seen.insert(image_id.clone()) {
            return Err(row.problem(Some("image_id"), format!("duplicate image id {image_id:?}")));
        }
        Ok(ExteriorRow { image_id, file, centre, opk_deg })
    }))
}

/// A parsed CSV: header positions and the data lines.
struct Sheet<'a> {
    name: &'a str,
    columns: Vec<String>,
    lines: Vec<(usize, Vec<String>)>,
}

impl<'a> Sheet<'a> {
    fn parse(name: &'a str, bytes: &[u8], required: &[&str]) -> Result<Self, RowProblem> {
        let whole = |line, problem: String| RowProblem { file: name.to_owned(), line, field: None, problem };
        let text = std::str::from_utf8(bytes).map_err(|e| whole(1, format!("not UTF-8 text: {e}")))?;
        let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l)).filter(|(_, l)| !l.trim().is_empty());
        let (_, header) = lines.next().ok_or_else(|| whole(1, "empty file: expected a header line".into()))?;
        let columns: Vec<String> =
            split(header).map_err(|e| whole(1, e))?.into_iter().map(|c| c.to_lowercase()).collect();
        let missing: Vec<&str> = required.iter().copied().filter(|r| !columns.iter().any(|c| c == r)).collect();
        if !missing.is_empty() {
            return Err(whole(1, format!("missing column(s) {} (header: {header})", missing.join(", "))));
        }
        let mut data = Vec::new();
        for (number, line) in lines {
            // An unbalanced quote keeps the line with no cells so that the row reports it.
            data.push((number, split(line).unwrap_or_default()));
        }
        Ok(Self { name, columns, lines: data })
    }

    fn rows<R>(&self, mut read: impl FnMut(&Row<'_>) -> Result<R, RowProblem>) -> Table<R> {
        let mut table = Table { rows: Vec::new(), skipped: Vec::new() };
        for (line, cells) in &self.lines {
            let row = Row { sheet: self, line: *line, cells };
            let outcome = if cells.len() != self.columns.len() {
                let found = format!("{} cells where the header has {}", cells.len(), self.columns.len());
                Err(row.problem(None, found))
            } else {
                read(&row)
            };
            match outcome {
                Ok(r) => table.rows.push(r),
                Err(p) => table.skipped.push(p),
            }
        }
        table
    }
}

/// One data line of a sheet.
struct Row<'a> {
    sheet: &'a Sheet<'a>,
    line: usize,
    cells: &'a [String],
}

impl Row<'_> {
    fn problem(&self, field: Option<&str>, problem: String) -> RowProblem {
        RowProblem { file: self.sheet.name.to_owned(), line: self.line, field: field.map(str::to_owned), problem }
    }

    fn cell(&self, column: &str) -> Result<&str, RowProblem> {
        let i = self.sheet.columns.iter().position(|c| c == column);
        i.and_then(|i| self.cells.get(i)).map(|s| s.trim()).ok_or_else(|| self.problem(Some(column), "missing".into()))
    }

    fn text(&self, column: &str) -> Result<String, RowProblem> {
        let value = self.cell(column)?;
        if value.is_empty() {
            return Err(self.problem(Some(column), "empty".into()));
        }
        Ok(value.to_owned())
    }

    fn number(&self, column: &str) -> Result<f64, RowProblem> {
        let value = self.cell(column)?;
        match value.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.problem(Some(column), format!("{value:?} is not a finite number"))),
        }
    }
}

/// Split one CSV line into cells; double quotes protect commas, `""` is a quote inside quotes.
fn split(line: &str) -> Result<Vec<String>, String> {
    let mut cells = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        let cell = cells.last_mut().ok_or("internal: no cell")?;
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                cell.push('"');
            }
            ('"', _) => quoted = !quoted,
            (',', false) => cells.push(String::new()),
            _ => cell.push(c),
        }
    }
    if quoted {
        return Err("unbalanced double quote".into());
    }
    Ok(cells)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn reads_an_index_in_any_column_order_and_skips_bad_rows_with_their_line_and_field() {
        let text = "file,image_id,time,extra\n\
                    a.jpg,a,10.5,x\n\
                    b.jpg,b,not-a-time,x\n\
                    \n\
                    c.jpg,,12,x\n\
                    d.jpg,a,13,x\n\
                    e.jpg,e,14\n\
                    \"f,1.jpg\",f,15,x\n";
        let t = read_index("pano/index.csv", text.as_bytes()).unwrap();
        let ids: Vec<&str> = t.rows.iter().map(|r| r.image_id.as_str()).collect();
        assert_eq!(ids, ["a", "f"]);
        assert_eq!(t.rows[0].time, 10.5);
        assert_eq!(t.rows[1].file, "f,1.jpg");
        let lines: Vec<(usize, Option<&str>)> = t.skipped.iter().map(|p| (p.line, p.field.as_deref())).collect();
        assert_eq!(lines, [(3, Some("time")), (5, Some("image_id")), (6, Some("image_id")), (7, None)]);
        assert_eq!(t.skipped[0].to_string(), "pano/index.csv line 3 field time: \"not-a-time\" is not a finite number");
        assert!(t.skipped[2].problem.contains("duplicate"));
    }

    #[test]
    fn a_missing_column_or_an_empty_file_is_an_error_for_the_table() {
        let e = read_index("i.csv", b"image_id,file\na,a.jpg\n").unwrap_err();
        assert_eq!((e.line, e.field.as_deref()), (1, None));
        assert!(e.problem.contains("missing column(s) time"), "{e}");
        assert!(read_index("i.csv", b"").unwrap_err().problem.contains("empty"));
        assert!(read_index("i.csv", &[0xff, 0xfe]).unwrap_err().problem.contains("UTF-8"));
    }

    #[test]
    fn reads_exterior_orientations() {
        let text = "image_id,file,x,y,z,omega_deg,phi_deg,kappa_deg\n\
                    a0,a0.jpg,564793.6,5932847.5,1508.0,0.1,-0.2,90\n\
                    a1,a1.jpg,564841.6,5932847.5,1508.0,0.1,inf,90\n";
        let t = read_exterior("eo.csv", text.as_bytes()).unwrap();
        assert_eq!(t.rows.len(), 1);
        assert_eq!(t.rows[0].centre, [564793.6, 5932847.5, 1508.0]);
        assert_eq!(t.rows[0].opk_deg, [0.1, -0.2, 90.0]);
        assert_eq!((t.skipped[0].line, t.skipped[0].field.as_deref()), (3, Some("phi_deg")));
    }

    #[test]
    fn an_unbalanced_quote_skips_only_its_row() {
        let t = read_index("i.csv", b"image_id,time,file\n\"a,1,a.jpg\nb,2,b.jpg\n").unwrap();
        assert_eq!(t.rows.len(), 1);
        assert_eq!(t.skipped[0].line, 2);
    }

    /// Rows and skipped rows are at most one per line; a table error or a skipped row names the file.
    fn check<R>(bytes: &[u8], outcome: Result<Table<R>, RowProblem>) -> Result<(), TestCaseError> {
        match outcome {
            Ok(table) => {
                let lines = bytes.iter().filter(|b| **b == b'\n').count() + 1;
                prop_assert!(table.rows.len() + table.skipped.len() < lines);
                for p in &table.skipped {
                    prop_assert!(p.file == "in.csv" && p.line >= 2 && p.line <= lines, "{p}");
                    prop_assert!(p.to_string().starts_with("in.csv line "), "{p}");
                }
            }
            Err(e) => prop_assert!(e.file == "in.csv" && e.to_string().starts_with("in.csv line 1"), "{e}"),
        }
        Ok(())
    }

    const INDEX: &str = "image_id,time,file\na,10.5,a.jpg\nb,11,\"b,1.jpg\"\n\nc,12.25,c.jpg\n";
    const EXTERIOR: &str = "image_id,file,x,y,z,omega_deg,phi_deg,kappa_deg\n\
                            a0,a0.jpg,564793.6,5932847.5,1508.0,0.1,-0.2,90\n\
                            a1,a1.jpg,564841.6,5932847.5,1508.0,0.1,0.3,90\n";

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 256,
            rng_seed: proptest::test_runner::RngSeed::Fixed(21),
            ..ProptestConfig::default()
        })]

        #[test]
        fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..4096)) {
            check(&bytes, read_index("in.csv", &bytes))?;
            check(&bytes, read_exterior("in.csv", &bytes))?;
        }

        #[test]
        fn arbitrary_table_like_text_never_panics(body in "[a-z0-9_.,\"\r\n\u{e9} -]{0,4000}") {
            for header in ["image_id,time,file\n", "image_id,file,x,y,z,omega_deg,phi_deg,kappa_deg\n"] {
                let text = format!("{header}{body}");
                check(text.as_bytes(), read_index("in.csv", text.as_bytes()))?;
                check(text.as_bytes(), read_exterior("in.csv", text.as_bytes()))?;
            }
        }

        #[test]
        fn mutated_tables_read_or_name_the_file(edits in plumbline_testkit::mutation::edits()) {
            let index = plumbline_testkit::mutation::mutate(INDEX.as_bytes().to_vec(), &edits);
            check(&index, read_index("in.csv", &index))?;
            let exterior = plumbline_testkit::mutation::mutate(EXTERIOR.as_bytes().to_vec(), &edits);
            check(&exterior, read_exterior("in.csv", &exterior))?;
        }
    }
}
