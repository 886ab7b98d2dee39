//! The text of one CSV line: comment, header or record (SPEC §5).
//!
//! Everything here works on the bytes of one line without its `\n`, and
//! allocates nothing on the record path.

use crate::record::DataKind;

use super::layout::{
    COUNT_COLUMNS, INCREMENT_COLUMNS, MAX_COLUMNS, RATE_COLUMNS, TEMPERATURE_COLUMN,
};

/// The UTF-8 byte-order mark some spreadsheet programs put first.
pub(crate) const UTF8_BOM: &[u8] = b"\xef\xbb\xbf";

#[inline]
fn is_blank(b: u8) -> bool {
    b == b' ' || b == b'\t'
}

fn trim(mut s: &[u8]) -> &[u8] {
    while let [first, rest @ ..] = s {
        if !is_blank(*first) {
            break;
        }
        s = rest;
    }
    while let [rest @ .., last] = s {
        if !is_blank(*last) {
            break;
        }
        s = rest;
    }
    s
}

/// Drops the `\r` of a CRLF line end.
#[inline]
pub(crate) fn strip_cr(line: &[u8]) -> &[u8] {
    match line {
        [rest @ .., b'\r'] => rest,
        _ => line,
    }
}

/// True for blank lines and comments (`#` after optional blanks).
#[inline]
pub(crate) fn is_skippable(line: &[u8]) -> bool {
    match line.iter().find(|b| !is_blank(**b)) {
        None => true,
        Some(b) => *b == b'#',
    }
}

/// Why the first content line is not a header.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum HeaderError {
    /// It starts with a number: data came before any header.
    Missing,
    /// It is text, but not one of the accepted headers.
    Unknown,
}

/// Reads the header, which names the kind of data and whether a last
/// column `temp_c` follows (the second value). Names must match exactly;
/// blanks around them are allowed.
pub(crate) fn parse_header(line: &[u8]) -> Result<(DataKind, bool), HeaderError> {
    let matches = |names: &[&str; 7]| {
        let mut fields = line.split(|b| *b == b',').map(trim);
        if !names
            .iter()
            .all(|name| fields.next() == Some(name.as_bytes()))
        {
            return None;
        }
        match fields.next() {
            None => Some(false),
            Some(last) if last == TEMPERATURE_COLUMN.as_bytes() && fields.next().is_none() => {
                Some(true)
            }
            Some(_) => None,
        }
    };
    if let Some(temperature) = matches(&INCREMENT_COLUMNS) {
        Ok((DataKind::Increments, temperature))
    } else if let Some(temperature) = matches(&RATE_COLUMNS) {
        Ok((DataKind::Rates, temperature))
    } else if let Some(temperature) = matches(&COUNT_COLUMNS) {
        Ok((DataKind::Counts, temperature))
    } else {
        let first = line
            .split(|b| *b == b',')
            .map(trim)
            .next()
            .unwrap_or_default();
        if fast_float2::parse::<f64, _>(first).is_ok() {
            Err(HeaderError::Missing)
        } else {
            Err(HeaderError::Unknown)
        }
    }
}

/// Why a record line did not give its numbers.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum FieldError {
    /// The line has this many comma-separated fields, not the header's.
    ColumnCount(usize),
    /// The field at this 0-based column is not a decimal number.
    NotNumeric(usize),
}

/// Number of comma-separated fields.
pub(crate) fn count_fields(line: &[u8]) -> usize {
    memchr::memchr_iter(b',', line).count() + 1
}

/// The text of the field at 0-based `column`, without surrounding blanks.
pub(crate) fn field(line: &[u8], column: usize) -> &[u8] {
    line.split(|b| *b == b',')
        .nth(column)
        .map(trim)
        .unwrap_or_default()
}

/// Decides what to report once parsing stopped at `column`: a wrong column
/// count explains more than the first field that failed because of it.
#[cold]
fn field_error(line: &[u8], column: usize, columns: usize) -> FieldError {
    match count_fields(line) {
        n if n == columns => FieldError::NotNumeric(column),
        n => FieldError::ColumnCount(n),
    }
}

