//! The CSV header: which column holds which trajectory field, in which unit.

use crate::formats::{FormatError, Horizontal, Quantity, UnitProblem};

/// The unit of a column whose header names none: seconds, metres, degrees.
fn default_unit(quantity: Quantity) -> Unit {
    match quantity {
        Quantity::Time => Unit::Second,
        Quantity::Length => Unit::Metre,
        Quantity::Angle => Unit::Degree,
    }
}

/// A unit a header may name in brackets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Unit {
    Second,
    Metre,
    Degree,
    Radian,
}

impl Unit {
    fn parse(symbol: &str) -> Option<Self> {
        match symbol {
            "s" => Some(Self::Second),
            "m" => Some(Self::Metre),
            "deg" => Some(Self::Degree),
            "rad" => Some(Self::Radian),
            _ => None,
        }
    }

    fn quantity(self) -> Quantity {
        match self {
            Self::Second => Quantity::Time,
            Self::Metre => Quantity::Length,
            Self::Degree | Self::Radian => Quantity::Angle,
        }
    }

    /// `value` (in `self`) expressed in `to`, a unit of the same quantity.
    pub(super) fn convert(self, value: f64, to: Unit) -> f64 {
        match (self, to) {
            (Self::Degree, Self::Radian) => value.to_radians(),
            (Self::Radian, Self::Degree) => value.to_degrees(),
            _ => value,
        }
    }
}

/// The trajectory fields a column can hold; the discriminant indexes [`Found::columns`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Field {
    Time,
    Easting,
    Northing,
    Latitude,
    Longitude,
    Height,
    Roll,
    Pitch,
    Heading,
    StdEasting,
    StdNorthing,
    StdHeight,
    StdRoll,
    StdPitch,
    StdHeading,
}

impl Field {
    const COUNT: usize = 15;
    const STD: [Field; 6] =
        [Self::StdEasting, Self::StdNorthing, Self::StdHeight, Self::StdRoll, Self::StdPitch, Self::StdHeading];

    /// The field a (case-insensitive) column name denotes; `azimuth` is NovAtel's spelling of heading.
    fn from_name(name: &str) -> Option<Self> {
        let field = match name.to_ascii_lowercase().as_str() {
            "time" => Self::Time,
            "easting" => Self::Easting,
            "northing" => Self::Northing,
            "latitude" => Self::Latitude,
            "longitude" => Self::Longitude,
            "height" => Self::Height,
            "roll" => Self::Roll,
            "pitch" => Self::Pitch,
            "heading" | "azimuth" => Self::Heading,
            "std_easting" => Self::StdEasting,
            "std_northing" => Self::StdNorthing,
            "std_height" => Self::StdHeight,
            "std_roll" => Self::StdRoll,
            "std_pitch" => Self::StdPitch,
            "std_heading" | "std_azimuth" => Self::StdHeading,
            _ => return None,
        };
        Some(field)
    }

    /// The documented column name.
    fn name(self) -> &'static str {
        match self {
            Self::Time => "time",
            Self::Easting => "easting",
            Self::Northing => "northing",
            Self::Latitude => "latitude",
            Self::Longitude => "longitude",
            Self::Height => "height",
            Self::Roll => "roll",
            Self::Pitch => "pitch",
            Self::Heading => "heading",
            Self::StdEasting => "std_easting",
            Self::StdNorthing => "std_northing",
            Self::StdHeight => "std_height",
            Self::StdRoll => "std_roll",
            Self::StdPitch => "std_pitch",
            Self::StdHeading => "std_heading",
        }
    }

    fn quantity(self) -> Quantity {
        match self {
            Self::Time => Quantity::Time,
            Self::Easting | Self::Northing | Self::Height | Self::StdEasting | Self::StdNorthing | Self::StdHeight => {
                Quantity::Length
            }
            _ => Quantity::Angle,
        }
    }
}

/// A recognised column: its position, its name as written (for messages), its unit.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Column {
    pub(super) index: usize,
    pub(super) name: String,
    pub(super) unit: Unit,
}

/// Where each field of a record is, resolved from the header.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Layout {
    pub(super) horizontal: Horizontal,
    pub(super) width: usize,
    pub(super) time: Column,
    /// Easting or longitude.
    pub(super) x: Column,
    /// Northing or latitude.
    pub(super) y: Column,
    pub(super) height: Column,
    /// Roll, pitch, heading.
    pub(super) attitude: [Column; 3],
    /// East, north, height, roll, pitch, heading σ.
    pub(super) std: Option<[Column; 6]>,
}

