//! A noise model held for a unit: its characterisation (a long static
//! recording, `sinscal noise --static`), stated once and used for each of
//! its calibrations, by the command line (`calibrate --noise FILE`,
//! `--noise-reference FILE`) and by the server (a unit's held model).
//!
//! Why a line holds one: from a single run a navigation-grade unit's gyro
//! ARW and bias instability lie under its pulse quantization at every τ a
//! dwell offers, so the run's own fit can trade one for the other, and the
//! two imply different σ for parameters seen over different times
//! (docs/FIGURES.md, "Real sensors"). A model held for the unit settles
//! that split for all its runs.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::options::{EstimateOptions, NoiseDensity};

/// The terms a held model may state: the estimator's noise model, by the
/// truth file's `noise` names in canonical units (SPEC §2, §2a). The
/// truth's simulation-only fields (vibration, jitter, gaps) are refused by
/// name, since the estimator would silently drop them.
pub const NOISE_TERMS: [&str; 8] = [
    "gyro_arw_deg_rt_h",
    "accel_vrw_ug_rt_hz",
    "gyro_bias_instability_deg_h",
    "accel_bias_instability_ug",
    "gyro_rrw_deg_h_rt_h",
    "accel_rw_ug_rt_h",
    "gyro_quantum_arcsec",
    "accel_quantum_mps",
];

/// The two white densities every noise model states.
const REQUIRED_TERMS: [&str; 2] = ["gyro_arw_deg_rt_h", "accel_vrw_ug_rt_hz"];

/// Why a stated noise model is refused, naming the term.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum NoiseTermsError {
    #[error("a noise model is a JSON object of its terms")]
    NotAnObject,
    #[error("\"{0}\" is not a term of the estimator's noise model (one of {terms})", terms = NOISE_TERMS.join(", "))]
    UnknownTerm(String),
    #[error("\"{name}\": {value} is not a finite number at least 0")]
    NotANonNegativeNumber { name: String, value: String },
    #[error("\"{0}\" is required and above 0")]
    MissingWhite(&'static str),
}

impl NoiseTermsError {
    /// The term the error names, when it names one.
    pub fn term(&self) -> Option<&str> {
        match self {
            NoiseTermsError::NotAnObject => None,
            NoiseTermsError::UnknownTerm(name) => Some(name),
            NoiseTermsError::NotANonNegativeNumber { name, .. } => Some(name),
            NoiseTermsError::MissingWhite(name) => Some(name),
        }
    }
}

/// Reads a stated noise model: a JSON object of [`NOISE_TERMS`], both
/// white densities present and above 0, every term a finite number ≥ 0.
pub fn parse_noise_terms(value: &Value) -> Result<NoiseDensity, NoiseTermsError> {
    let object = value.as_object().ok_or(NoiseTermsError::NotAnObject)?;
    for (name, v) in object {
        if !NOISE_TERMS.contains(&name.as_str()) {
            return Err(NoiseTermsError::UnknownTerm(name.clone()));
        }
        if !v.as_f64().is_some_and(|x| x.is_finite() && x >= 0.0) {
            return Err(NoiseTermsError::NotANonNegativeNumber {
                name: name.clone(),
                value: v.to_string(),
            });
        }
    }
    for name in REQUIRED_TERMS {
        if object.get(name).and_then(Value::as_f64).unwrap_or(0.0) <= 0.0 {
            return Err(NoiseTermsError::MissingWhite(name));
        }
    }
    // Every field was checked above to be a known term holding a number.
    Ok(serde_json::from_value(value.clone()).expect("checked noise terms deserialize"))
}

/// How a calibration uses a held model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeldNoiseUse {
    /// As the run's noise model, instead of measuring and fitting one
    /// (`calibrate --noise`): σ as a covariance analysis of that noise
    /// gives them.
    Given,
    /// As the reference the run's own fitted model is tested against
    /// (`calibrate --noise-reference`): the estimates are the fitted
    /// model's, the result says whether the unit still has the held noise.
    Reference,
}

impl HeldNoiseUse {
    pub fn as_str(self) -> &'static str {
        match self {
            HeldNoiseUse::Given => "given",
            HeldNoiseUse::Reference => "reference",
        }
    }
}

