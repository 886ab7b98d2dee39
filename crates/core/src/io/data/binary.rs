//! The f64le record layout: seven little-endian IEEE-754 doubles in the
//! order `t,dthx,dthy,dthz,dvx,dvy,dvz`, and with `"temperature_column":
//! true` in the metadata an eighth, `temp_c`.

use crate::record::Record;

use super::layout::MAX_COLUMNS;

/// Values in a record.
pub(crate) const VALUES: usize = 7;
/// Bytes in a record.
pub const RECORD_BYTES: usize = VALUES * 8;
/// Bytes in a record that carries the temperature.
pub const RECORD_BYTES_WITH_TEMPERATURE: usize = (VALUES + 1) * 8;

/// Decodes one record's values: as many as `bytes` holds whole (7 or 8).
#[inline]
pub(crate) fn decode(bytes: &[u8]) -> [f64; MAX_COLUMNS] {
    let mut values = [0.0; MAX_COLUMNS];
    for (value, raw) in values.iter_mut().zip(bytes.chunks_exact(8)) {
        let mut word = [0u8; 8];
        word.copy_from_slice(raw);
        *value = f64::from_le_bytes(word);
    }
    values
}

/// Encodes a record in file order.
#[inline]
pub(crate) fn encode(record: &Record) -> [u8; RECORD_BYTES] {
    let values = [
        record.t,
        record.dtheta[0],
        record.dtheta[1],
        record.dtheta[2],
        record.dv[0],
        record.dv[1],
        record.dv[2],
    ];
    let mut out = [0u8; RECORD_BYTES];
    for (raw, value) in out.chunks_exact_mut(8).zip(values) {
        raw.copy_from_slice(&value.to_le_bytes());
    }
    out
}

/// Encodes a record and its temperature in file order.
#[inline]
pub(crate) fn encode_with_temperature(
    record: &Record,
    temp_c: f64,
) -> [u8; RECORD_BYTES_WITH_TEMPERATURE] {
    let mut out = [0u8; RECORD_BYTES_WITH_TEMPERATURE];
    out[..RECORD_BYTES].copy_from_slice(&encode(record));
    out[RECORD_BYTES..].copy_from_slice(&temp_c.to_le_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_little_endian_in_header_order() {
        let record = Record {
            t: 1.0,
            dtheta: [2.0, 3.0, 4.0],
            dv: [5.0, 6.0, -0.0],
        };
        let bytes = encode(&record);
        // 1.0 is 0x3ff0_0000_0000_0000: its high byte comes last.
        assert_eq!(&bytes[..8], &[0, 0, 0, 0, 0, 0, 0xf0, 0x3f]);
        assert_eq!(&bytes[48..], &[0, 0, 0, 0, 0, 0, 0, 0x80]);
        let values = decode(&bytes);
        assert_eq!(values[..7], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, -0.0]);
        assert!(values[6].is_sign_negative());
        let values = decode(&encode_with_temperature(&record, 31.25));
        assert_eq!(values, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, -0.0, 31.25]);
    }
}
