//! What a design must reach: a 1-σ goal per parameter, canonical units.

use std::collections::BTreeMap;

use crate::model::params::paper_accuracy;
use crate::model::PARAMETERS;

/// Per-parameter accuracy targets (canonical units, `PARAMETERS` order).
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    pub name: String,
    pub accuracy: Vec<f64>,
}

/// A target file names a parameter that does not exist, or gives a value
/// that is not a positive number.
#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    #[error("target: unknown parameter {0:?}")]
    Unknown(String),
    #[error("target: {name} must be a positive number, got {value}")]
    NotPositive { name: String, value: f64 },
    #[error("target: {0}")]
    Json(#[from] serde_json::Error),
}

impl Target {
    /// The seed paper's Table 1 accuracy for every parameter.
    pub fn table1() -> Target {
        Target {
            name: "table1".into(),
            accuracy: PARAMETERS.iter().map(|p| paper_accuracy(p.group)).collect(),
        }
    }

    /// A JSON object of accuracies by canonical parameter name; parameters
    /// it leaves out keep their Table 1 value.
    pub fn from_json(name: &str, text: &[u8]) -> Result<Target, TargetError> {
        Target::from_accuracies(name, serde_json::from_slice(text)?)
    }

    /// Accuracies by canonical parameter name; parameters left out keep
    /// their Table 1 value.
    pub fn from_accuracies(
        name: &str,
        given: BTreeMap<String, f64>,
    ) -> Result<Target, TargetError> {
        let mut t = Target::table1();
        t.name = name.to_string();
        for (key, value) in given {
            let i = PARAMETERS
                .iter()
                .position(|p| p.name == key)
                .ok_or_else(|| TargetError::Unknown(key.clone()))?;
            if !(value.is_finite() && value > 0.0) {
                return Err(TargetError::NotPositive { name: key, value });
            }
            t.accuracy[i] = value;
        }
        Ok(t)
    }

    /// The target with every accuracy divided by `factor` (a tighter goal).
    pub fn tightened(&self, factor: f64) -> Target {
        Target {
            name: format!("{} / {factor}", self.name),
            accuracy: self.accuracy.iter().map(|a| a / factor).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_overrides_only_what_it_names() {
        let t = Target::from_json("f", br#"{"gyro_bias_x": 0.001}"#).unwrap();
        assert_eq!(t.accuracy[0], 0.001);
        assert_eq!(t.accuracy[1], Target::table1().accuracy[1]);
        let e = Target::from_json("f", br#"{"gyro_bias_q": 1}"#).unwrap_err();
        assert!(e.to_string().contains("gyro_bias_q"), "{e}");
        let e = Target::from_json("f", br#"{"gyro_bias_x": -1}"#).unwrap_err();
        assert!(e.to_string().contains("positive"), "{e}");
    }
}
