//! A product type's acceptance limits: per canonical parameter (SPEC §2), an
//! optional bound on |value|, on σ and on repeatability, each in the
//! parameter's canonical unit. Read from JSON by [`ProductLimits::from_json`],
//! which names the field at fault.

use std::collections::BTreeMap;

use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize, Serializer};

use crate::model::{N_PARAMS, PARAMETERS};

/// Which bound of a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LimitKind {
    /// |value| of the run's estimate.
    MaxAbsValue,
    /// The estimator's own 1-σ of the run's estimate.
    MaxSigma,
    /// The sample standard deviation (n − 1) of the unit's estimates over
    /// its calibrated runs up to and including the run.
    MaxRepeatability,
}

impl LimitKind {
    pub const ALL: [LimitKind; 3] = [
        LimitKind::MaxAbsValue,
        LimitKind::MaxSigma,
        LimitKind::MaxRepeatability,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            LimitKind::MaxAbsValue => "max_abs_value",
            LimitKind::MaxSigma => "max_sigma",
            LimitKind::MaxRepeatability => "max_repeatability",
        }
    }
}

/// The bounds of one parameter; `None` is no bound.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ParameterLimits {
    pub max_abs_value: Option<f64>,
    pub max_sigma: Option<f64>,
    pub max_repeatability: Option<f64>,
}

impl ParameterLimits {
    pub fn get(&self, kind: LimitKind) -> Option<f64> {
        match kind {
            LimitKind::MaxAbsValue => self.max_abs_value,
            LimitKind::MaxSigma => self.max_sigma,
            LimitKind::MaxRepeatability => self.max_repeatability,
        }
    }

    fn slot(&mut self, kind: LimitKind) -> &mut Option<f64> {
        match kind {
            LimitKind::MaxAbsValue => &mut self.max_abs_value,
            LimitKind::MaxSigma => &mut self.max_sigma,
            LimitKind::MaxRepeatability => &mut self.max_repeatability,
        }
    }

    pub fn is_empty(&self) -> bool {
        LimitKind::ALL.iter().all(|k| self.get(*k).is_none())
    }
}

/// Why a limits document is refused, and where (a dotted path such as
/// `limits.gyro_bias_x.max_sigma`).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct LimitError {
    pub field: String,
    pub message: String,
}

/// A product type's limits, indexed in canonical parameter order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProductLimits {
    params: [ParameterLimits; N_PARAMS],
}

impl ProductLimits {
    /// The limits of parameter `i` (canonical index).
    pub fn of(&self, i: usize) -> &ParameterLimits {
        &self.params[i]
    }

    /// Sets one bound of a parameter by canonical name.
    pub fn set(&mut self, name: &str, kind: LimitKind, max: f64) -> Result<(), LimitError> {
        let field = format!("{name}.{}", kind.as_str());
        let i = index_of(name).ok_or_else(|| LimitError {
            field: name.to_string(),
            message: unknown_parameter(name),
        })?;
        check_bound(max).map_err(|message| LimitError { field, message })?;
        *self.params[i].slot(kind) = Some(max);
        Ok(())
    }

    /// Whether any parameter has a repeatability bound.
    pub fn limits_repeatability(&self) -> bool {
        self.params.iter().any(|p| p.max_repeatability.is_some())
    }

    pub fn is_empty(&self) -> bool {
        self.params.iter().all(ParameterLimits::is_empty)
    }

    /// Reads limits from JSON: an object of canonical parameter names, each
    /// an object of `max_abs_value`, `max_sigma`, `max_repeatability` (a
    /// number > 0, or null for none). Errors name the field under `at`
    /// (the document's own path, e.g. `limits`).
    pub fn from_json(value: &serde_json::Value, at: &str) -> Result<Self, LimitError> {
        let fail = |field: String, message: String| LimitError { field, message };
        let obj = value.as_object().ok_or_else(|| {
            fail(
                at.to_string(),
                "must be an object of parameter names".into(),
            )
        })?;
        let mut limits = ProductLimits::default();
        for (name, bounds) in obj {
            let here = format!("{at}.{name}");
            let i = index_of(name).ok_or_else(|| fail(here.clone(), unknown_parameter(name)))?;
            let bounds = bounds.as_object().ok_or_else(|| {
                fail(
                    here.clone(),
                    "must be an object of max_abs_value, max_sigma, max_repeatability".into(),
                )
            })?;
            for (key, v) in bounds {
                let field = format!("{here}.{key}");
                let kind = LimitKind::ALL
                    .into_iter()
                    .find(|k| k.as_str() == key)
                    .ok_or_else(|| {
                        fail(
                            field.clone(),
                            "unknown limit: max_abs_value, max_sigma or max_repeatability".into(),
                        )
                    })?;
                if v.is_null() {
                    continue;
                }
                let max = v
                    .as_f64()
                    .ok_or_else(|| fail(field.clone(), format!("must be a number, got {v}")))?;
                check_bound(max).map_err(|m| fail(field.clone(), m))?;
                *limits.params[i].slot(kind) = Some(max);
            }
        }
        Ok(limits)
    }
}

