//! Errors of the trajectory formats: each names the input, where in it (line and column, or byte offset and
//! record) and what was found.

/// A defect in a trajectory file, or a trajectory that a format cannot hold.
///
/// `input` is the label the caller passed to the parser (usually the file name). Lines are 1-based,
/// records and byte offsets 0-based.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FormatError {
    /// The bytes are not UTF-8 text.
    #[error("{input} line {line}: not valid UTF-8 text")]
    NotUtf8 { input: String, line: usize },
    /// Only blank and comment lines: no header.
    #[error("{input}: no header line (the file is empty or holds only comments)")]
    NoHeader { input: String },
    /// A header column has a unit that is unknown or of the wrong quantity.
    #[error("{input} line {line}, column \"{column}\": {problem}")]
    BadUnit { input: String, line: usize, column: String, problem: UnitProblem },
    /// Two header columns hold the same field (e.g. `heading` and `azimuth`).
    #[error("{input} line {line}: column \"{column}\" holds the same field as column \"{first}\"")]
    DuplicateColumn { input: String, line: usize, column: String, first: String },
    /// A required column is absent.
    #[error("{input}: missing column \"{column}\"; header found: {}", header.join(", "))]
    MissingColumn { input: String, column: &'static str, header: Vec<String> },
    /// Neither projected nor geographic position columns.
    #[error(
        "{input}: no position columns (need easting,northing or latitude,longitude); header found: {}",
        header.join(", ")
    )]
    MissingPosition { input: String, header: Vec<String> },
    /// Both projected and geographic position columns: which one holds is ambiguous.
    #[error("{input}: both projected (easting/northing) and geographic (latitude/longitude) columns; keep one set")]
    AmbiguousPosition { input: String },
    /// Some but not all of the six standard-deviation columns.
    #[error("{input}: standard deviations need all six std_ columns or none; missing {}", missing.join(", "))]
    PartialStd { input: String, missing: Vec<&'static str> },
    /// A data line has a different number of fields than the header.
    #[error("{input} line {line}: {found} fields, but the header has {expected}")]
    FieldCount { input: String, line: usize, expected: usize, found: usize },
    /// A value does not parse as a number.
    #[error("{input} line {line}, column \"{column}\": \"{text}\" is not a number")]
    NotANumber { input: String, line: usize, column: String, text: String },
    /// A value is NaN or infinite (as written, or after unit conversion).
    #[error("{input} line {line}, column \"{column}\": \"{text}\" is not finite")]
    NotFinite { input: String, line: usize, column: String, text: String },
    /// A binary file ends inside a record.
    #[error(
        "{input}: truncated {format} record {index} at byte offset {offset}: \
         {present} of its {record_len} bytes present"
    )]
    Truncated { input: String, format: &'static str, index: usize, offset: usize, present: usize, record_len: usize },
    /// A binary file with no record at all.
    #[error("{input}: empty (0 bytes): no {format} record")]
    Empty { input: String, format: &'static str },
    /// A binary record's field holds a value the field cannot have (NaN, a latitude beyond ±90°, a negative σ).
    #[error("{input}: {format} record {index}, field `{field}`: {value} {problem}")]
    BadValue {
        input: String,
        format: &'static str,
        index: usize,
        field: &'static str,
        value: f64,
        problem: &'static str,
    },
    /// The format holds geographic coordinates only.
    #[error("{format} holds geographic coordinates (latitude/longitude), but the trajectory is projected")]
    NotGeographic { format: &'static str },
    /// An extra CSV column has a different length than the trajectory.
    #[error("extra column \"{column}\" has {found} values for {expected} records")]
    ColumnLength { column: String, expected: usize, found: usize },
    /// An extra CSV column name would break the header.
    #[error("extra column name {column:?} must be non-empty without ',', ';', '#' or line breaks")]
    BadColumnName { column: String },
}

/// Why a CSV header unit was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum UnitProblem {
    /// The bracket text is no known unit.
    #[error("unknown unit \"{unit}\"; use {}", expected.allowed())]
    Unknown { unit: String, expected: Quantity },
    /// A known unit of another quantity (`easting[deg]`).
    #[error("unit \"{unit}\" is {is}, but the column holds {expected}; use {}", expected.allowed())]
    WrongQuantity { unit: String, is: Quantity, expected: Quantity },
    /// Unbalanced brackets or text after the closing bracket.
    #[error("malformed unit in \"{cell}\"; write name[unit]")]
    Malformed { cell: String },
}

/// What a CSV column measures; it decides the units allowed in its header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// Seconds.
    Time,
    /// Metres.
    Length,
    /// Degrees or radians.
    Angle,
}

impl Quantity {
    /// The header units allowed for this quantity, as a hint.
    pub fn allowed(self) -> &'static str {
        match self {
            Self::Time => "[s]",
            Self::Length => "[m]",
            Self::Angle => "[deg] or [rad]",
        }
    }
}

impl std::fmt::Display for Quantity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Time => "a time",
            Self::Length => "a length",
            Self::Angle => "an angle",
        })
    }
}
