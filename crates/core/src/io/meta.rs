//! The JSON documents beside a run's data (SPEC §5): run metadata and the
//! simulator's truth.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::data::{CountsConversion, DataFormat};
use crate::model::thermal::PLAUSIBLE_C;
use crate::model::{Effects, ErrorParameters, TemperatureHistory, ThermalTruth};
use crate::nav::Site;
use crate::sim::{BiasMean, Noise, SchemeRef, SimConfig};

/// Errors reading or checking a JSON document.
#[derive(Debug, thiserror::Error)]
pub enum MetaError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Malformed JSON or a field of the wrong type; serde's message names
    /// the line and column.
    #[error("{what}: {source}")]
    Json {
        what: String,
        #[source]
        source: serde_json::Error,
    },
    #[error("{what}: {message}")]
    Invalid { what: String, message: String },
}

/// Longest accepted unit serial.
pub const MAX_SERIAL_LEN: usize = 64;

/// Checks a unit serial: 1–64 characters, letters, digits, `-`, `_`, `.`,
/// starting with a letter or digit (so it can never be `.` or `..`).
pub fn validate_serial(serial: &str) -> Result<(), String> {
    validate_name("unit_serial", serial)
}

/// Checks a product type's name (metadata `product`, the API's
/// `/product-types/{name}`): the rule of a unit serial, since it too
/// becomes a path segment.
pub fn validate_product(name: &str) -> Result<(), String> {
    validate_name("product", name)
}

fn validate_name(what: &str, name: &str) -> Result<(), String> {
    let ok_char = |c: char| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.');
    if name.is_empty() || name.len() > MAX_SERIAL_LEN {
        return Err(format!(
            "{what} must be 1 to {MAX_SERIAL_LEN} characters, got {}",
            name.len()
        ));
    }
    if let Some(bad) = name.chars().find(|c| !ok_char(*c)) {
        return Err(format!(
            "{what} {name:?} contains {bad:?}: only letters, digits, '-', '_' and '.' are allowed"
        ));
    }
    if !name.starts_with(|c: char| c.is_ascii_alphanumeric()) {
        return Err(format!("{what} {name:?} must start with a letter or digit"));
    }
    Ok(())
}

fn check_rate(rate: f64) -> Result<(), String> {
    if rate.is_finite() && rate > 0.0 && rate <= 100_000.0 {
        Ok(())
    } else {
        Err(format!("sample_rate_hz {rate} must be in (0, 100000]"))
    }
}

/// A run's metadata.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunMetadata {
    pub unit_serial: String,
    pub sample_rate_hz: f64,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub height_m: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity_mps2: Option<f64>,
    #[serde(default)]
    pub format: DataFormat,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scheme: Option<SchemeRef>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub station: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operator: Option<String>,
    /// RFC 3339 time of recording, kept as given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recorded_at: Option<String>,
    /// A soaked run's temperature, °C (SPEC §3a).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
    /// f64le: each record has an 8th value, the unit's temperature `temp_c`
    /// (SPEC §5). A CSV file's header says so for itself.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub temperature_column: bool,
    /// A run of raw outputs (a CSV `counts` header): each channel's
    /// nominal offset and weight (SPEC §5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub counts: Option<CountsConversion>,
    /// The product type the unit is built to (its acceptance limits are
    /// the server's product type of this name).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub product: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub notes: Option<String>,
    /// Fields this version does not know, kept so nothing a station sent
    /// is lost.
    #[serde(flatten)]
    pub extra: BTreeMap<String, serde_json::Value>,
}

impl RunMetadata {
    /// `recorded_at` in milliseconds since the epoch, or why it is not
    /// RFC 3339.
    pub fn recorded_at_ms(&self) -> Result<Option<i64>, String> {
        self.recorded_at
            .as_deref()
            .map(|t| {
                chrono::DateTime::parse_from_rfc3339(t)
                    .map(|d| d.timestamp_millis())
                    .map_err(|e| format!("recorded_at {t:?} is not RFC 3339: {e}"))
            })
            .transpose()
    }

    pub fn site(&self) -> Site {
        Site {
            gravity_mps2: self.gravity_mps2,
            ..Site::new(self.latitude_deg, self.longitude_deg, self.height_m)
        }
    }