impl std::str::FromStr for HeldNoiseUse {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "given" => Ok(HeldNoiseUse::Given),
            "reference" => Ok(HeldNoiseUse::Reference),
            other => Err(format!("\"{other}\" is not a use (given or reference)")),
        }
    }
}

/// The stored spelling read back (a database column).
impl TryFrom<String> for HeldNoiseUse {
    type Error = String;

    fn try_from(s: String) -> Result<Self, Self::Error> {
        s.parse()
    }
}

/// A unit's held noise model and how its calibrations use it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldNoise {
    pub noise: NoiseDensity,
    pub used_as: HeldNoiseUse,
}

impl HeldNoise {
    /// A held model read back from its stored text (the terms' JSON and
    /// the use's spelling), checked as when it was set.
    pub fn from_stored(noise_json: &str, used_as: &str) -> Result<HeldNoise, String> {
        let value: Value = serde_json::from_str(noise_json).map_err(|e| e.to_string())?;
        Ok(HeldNoise {
            noise: parse_noise_terms(&value).map_err(|e| e.to_string())?,
            used_as: used_as.parse()?,
        })
    }

    /// The options a calibration of the unit runs with: the held model put
    /// where its use says, the other slot left as the options had it.
    pub fn apply_to(&self, opts: &mut EstimateOptions) {
        match self.used_as {
            HeldNoiseUse::Given => opts.noise = Some(self.noise),
            HeldNoiseUse::Reference => opts.noise_reference = Some(self.noise),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_real_units_terms_are_read_in_canonical_units() {
        let d = parse_noise_terms(
            &json!({"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5,
            "gyro_bias_instability_deg_h": 0.0015, "gyro_quantum_arcsec": 1}),
        )
        .unwrap();
        assert_eq!(d.gyro_arw_deg_rt_h, 0.0003);
        assert_eq!(d.gyro_bias_instability_deg_h, 0.0015);
        assert_eq!(d.gyro_quantum_arcsec, 1.0);
        assert_eq!(d.accel_rw_ug_rt_h, 0.0);
    }

    #[test]
    fn a_misspelt_missing_or_negative_term_is_refused_by_name() {
        let white = json!({"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5});
        let with = |name: &str, v: Value| {
            let mut o = white.clone();
            o[name] = v;
            parse_noise_terms(&o).unwrap_err()
        };
        let e = with("gyro_bias_instabilty_deg_h", json!(1));
        assert_eq!(e.term(), Some("gyro_bias_instabilty_deg_h"));
        let e = with("vibration", json!({"rms_ug": 30}));
        assert!(e.to_string().contains("\"vibration\" is not a term"));
        let e = parse_noise_terms(&json!({"gyro_arw_deg_rt_h": 0.0003})).unwrap_err();
        assert_eq!(e, NoiseTermsError::MissingWhite("accel_vrw_ug_rt_hz"));
        let e = with("accel_rw_ug_rt_h", json!(-1));
        assert_eq!(e.term(), Some("accel_rw_ug_rt_h"));
        let e = with("gyro_arw_deg_rt_h", json!("0.0003"));
        assert_eq!(e.term(), Some("gyro_arw_deg_rt_h"));
        assert_eq!(
            parse_noise_terms(&json!([1, 2])),
            Err(NoiseTermsError::NotAnObject)
        );
    }

    #[test]
    fn a_held_model_goes_where_its_use_says() {
        let noise = NoiseDensity::white(0.0003, 5.0);
        let mut opts = EstimateOptions::default();
        HeldNoise {
            noise,
            used_as: HeldNoiseUse::Reference,
        }
        .apply_to(&mut opts);
        assert_eq!((opts.noise, opts.noise_reference), (None, Some(noise)));
        let mut opts = EstimateOptions::default();
        HeldNoise {
            noise,
            used_as: HeldNoiseUse::Given,
        }
        .apply_to(&mut opts);
        assert_eq!((opts.noise, opts.noise_reference), (Some(noise), None));
        assert_eq!("reference".parse(), Ok(HeldNoiseUse::Reference));
        assert!("both".parse::<HeldNoiseUse>().is_err());
    }
}
