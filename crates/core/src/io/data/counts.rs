//! Raw outputs (SPEC §5 `counts` header, §2a): a run that holds what the
//! unit's interface gives, with the nominal offset and weight of each
//! channel in the metadata. The physical value is (count − offset) ×
//! weight; the 24 parameters are what is left after that conversion,
//! however large (a MEMS unit's datasheet offsets leave biases of a
//! degree per second).

use serde::{Deserialize, Serialize};

use super::layout::MAX_COLUMNS;
use crate::record::DataKind;

/// What a counts record holds before conversion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CountedKind {
    /// Pulse counts per record: weights in rad and m/s per count.
    Increments,
    /// Raw samples of rate and force: weights in rad/s and m/s² per count.
    Rates,
}

impl CountedKind {
    /// The kind of data the converted values are.
    pub fn data_kind(self) -> DataKind {
        match self {
            CountedKind::Increments => DataKind::Increments,
            CountedKind::Rates => DataKind::Rates,
        }
    }
}

/// One triad's nominal conversion: per axis, the count that reads zero and
/// the physical value of one count.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TriadConversion {
    pub offset: [f64; 3],
    pub weight: [f64; 3],
}

/// The metadata's `"counts"` object.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CountsConversion {
    pub kind: CountedKind,
    pub gyro: TriadConversion,
    pub accel: TriadConversion,
}

impl CountsConversion {
    /// Why the conversion cannot be used, naming the field: every offset
    /// finite, every weight finite and non-zero.
    pub fn problem(&self) -> Option<String> {
        for (triad, name) in [(&self.gyro, "gyro"), (&self.accel, "accel")] {
            for axis in 0..3 {
                let (o, w) = (triad.offset[axis], triad.weight[axis]);
                if !o.is_finite() {
                    return Some(format!("counts.{name}.offset[{axis}] is {o}, not finite"));
                }
                if !(w.is_finite() && w != 0.0) {
                    return Some(format!(
                        "counts.{name}.weight[{axis}] is {w}: a weight must be finite and \
                         non-zero"
                    ));
                }
            }
        }
        None
    }

    /// The physical values of a counts record's columns 1–6, in place
    /// (time and any temperature column are left as they are).
    #[inline]
    pub fn convert(&self, values: &mut [f64; MAX_COLUMNS]) {
        for axis in 0..3 {
            let g = &mut values[1 + axis];
            *g = (*g - self.gyro.offset[axis]) * self.gyro.weight[axis];
            let a = &mut values[4 + axis];
            *a = (*a - self.accel.offset[axis]) * self.accel.weight[axis];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn xsens_like() -> CountsConversion {
        CountsConversion {
            kind: CountedKind::Rates,
            gyro: TriadConversion {
                offset: [32768.0, 32466.0, 32485.0],
                weight: [1.0 / 4778.0, 1.0 / 4758.0, 1.0 / 4766.0],
            },
            accel: TriadConversion {
                offset: [33123.0, 33276.0, 32360.0],
                weight: [1.0 / 415.0, 1.0 / 413.0, 1.0 / 415.0],
            },
        }
    }

    #[test]
    fn a_count_becomes_its_offset_removed_times_its_weight() {
        let conv = xsens_like();
        let mut v = [
            0.5,
            32768.0,
            32466.0 + 4758.0,
            32485.0,
            33123.0,
            33276.0,
            36429.0,
            21.0,
        ];
        conv.convert(&mut v);
        assert_eq!(v[0], 0.5);
        assert_eq!(v[1], 0.0);
        assert!((v[2] - 1.0).abs() < 1e-12);
        assert!((v[6] - (36429.0 - 32360.0) / 415.0).abs() < 1e-12);
        assert_eq!(v[7], 21.0, "the temperature column is not a count");
    }

    #[test]
    fn the_metadata_object_reads_as_the_contract_writes_it() {
        let json = r#"{"kind": "rates",
            "gyro": {"offset": [32768, 32466, 32485], "weight": [2e-4, 2e-4, 2e-4]},
            "accel": {"offset": [33123, 33276, 32360], "weight": [0.0024, 0.0024, 0.0024]}}"#;
        let conv: CountsConversion = serde_json::from_str(json).unwrap();
        assert_eq!(conv.kind, CountedKind::Rates);
        assert_eq!(conv.problem(), None);
        let zero = CountsConversion {
            accel: TriadConversion {
                weight: [0.0024, 0.0, 0.0024],
                ..conv.accel
            },
            ..conv
        };
        assert!(zero.problem().unwrap().contains("counts.accel.weight[1]"));
    }
}