    /// Checks every required field's value.
    pub fn validate(&self) -> Result<(), MetaError> {
        let invalid = |message: String| MetaError::Invalid {
            what: "metadata".into(),
            message,
        };
        validate_serial(&self.unit_serial).map_err(invalid)?;
        check_rate(self.sample_rate_hz).map_err(invalid)?;
        if let Some(product) = &self.product {
            validate_product(product).map_err(invalid)?;
        }
        self.site().validate().map_err(invalid)?;
        if let Some(t) = self.temperature_c {
            if !(t.is_finite() && PLAUSIBLE_C.contains(&t)) {
                return Err(invalid(format!(
                    "temperature_c {t} is outside {}..{} °C",
                    PLAUSIBLE_C.start(),
                    PLAUSIBLE_C.end()
                )));
            }
        }
        if let Some(c) = &self.counts {
            if self.format == DataFormat::F64le {
                return Err(invalid(
                    "counts: raw counts come in a CSV file with a `counts` header; an f64le \
                     run holds increments"
                        .into(),
                ));
            }
            if let Some(problem) = c.problem() {
                return Err(invalid(problem));
            }
        }
        if let Some(s) = &self.scheme {
            s.resolve(None)
                .map_err(|e| invalid(format!("scheme: {e}")))?;
        }
        Ok(())
    }

    /// Parses and validates metadata from JSON text.
    pub fn from_json(text: &[u8]) -> Result<Self, MetaError> {
        let m: RunMetadata = serde_json::from_slice(text).map_err(|source| MetaError::Json {
            what: "metadata".into(),
            source,
        })?;
        m.validate()?;
        Ok(m)
    }
}

/// The truth a simulator writes beside its run (SPEC §5), and the input of
/// `sinscal simulate --truth`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Truth {
    pub sample_rate_hz: f64,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub height_m: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity_mps2: Option<f64>,
    /// All 24 parameters by canonical name, canonical units.
    pub parameters: BTreeMap<String, f64>,
    #[serde(default)]
    pub noise: Noise,
    /// SPEC §2a: the run means of the wandering biases (instability and
    /// random walk) over every record from t = 0 to the end: what a
    /// calibration's bias is compared with, b + this. Written by the
    /// simulator after the records; an output, so a truth read back
    /// simulates the same run whatever it says here.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_mean_over_run: Option<BiasMean>,
    #[serde(default)]
    pub effects: Effects,
    #[serde(default)]
    pub initial_attitude_error_deg: [f64; 3],
    pub scheme: SchemeRef,
    #[serde(default)]
    pub seed: u64,
    /// SPEC §3a: how the parameters move with temperature.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thermal: Option<ThermalTruth>,
    /// SPEC §3a: the unit's temperature through the run (a bare number:
    /// a soak).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature: Option<TemperatureHistory>,
}

impl Truth {
    pub fn site(&self) -> Site {
        Site {
            gravity_mps2: self.gravity_mps2,
            ..Site::new(self.latitude_deg, self.longitude_deg, self.height_m)
        }
    }

    pub fn params(&self) -> Result<ErrorParameters, MetaError> {
        ErrorParameters::from_canonical(&self.parameters).map_err(|e| MetaError::Invalid {
            what: "truth".into(),
            message: e.to_string(),
        })
    }

    /// The simulation this truth describes. A scheme given by name takes
    /// the built-in's default dwell.
    pub fn to_sim_config(&self) -> Result<SimConfig, MetaError> {
        let invalid = |message: String| MetaError::Invalid {
            what: "truth".into(),
            message,
        };
        check_rate(self.sample_rate_hz).map_err(invalid)?;
        let scheme = self
            .scheme
            .resolve(None)
            .map_err(|e| invalid(format!("scheme: {e}")))?;
        Ok(SimConfig {
            site: self.site(),
            sample_rate_hz: self.sample_rate_hz,
            scheme,
            params: self.params()?,
            effects: self.effects,
            noise: self.noise.clone(),
            initial_attitude_error_deg: self.initial_attitude_error_deg,
            seed: self.seed,
            thermal: self.thermal,
            temperature: self.temperature.clone(),
        })
    }

    /// The truth of a simulation (the inverse of [`Truth::to_sim_config`]);
    /// the scheme is written out in full. `bias_mean_over_run` is left
    /// out: only the records give it (`Simulator::bias_mean_over_run`).
    pub fn from_sim_config(cfg: &SimConfig) -> Self {
        Truth {
            sample_rate_hz: cfg.sample_rate_hz,
            latitude_deg: cfg.site.latitude_deg,
            longitude_deg: cfg.site.longitude_deg,
            height_m: cfg.site.height_m,
            gravity_mps2: cfg.site.gravity_mps2,
            parameters: cfg.params.to_canonical(),
            noise: cfg.noise.clone(),
            bias_mean_over_run: None,
            effects: cfg.effects,
            initial_attitude_error_deg: cfg.initial_attitude_error_deg,
            scheme: SchemeRef::Inline(cfg.scheme.clone()),
            seed: cfg.seed,
            thermal: cfg.thermal,
            temperature: cfg.temperature.clone(),
        }
    }
}

/// Reads a JSON document from a file.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, MetaError> {
    let file = File::open(path).map_err(|source| MetaError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    serde_json::from_reader(BufReader::new(file)).map_err(|source| MetaError::Json {
        what: path.display().to_string(),
        source,
    })
}

