//! Fixed-size records of little-endian `f64`, the layout shared by the Applanix binary files (SBET, smrmsg).

use super::FormatError;

/// Bytes of one `f64`.
const F64_LEN: usize = 8;

/// Split `bytes` into records of `N` little-endian `f64`; a trailing partial record is an error naming
/// its index and byte offset.
pub(crate) fn read_records<const N: usize>(
    bytes: &[u8],
    input: &str,
    format: &'static str,
) -> Result<Vec<[f64; N]>, FormatError> {
    let record_len = N * F64_LEN;
    let chunks = bytes.chunks_exact(record_len);
    let rest = chunks.remainder().len();
    if rest != 0 {
        let index = bytes.len() / record_len;
        let offset = index * record_len;
        return Err(FormatError::Truncated {
            input: input.to_owned(),
            format,
            index,
            offset,
            present: rest,
            record_len,
        });
    }
    Ok(chunks.map(decode).collect())
}

/// A check of one field of a binary record: its index, its name, the test, and what a failure means.
pub(crate) type FieldCheck = (usize, &'static str, fn(f64) -> bool, &'static str);

/// An empty file, or the first field of any record that fails its check, as an error naming record and field;
/// fields without a check are not looked at.
pub(crate) fn check_records<const N: usize>(
    records: &[[f64; N]],
    input: &str,
    format: &'static str,
    checks: &[FieldCheck],
) -> Result<(), FormatError> {
    if records.is_empty() {
        return Err(FormatError::Empty { input: input.to_owned(), format });
    }
    for (index, record) in records.iter().enumerate() {
        for &(i, field, ok, problem) in checks {
            let value = record[i];
            if !ok(value) {
                return Err(FormatError::BadValue { input: input.to_owned(), format, index, field, value, problem });
            }
        }
    }
    Ok(())
}

/// Encode records of `N` `f64` as little-endian bytes.
pub(crate) fn write_records<const N: usize>(records: impl ExactSizeIterator<Item = [f64; N]>) -> Vec<u8> {
    let mut out = Vec::with_capacity(records.len() * N * F64_LEN);
    for record in records {
        for value in record {
            out.extend_from_slice(&value.to_le_bytes());
        }
    }
    out
}

/// Decode one record; `chunk` is exactly `N * 8` bytes (from `chunks_exact`).
fn decode<const N: usize>(chunk: &[u8]) -> [f64; N] {
    std::array::from_fn(|i| {
        let mut b = [0u8; F64_LEN];
        b.copy_from_slice(&chunk[i * F64_LEN..(i + 1) * F64_LEN]);
        f64::from_le_bytes(b)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_and_truncation_names_the_offset() {
        let records = [[1.0, -2.5], [f64::MAX, 0.0]];
        let bytes = write_records(records.into_iter());
        assert_eq!(bytes.len(), 32);
        assert_eq!(read_records::<2>(&bytes, "x", "test").unwrap(), records);
        let err = read_records::<2>(&bytes[..21], "x", "test").unwrap_err();
        assert_eq!(err.to_string(), "x: truncated test record 1 at byte offset 16: 5 of its 16 bytes present");
        assert!(read_records::<2>(&[], "x", "test").unwrap().is_empty());
    }
}
