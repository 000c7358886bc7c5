//! True painted elements from CSV text (`id,kind,width_m,wkt`, as the simulator writes its
//! `truth/road_markings.csv` and as an agency's marking layer can be exported): columns are found by header
//! name, the WKT is a `LINESTRING (e n, e n, …)` in the map's CRS.

use thiserror::Error;

use crate::evaluate::TruthElement;
use crate::lines::LineKind;

/// A row of the markings CSV that cannot be read: its 1-based line, the field and what is wrong.
#[derive(Clone, Debug, Error, PartialEq)]
#[error("line {line}, {field}: {problem}")]
pub struct MarkingsCsvError {
    /// 1-based line of the text (the header is line 1).
    pub line: usize,
    /// The column (or `header`).
    pub field: &'static str,
    /// What is wrong.
    pub problem: String,
}

/// Read the elements of a markings CSV. Kinds `solid`, `dashed`, `stop_line` and `zebra_stripe` keep their
/// meaning; any other kind (`arrow`, symbols) becomes [`LineKind::Other`]. Blank lines are skipped; the first
/// bad row is reported.
pub fn parse_markings_csv(text: &str) -> Result<Vec<TruthElement>, MarkingsCsvError> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let err = |line: usize, field: &'static str, problem: String| MarkingsCsvError { line, field, problem };
    let Some((_, header)) = lines.next() else { return Ok(Vec::new()) };
    let names = split_row(header);
    let column = |name: &'static str| {
        names.iter().position(|n| n.trim() == name).ok_or_else(|| err(1, "header", format!("no column `{name}`")))
    };
    let (kind_at, width_at, wkt_at) = (column("kind")?, column("width_m")?, column("wkt")?);
    let id_at = names.iter().position(|n| n.trim() == "id");
    let mut out = Vec::new();
    for (index, row) in lines {
        let line = index + 1;
        let fields = split_row(row);
        let field = |at: usize, name: &'static str| {
            fields.get(at).map(|f| f.trim()).ok_or_else(|| err(line, name, "missing".to_owned()))
        };
        let kind = match field(kind_at, "kind")? {
            "solid" => LineKind::Solid,
            "dashed" => LineKind::Dashed,
            "stop_line" => LineKind::StopLine,
            "zebra_stripe" => LineKind::ZebraStripe,
            _ => LineKind::Other,
        };
        let width = field(width_at, "width_m")?;
        let width_m = width
            .parse::<f64>()
            .ok()
            .filter(|w| w.is_finite() && *w >= 0.0)
            .ok_or_else(|| err(line, "width_m", format!("`{width}` is not a width in metres")))?;
        let points = linestring(field(wkt_at, "wkt")?).map_err(|problem| err(line, "wkt", problem))?;
        // Without an `id` column (or with an empty id) a marking is named by its line.
        let id = id_at.and_then(|at| fields.get(at)).map(|f| f.trim()).filter(|f| !f.is_empty());
        let id = id.map_or_else(|| format!("line {line}"), str::to_owned);
        out.push(TruthElement { id, kind, points, width_m });
    }
    Ok(out)
}

/// The fields of one CSV row; a double-quoted field may hold commas and doubled quotes.
fn split_row(row: &str) -> Vec<String> {
    let (mut fields, mut cur, mut quoted) = (Vec::new(), String::new(), false);
    let mut chars = row.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => fields.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    fields.push(cur);
    fields
}

/// The vertices of a WKT `LINESTRING (x y, x y, …)` (a third coordinate is ignored); at least two.
fn linestring(wkt: &str) -> Result<Vec<[f64; 2]>, String> {
    let body = wkt
        .get(..10)
        .filter(|head| head.eq_ignore_ascii_case("LINESTRING"))
        .and_then(|_| wkt[10..].trim().strip_prefix('('))
        .and_then(|b| b.strip_suffix(')'))
        .ok_or_else(|| format!("`{wkt}` is not a WKT LINESTRING"))?;
    let points = body
        .split(',')
        .map(|v| {
            let mut xy = v.split_whitespace().map(str::parse::<f64>);
            match (xy.next(), xy.next()) {
                (Some(Ok(e)), Some(Ok(n))) if e.is_finite() && n.is_finite() => Ok([e, n]),
                _ => Err(format!("vertex `{}` is not two numbers", v.trim())),
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    if points.len() < 2 {
        return Err("a line needs at least two vertices".to_owned());
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_read_by_header_name_and_bad_rows_say_where() {
        let text = "id,kind,width_m,wkt\n\
                    s1.l0.d3,dashed,0.120,\"LINESTRING (10.000 20.000, 10.000 23.000)\"\n\
                    \n\
                    s1.to.arrow0,arrow,0.300,\"LINESTRING (1 2, 3 4, 5 6)\"\n";
        let got = parse_markings_csv(text).unwrap();
        assert_eq!(got.len(), 2);
        assert_eq!(
            got[0],
            TruthElement {
                id: "s1.l0.d3".into(),
                kind: LineKind::Dashed,
                points: vec![[10.0, 20.0], [10.0, 23.0]],
                width_m: 0.12
            }
        );
        assert_eq!((got[1].kind, got[1].points.len()), (LineKind::Other, 3));
        let moved = "wkt,width_m,kind\n\"LINESTRING(0 0,1 1)\",0.5,stop_line\n";
        assert_eq!(parse_markings_csv(moved).unwrap()[0].kind, LineKind::StopLine);
        assert_eq!(parse_markings_csv(moved).unwrap()[0].id, "line 2", "no id column: named by its line");
        let bad = parse_markings_csv("kind,width_m,wkt\nsolid,0.1,\"LINESTRING (0 0, 1 x)\"\n").unwrap_err();
        assert_eq!((bad.line, bad.field), (2, "wkt"));
        assert!(bad.to_string().starts_with("line 2, wkt: vertex `1 x`"));
        assert_eq!(parse_markings_csv("kind,wkt\n").unwrap_err().field, "header");
        assert_eq!(
            parse_markings_csv("kind,width_m,wkt\nsolid,-1,\"LINESTRING (0 0, 1 1)\"").unwrap_err().field,
            "width_m"
        );
        assert!(parse_markings_csv("").unwrap().is_empty());
    }
}