/// Writes a JSON document to a file, pretty-printed.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), MetaError> {
    let io_err = |source| MetaError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut w = BufWriter::new(File::create(path).map_err(io_err)?);
    serde_json::to_writer_pretty(&mut w, value).map_err(|source| MetaError::Json {
        what: path.display().to_string(),
        source,
    })?;
    w.write_all(b"\n").map_err(io_err)?;
    w.flush().map_err(io_err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_metadata_example_parses() {
        let m = RunMetadata::from_json(
            br#"{"unit_serial": "RLG-0042", "sample_rate_hz": 100,
                "latitude_deg": 28.2215, "longitude_deg": 112.9924, "height_m": 50,
                "gravity_mps2": 9.79136, "format": "csv", "scheme": "ten-position",
                "station": "line-2/bay-4", "operator": "kim", "recorded_at": "2026-11-24T08:00:00Z",
                "temperature_c": 25.0, "notes": "first run", "fixture": "B7"}"#,
        )
        .unwrap();
        assert_eq!(m.site().gravity(), 9.79136);
        assert_eq!(m.extra["fixture"], "B7");
    }

    #[test]
    fn bad_serials_are_refused() {
        for bad in ["", "../etc", "RLG 42", "RLG/42", ".hidden", "é"] {
            assert!(validate_serial(bad).is_err(), "{bad:?}");
        }
        for good in ["RLG-0042", "u_1.2", "7"] {
            assert!(validate_serial(good).is_ok(), "{good:?}");
        }
        let err = RunMetadata::from_json(
            br#"{"unit_serial": "a/b", "sample_rate_hz": 100, "latitude_deg": 0, "longitude_deg": 0, "height_m": 0}"#,
        )
        .unwrap_err();
        assert!(err.to_string().contains("unit_serial"));
    }

    #[test]
    fn product_is_a_name_like_a_serial() {
        let meta = |product: &str| {
            format!(
                r#"{{"unit_serial": "A1", "sample_rate_hz": 100, "latitude_deg": 0,
                    "longitude_deg": 0, "height_m": 0, "product": {product}}}"#
            )
        };
        let m = RunMetadata::from_json(meta("\"SINS-90\"").as_bytes()).unwrap();
        assert_eq!(m.product.as_deref(), Some("SINS-90"));
        assert!(m.extra.is_empty());
        let err = RunMetadata::from_json(meta("\"a/b\"").as_bytes()).unwrap_err();
        assert!(err.to_string().contains("product"), "{err}");
        assert!(RunMetadata::from_json(meta("7").as_bytes()).is_err());
    }

    #[test]
    fn temperature_fields_are_checked() {
        let meta = |extra: &str| {
            format!(
                r#"{{"unit_serial": "A1", "sample_rate_hz": 100, "latitude_deg": 0,
                    "longitude_deg": 0, "height_m": 0{extra}}}"#
            )
        };
        let m = RunMetadata::from_json(meta("").as_bytes()).unwrap();
        assert!(!m.temperature_column);
        assert!(!serde_json::to_string(&m).unwrap().contains("temperature"));
        let m = RunMetadata::from_json(
            meta(r#", "format": "f64le", "temperature_column": true"#).as_bytes(),
        )
        .unwrap();
        assert!(m.temperature_column && m.extra.is_empty());
        let err = RunMetadata::from_json(meta(r#", "temperature_c": 350"#).as_bytes()).unwrap_err();
        assert!(err.to_string().contains("temperature_c"), "{err}");
        assert!(RunMetadata::from_json(meta(r#", "temperature_column": 1"#).as_bytes()).is_err());
    }

    #[test]
    fn a_truth_carries_its_thermal_model_and_temperature() {
        let text = r#"{"sample_rate_hz": 100, "latitude_deg": 28.2, "longitude_deg": 112.9,
            "height_m": 50, "parameters": {}, "scheme": "ten-position",
            "thermal": {"linear": {"gyro_bias_x": 0.001}, "gyro_bias_rate": [0.01, 0, 0]},
            "temperature": {"start_c": 10, "rate_c_per_min": 0.25, "max_c": 60}}"#;
        let truth: Truth = serde_json::from_str(text).unwrap();
        assert_eq!(truth.thermal.unwrap().linear(0), 0.001);
        let back: Truth = serde_json::from_value(serde_json::to_value(&truth).unwrap()).unwrap();
        assert_eq!(back, truth);
        let bad = text.replace("gyro_bias_x", "gyro_bias_q");
        assert!(serde_json::from_str::<Truth>(&bad).is_err());
    }

    #[test]
    fn missing_required_field_names_it() {
        let err =
            RunMetadata::from_json(br#"{"unit_serial": "A1", "sample_rate_hz": 100}"#).unwrap_err();
        assert!(err.to_string().contains("latitude_deg"), "{err}");
    }
}