fn index_of(name: &str) -> Option<usize> {
    PARAMETERS.iter().position(|p| p.name == name)
}

fn unknown_parameter(name: &str) -> String {
    format!("unknown parameter {name:?}: limits name the 24 canonical parameters (SPEC §2)")
}

fn check_bound(max: f64) -> Result<(), String> {
    if max.is_finite() && max > 0.0 {
        Ok(())
    } else {
        Err(format!(
            "must be a finite number > 0 (in the parameter's canonical unit), got {max}"
        ))
    }
}

/// As JSON: the parameters with at least one bound, in canonical order,
/// each with its bounds (absent ones left out) — the form `from_json`
/// reads.
impl Serialize for ProductLimits {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let set: Vec<(usize, &ParameterLimits)> = self
            .params
            .iter()
            .enumerate()
            .filter(|(_, p)| !p.is_empty())
            .collect();
        let mut map = s.serialize_map(Some(set.len()))?;
        for (i, p) in set {
            let bounds: BTreeMap<&str, f64> = LimitKind::ALL
                .into_iter()
                .filter_map(|k| p.get(k).map(|v| (k.as_str(), v)))
                .collect();
            map.serialize_entry(PARAMETERS[i].name, &bounds)?;
        }
        map.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn limits_round_trip_in_canonical_order() {
        let doc = json!({
            "accel_bias_x": {"max_abs_value": 100.0, "max_repeatability": null},
            "gyro_bias_x": {"max_sigma": 0.002, "max_repeatability": 0.003},
        });
        let limits = ProductLimits::from_json(&doc, "limits").unwrap();
        assert_eq!(limits.of(0).max_sigma, Some(0.002));
        assert_eq!(limits.of(9).max_abs_value, Some(100.0));
        assert!(limits.limits_repeatability());
        let text = serde_json::to_string(&limits).unwrap();
        assert_eq!(
            text,
            r#"{"gyro_bias_x":{"max_repeatability":0.003,"max_sigma":0.002},"accel_bias_x":{"max_abs_value":100.0}}"#
        );
        let back = serde_json::from_str::<serde_json::Value>(&text).unwrap();
        assert_eq!(ProductLimits::from_json(&back, "limits").unwrap(), limits);
    }

    #[test]
    fn errors_name_the_field() {
        let err = |doc: serde_json::Value| ProductLimits::from_json(&doc, "limits").unwrap_err();
        let e = err(json!({"gyro_bias_q": {"max_sigma": 1.0}}));
        assert_eq!(e.field, "limits.gyro_bias_q");
        assert!(e.message.contains("unknown parameter"), "{e}");
        let e = err(json!({"gyro_bias_x": {"max_sigma": -1.0}}));
        assert_eq!(e.field, "limits.gyro_bias_x.max_sigma");
        assert!(e.message.contains("> 0"), "{e}");
        let e = err(json!({"gyro_bias_x": {"max_sigma": 0}}));
        assert_eq!(e.field, "limits.gyro_bias_x.max_sigma");
        let e = err(json!({"gyro_bias_x": {"max_value": 1.0}}));
        assert_eq!(e.field, "limits.gyro_bias_x.max_value");
        let e = err(json!({"gyro_bias_x": {"max_sigma": "1"}}));
        assert!(e.message.contains("number"), "{e}");
        let e = err(json!({"gyro_bias_x": 1.0}));
        assert_eq!(e.field, "limits.gyro_bias_x");
        let e = err(json!([1]));
        assert_eq!(e.field, "limits");
        assert_eq!(
            ProductLimits::default().set("nope", LimitKind::MaxSigma, 1.0),
            Err(LimitError {
                field: "nope".into(),
                message: unknown_parameter("nope")
            })
        );
    }
}