/// Parse the header cells; returns the layout and one warning per ignored column.
pub(super) fn parse(cells: &[&str], line: usize, input: &str) -> Result<(Layout, Vec<String>), FormatError> {
    let mut found: [Option<Column>; Field::COUNT] = std::array::from_fn(|_| None);
    let mut warnings = Vec::new();
    for (index, cell) in cells.iter().enumerate() {
        let Some((field, column)) = recognise(cell, index, line, input)? else {
            warnings.push(format!("{input} line {line}: column \"{cell}\" is not a trajectory column and is ignored"));
            continue;
        };
        if let Some(first) = &found[field as usize] {
            let (column, first) = (column.name, first.name.clone());
            return Err(FormatError::DuplicateColumn { input: input.to_owned(), line, column, first });
        }
        found[field as usize] = Some(column);
    }
    let header: Vec<String> = cells.iter().map(|c| (*c).to_owned()).collect();
    let layout = Found { columns: found, header, input }.into_layout()?;
    Ok((layout, warnings))
}

/// The field and column of one header cell, `None` for a column plumbline does not read.
fn recognise(cell: &str, index: usize, line: usize, input: &str) -> Result<Option<(Field, Column)>, FormatError> {
    let (name, unit) = split_unit(cell);
    let Some(field) = Field::from_name(name) else { return Ok(None) };
    let bad = |problem| FormatError::BadUnit { input: input.to_owned(), line, column: name.to_owned(), problem };
    let unit = check_unit(field.quantity(), unit, cell).map_err(bad)?;
    Ok(Some((field, Column { index, name: name.to_owned(), unit })))
}

/// `name[unit]` → (name, Some(bracket text with what follows)); no bracket → (name, None).
fn split_unit(cell: &str) -> (&str, Option<&str>) {
    match cell.split_once('[') {
        Some((name, rest)) => (name.trim(), Some(rest)),
        None => (cell.trim(), None),
    }
}

/// The unit of a column measuring `quantity`, from the text after `[` (or the default without one).
fn check_unit(quantity: Quantity, after_bracket: Option<&str>, cell: &str) -> Result<Unit, UnitProblem> {
    let Some(rest) = after_bracket else { return Ok(default_unit(quantity)) };
    let malformed = || UnitProblem::Malformed { cell: cell.to_owned() };
    let (symbol, tail) = rest.split_once(']').ok_or_else(malformed)?;
    if !tail.trim().is_empty() || symbol.contains('[') {
        return Err(malformed());
    }
    let symbol = symbol.trim();
    let unit =
        Unit::parse(symbol).ok_or_else(|| UnitProblem::Unknown { unit: symbol.to_owned(), expected: quantity })?;
    if unit.quantity() != quantity {
        return Err(UnitProblem::WrongQuantity { unit: symbol.to_owned(), is: unit.quantity(), expected: quantity });
    }
    Ok(unit)
}

/// The recognised columns, before checking that the required ones are there.
struct Found<'a> {
    columns: [Option<Column>; Field::COUNT],
    header: Vec<String>,
    input: &'a str,
}

impl Found<'_> {
    fn into_layout(mut self) -> Result<Layout, FormatError> {
        let horizontal = self.horizontal()?;
        let (x, y) = match horizontal {
            Horizontal::Projected => (self.take(Field::Easting)?, self.take(Field::Northing)?),
            Horizontal::Geographic => (self.take(Field::Longitude)?, self.take(Field::Latitude)?),
        };
        Ok(Layout {
            horizontal,
            width: self.header.len(),
            time: self.take(Field::Time)?,
            x,
            y,
            height: self.take(Field::Height)?,
            attitude: [self.take(Field::Roll)?, self.take(Field::Pitch)?, self.take(Field::Heading)?],
            std: self.std()?,
        })
    }

    fn has(&self, field: Field) -> bool {
        self.columns[field as usize].is_some()
    }

    fn horizontal(&self) -> Result<Horizontal, FormatError> {
        let projected = self.has(Field::Easting) || self.has(Field::Northing);
        let geographic = self.has(Field::Latitude) || self.has(Field::Longitude);
        match (projected, geographic) {
            (true, true) => Err(FormatError::AmbiguousPosition { input: self.input.to_owned() }),
            (true, false) => Ok(Horizontal::Projected),
            (false, true) => Ok(Horizontal::Geographic),
            (false, false) => {
                Err(FormatError::MissingPosition { input: self.input.to_owned(), header: self.header.clone() })
            }
        }
    }

    fn take(&mut self, field: Field) -> Result<Column, FormatError> {
        self.columns[field as usize].take().ok_or_else(|| FormatError::MissingColumn {
            input: self.input.to_owned(),
            column: field.name(),
            header: self.header.clone(),
        })
    }

    /// All six σ columns, none, or an error listing the missing ones.
    fn std(&mut self) -> Result<Option<[Column; 6]>, FormatError> {
        let missing: Vec<&'static str> = Field::STD.iter().filter(|f| !self.has(**f)).map(|f| f.name()).collect();
        match missing.len() {
            0 => Ok(Some(self.take_std()?)),
            6 => Ok(None),
            _ => Err(FormatError::PartialStd { input: self.input.to_owned(), missing }),
        }
    }

    fn take_std(&mut self) -> Result<[Column; 6], FormatError> {
        let [e, n, h, r, p, y] = Field::STD;
        Ok([self.take(e)?, self.take(n)?, self.take(h)?, self.take(r)?, self.take(p)?, self.take(y)?])
    }
}