/// Parses the `columns` numbers (7, or 8 with `temp_c`) of a record line
/// into the first `columns` slots. Blanks around numbers are allowed.
/// `nan`, `inf` and overflowing numbers parse here and are left to the
/// finiteness check, so that the error can say why.
#[inline]
pub(crate) fn parse_values(line: &[u8], columns: usize) -> Result<[f64; MAX_COLUMNS], FieldError> {
    let mut values = [0.0; MAX_COLUMNS];
    let mut pos = 0;
    for (column, slot) in values[..columns].iter_mut().enumerate() {
        while pos < line.len() && is_blank(line[pos]) {
            pos += 1;
        }
        match fast_float2::parse_partial::<f64, _>(&line[pos..]) {
            Ok((value, used)) => {
                *slot = value;
                pos += used;
            }
            Err(_) => return Err(field_error(line, column, columns)),
        }
        while pos < line.len() && is_blank(line[pos]) {
            pos += 1;
        }
        if column + 1 < columns {
            if line.get(pos) == Some(&b',') {
                pos += 1;
            } else {
                return Err(field_error(line, column, columns));
            }
        } else if pos != line.len() {
            return Err(field_error(line, column, columns));
        }
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classifies_blank_and_comment_lines() {
        assert!(is_skippable(b""));
        assert!(is_skippable(b" \t "));
        assert!(is_skippable(b"# a comment"));
        assert!(is_skippable(b"  #indented"));
        assert!(!is_skippable(b"t,dthx"));
        assert!(!is_skippable(b"1,#"));
        assert_eq!(strip_cr(b"1,2\r"), b"1,2");
        assert_eq!(strip_cr(b"1,2"), b"1,2");
    }

    #[test]
    fn accepts_both_headers_with_blanks_and_nothing_else() {
        assert_eq!(
            parse_header(b"t,dthx,dthy,dthz,dvx,dvy,dvz"),
            Ok((DataKind::Increments, false))
        );
        assert_eq!(
            parse_header(b" t , wx,wy ,wz,\tfx,fy,fz "),
            Ok((DataKind::Rates, false))
        );
        assert_eq!(
            parse_header(b"t,dthx,dthy,dthz,dvx,dvy,dvz, temp_c"),
            Ok((DataKind::Increments, true))
        );
        assert_eq!(
            parse_header(b"t,wx,wy,wz,fx,fy,fz,temp_c"),
            Ok((DataKind::Rates, true))
        );
        for bad in [
            &b"t,dthx,dthy,dthz,dvx,dvy,dvz,temp"[..],
            b"t,dthx,dthy,dthz,dvx,dvy,dvz,temp_c,",
            b"t,dthx,dthy,dthz,dvx,dvy,dvz,temp_c,temp_c",
            b"t,temp_c,dthx,dthy,dthz,dvx,dvy,dvz",
        ] {
            assert_eq!(parse_header(bad), Err(HeaderError::Unknown));
        }
        assert_eq!(
            parse_header(b"t,dthx,dthy,dthz,dvx,dvy"),
            Err(HeaderError::Unknown)
        );
        assert_eq!(
            parse_header(b"t,dthx,dthy,dthz,dvx,dvy,dvz,"),
            Err(HeaderError::Unknown)
        );
        assert_eq!(
            parse_header(b"T,DTHX,DTHY,DTHZ,DVX,DVY,DVZ"),
            Err(HeaderError::Unknown)
        );
        assert_eq!(
            parse_header(b"t,wx,wy,wz,dvx,dvy,dvz"),
            Err(HeaderError::Unknown)
        );
        assert_eq!(parse_header(b"0.01,1,2,3,4,5,6"), Err(HeaderError::Missing));
        assert_eq!(parse_header(b" -1e-3 ,x"), Err(HeaderError::Missing));
    }

    #[test]
    fn parses_numbers_with_blanks_signs_and_exponents() {
        let v = parse_values(b" 0.01, -1.5e-6 ,+2,3.,.5,\t1E2 ,0", 7).expect("valid line");
        assert_eq!(v[..7], [0.01, -1.5e-6, 2.0, 3.0, 0.5, 100.0, 0.0]);
    }

    #[test]
    fn a_temperature_column_is_the_eighth_number() {
        let v = parse_values(b"0.01,1,2,3,4,5,6, 23.5", 8).expect("valid line");
        assert_eq!(v, [0.01, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 23.5]);
        assert_eq!(
            parse_values(b"0.01,1,2,3,4,5,6", 8),
            Err(FieldError::ColumnCount(7))
        );
        assert_eq!(
            parse_values(b"0.01,1,2,3,4,5,6,hot", 8),
            Err(FieldError::NotNumeric(7))
        );
    }

    #[test]
    fn non_finite_values_parse_for_the_finiteness_check() {
        let v = parse_values(b"1,nan,inf,-inf,1e400,0,0", 7).expect("parses");
        assert!(v[1].is_nan());
        assert_eq!(v[2], f64::INFINITY);
        assert_eq!(v[3], f64::NEG_INFINITY);
        assert_eq!(v[4], f64::INFINITY);
    }

    #[test]
    fn reports_the_column_count_before_a_bad_field() {
        assert_eq!(parse_values(b"1,2,3", 7), Err(FieldError::ColumnCount(3)));
        assert_eq!(
            parse_values(b"1,2,3,4,5,6,7,8", 7),
            Err(FieldError::ColumnCount(8))
        );
        assert_eq!(
            parse_values(b"1;2;3;4;5;6;7", 7),
            Err(FieldError::ColumnCount(1))
        );
        assert_eq!(parse_values(b"1,x,3", 7), Err(FieldError::ColumnCount(3)));
        assert_eq!(parse_values(b"", 7), Err(FieldError::ColumnCount(1)));
    }

    #[test]
    fn names_the_first_bad_field_when_the_count_is_right() {
        assert_eq!(
            parse_values(b"1,2,abc,4,5,6,7", 7),
            Err(FieldError::NotNumeric(2))
        );
        assert_eq!(
            parse_values(b"1,2,3,4,5,6,", 7),
            Err(FieldError::NotNumeric(6))
        );
        assert_eq!(
            parse_values(b"1,2,3,4,5,6,7 8", 7),
            Err(FieldError::NotNumeric(6))
        );
        assert_eq!(
            parse_values(b"1,2.5x,3,4,5,6,7", 7),
            Err(FieldError::NotNumeric(1))
        );
        assert_eq!(
            parse_values(b"1,0x10,3,4,5,6,7", 7),
            Err(FieldError::NotNumeric(1))
        );
        assert_eq!(field(b"1, 2.5x ,3", 1), b"2.5x");
        assert_eq!(field(b"1,2", 5), b"");
    }
}
