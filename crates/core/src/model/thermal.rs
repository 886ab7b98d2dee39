//! Temperature dependence of the error parameters (SPEC §3a): the thermal
//! truth a simulator generates with, and a unit's temperature history.
//!
//! ```text
//! p(T) = p + p1 ΔT + p2 ΔT²,   ΔT = T − 25 °C     (each of the 24 parameters)
//! b_g  gains  k Ṫ                                 (Ṫ in °C/min, k in deg/h per °C/min)
//! ```
//!
//! The coefficients are kept in canonical units (the JSON's), so a truth
//! written back is the truth that was read, bit for bit; SI is computed on
//! use.

use std::collections::BTreeMap;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::params::{index_of, ErrorParameters, N_PARAMS, PARAMETERS};
use super::units::DEG_PER_H;

/// The temperature the §2 parameters are stated at, °C.
pub const REFERENCE_C: f64 = 25.0;

/// Temperatures a unit can have, °C: anything outside is a fault of the
/// sensor or the file, not a chamber setting.
pub const PLAUSIBLE_C: std::ops::RangeInclusive<f64> = -100.0..=200.0;

/// Why a thermal truth or a temperature history is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ThermalError {
    #[error("thermal.{term}: unknown parameter {name:?}")]
    UnknownParameter { term: &'static str, name: String },
    #[error("thermal.{term}.{name} is not finite")]
    NotFinite { term: &'static str, name: String },
    #[error("thermal.gyro_bias_rate must be three finite numbers")]
    BiasRateNotFinite,
    #[error("temperature: {0}")]
    History(String),
}

/// The SPEC §3a thermal truth: per-parameter linear and quadratic
/// coefficients and the gyro bias against the rate of change of T.
/// A parameter absent from a term has a zero coefficient.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
#[serde(try_from = "ThermalJson", into = "ThermalJson")]
pub struct ThermalTruth {
    /// p1 per parameter in canonical order, canonical unit per °C.
    linear: [f64; N_PARAMS],
    /// p2 per parameter in canonical order, canonical unit per °C².
    quadratic: [f64; N_PARAMS],
    /// k, deg/h per (°C/min).
    gyro_bias_rate: [f64; 3],
}

/// The JSON form: `{"linear": {name: p1}, "quadratic": {name: p2},
/// "gyro_bias_rate": [kx, ky, kz]}`, every member optional.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ThermalJson {
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    linear: BTreeMap<String, f64>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    quadratic: BTreeMap<String, f64>,
    #[serde(default, skip_serializing_if = "is_zero3")]
    gyro_bias_rate: [f64; 3],
}

fn is_zero3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| *x == 0.0)
}

fn coefficients(
    term: &'static str,
    map: &BTreeMap<String, f64>,
) -> Result<[f64; N_PARAMS], ThermalError> {
    let mut out = [0.0; N_PARAMS];
    for (name, value) in map {
        let i = index_of(name).ok_or_else(|| ThermalError::UnknownParameter {
            term,
            name: name.clone(),
        })?;
        if !value.is_finite() {
            return Err(ThermalError::NotFinite {
                term,
                name: name.clone(),
            });
        }
        out[i] = *value;
    }
    Ok(out)
}

fn named(values: &[f64; N_PARAMS]) -> BTreeMap<String, f64> {
    PARAMETERS
        .iter()
        .zip(values)
        .filter(|(_, v)| **v != 0.0)
        .map(|(info, v)| (info.name.to_string(), *v))
        .collect()
}

impl TryFrom<ThermalJson> for ThermalTruth {
    type Error = ThermalError;

    fn try_from(j: ThermalJson) -> Result<Self, ThermalError> {
        ThermalTruth::from_canonical(&j.linear, &j.quadratic, j.gyro_bias_rate)
    }
}

impl From<ThermalTruth> for ThermalJson {
    fn from(m: ThermalTruth) -> Self {
        ThermalJson {
            linear: named(&m.linear),
            quadratic: named(&m.quadratic),
            gyro_bias_rate: m.gyro_bias_rate,
        }
    }
}

impl ThermalTruth {
    /// From coefficients by canonical name (canonical unit per °C and per
    /// °C²) and k in deg/h per (°C/min). Names are checked; absent names
    /// have zero coefficients.
    pub fn from_canonical(
        linear: &BTreeMap<String, f64>,
        quadratic: &BTreeMap<String, f64>,
        gyro_bias_rate: [f64; 3],
    ) -> Result<Self, ThermalError> {
        if !gyro_bias_rate.iter().all(|k| k.is_finite()) {
            return Err(ThermalError::BiasRateNotFinite);
        }
        Ok(ThermalTruth {
            linear: coefficients("linear", linear)?,
            quadratic: coefficients("quadratic", quadratic)?,
            gyro_bias_rate,
        })
    }

    /// True when no coefficient is set: the parameters do not move.
    pub fn is_zero(&self) -> bool {
        *self == Self::default()
    }

    /// p1 of parameter `i` (canonical order), canonical unit per °C.
    pub fn linear(&self, i: usize) -> f64 {
        self.linear[i]
    }

    /// p2 of parameter `i` (canonical order), canonical unit per °C².
    pub fn quadratic(&self, i: usize) -> f64 {
        self.quadratic[i]
    }

    /// k, deg/h per (°C/min).
    pub fn gyro_bias_rate(&self) -> [f64; 3] {
        self.gyro_bias_rate
    }

    /// The 24 parameters at `temperature_c`, from their values `at_25`
    /// at the reference temperature:
    ///
    /// ```text
    /// p_i(T) = p_i + (p1_i ΔT + p2_i ΔT²) · si_per_unit_i,   ΔT = T − 25
    /// ```
    pub fn params_at(&self, at_25: &ErrorParameters, temperature_c: f64) -> ErrorParameters {
        let d = temperature_c - REFERENCE_C;
        let mut out = *at_25;
        for (i, info) in PARAMETERS.iter().enumerate() {
            out.si[i] += (self.linear[i] * d + self.quadratic[i] * d * d) * info.si_per_unit;
        }
        out
    }

    /// The extra gyro bias k·Ṫ for `rate_c_per_min`, rad/s.
    pub fn gyro_bias_from_rate(&self, rate_c_per_min: f64) -> Vector3<f64> {
        Vector3::from(self.gyro_bias_rate) * (rate_c_per_min * DEG_PER_H)
    }

    /// The extra gyro angle over an interval in which T changed by
    /// `change_c`, rad. Exact whatever T(t) did inside it:
    ///
    /// ```text
    /// ∫ k Ṫ dt = k · DEG_PER_H · 60 s/min · (T(t_b) − T(t_a))
    /// ```
    ///
    /// (Ṫ is per minute, the integral runs over seconds.)
    pub fn gyro_angle_from_change(&self, change_c: f64) -> Vector3<f64> {
        Vector3::from(self.gyro_bias_rate) * (60.0 * DEG_PER_H * change_c)
    }
}

/// A unit's temperature through a run, t in seconds from the scheme's
/// start (SPEC §4's t = 0).
///
/// JSON: `{"start_c", "rate_c_per_min", "max_c"}` (a ramp from `start_c`
/// at `rate_c_per_min` until `max_c`, held after), `{"points": [[t_s,
/// T_c], ...]}` (linear between points, held outside them), or a bare
/// number: a soaked run at that temperature, whose run states it as
/// metadata `temperature_c` rather than as a column. (The bare number is
/// this project's; SPEC §3a names the first two forms.)
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "HistoryJson", into = "HistoryJson")]
pub enum TemperatureHistory {
    /// Constant, °C.
    Soak(f64),
    /// From `start_c` at `rate_c_per_min` until `max_c`, then held; before
    /// t = 0 the unit is at `start_c`. A negative rate cools towards a
    /// `max_c` below `start_c` (the SPEC's `max_c` read as where the ramp
    /// ends).
    Ramp {
        start_c: f64,
        rate_c_per_min: f64,
        max_c: f64,
    },
    /// `[t_s, T_c]`, times strictly increasing, at least one point.
    Points(Vec<[f64; 2]>),
}

#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum HistoryJson {
    Soak(f64),
    Ramp(RampJson),
    Points(PointsJson),
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RampJson {
    start_c: f64,
    rate_c_per_min: f64,
    max_c: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PointsJson {
    points: Vec<[f64; 2]>,
}

impl TryFrom<HistoryJson> for TemperatureHistory {
    type Error = ThermalError;

    fn try_from(j: HistoryJson) -> Result<Self, ThermalError> {
        let h = match j {
            HistoryJson::Soak(c) => TemperatureHistory::Soak(c),
            HistoryJson::Ramp(r) => TemperatureHistory::Ramp {
                start_c: r.start_c,
                rate_c_per_min: r.rate_c_per_min,
                max_c: r.max_c,
            },
            HistoryJson::Points(p) => TemperatureHistory::Points(p.points),
        };
        h.validate()?;
        Ok(h)
    }
}

impl From<TemperatureHistory> for HistoryJson {
    fn from(h: TemperatureHistory) -> Self {
        match h {
            TemperatureHistory::Soak(c) => HistoryJson::Soak(c),
            TemperatureHistory::Ramp {
                start_c,
                rate_c_per_min,
                max_c,
            } => HistoryJson::Ramp(RampJson {
                start_c,
                rate_c_per_min,
                max_c,
            }),
            TemperatureHistory::Points(points) => HistoryJson::Points(PointsJson { points }),
        }
    }
}

fn check_temperature(what: &str, c: f64) -> Result<(), ThermalError> {
    if c.is_finite() && PLAUSIBLE_C.contains(&c) {
        Ok(())
    } else {
        Err(ThermalError::History(format!(
            "{what} {c} °C is outside {}..{} °C",
            PLAUSIBLE_C.start(),
            PLAUSIBLE_C.end()
        )))
    }
}

impl TemperatureHistory {
    /// Checks that every temperature is plausible (a simulated run must be
    /// readable), the ramp heads towards `max_c`, and the points' times
    /// are finite and strictly increasing.
    pub fn validate(&self) -> Result<(), ThermalError> {
        let bad = |m: String| Err(ThermalError::History(m));
        match self {
            TemperatureHistory::Soak(c) => check_temperature("soak", *c),
            TemperatureHistory::Ramp {
                start_c,
                rate_c_per_min,
                max_c,
            } => {
                check_temperature("start_c", *start_c)?;
                check_temperature("max_c", *max_c)?;
                if !rate_c_per_min.is_finite() {
                    return bad("rate_c_per_min is not finite".into());
                }
                if (max_c - start_c) * rate_c_per_min < 0.0
                    || (*rate_c_per_min == 0.0 && max_c != start_c)
                {
                    return bad(format!(
                        "rate_c_per_min {rate_c_per_min} never takes {start_c} °C to max_c {max_c} °C"
                    ));
                }
                Ok(())
            }
            TemperatureHistory::Points(points) => {
                if points.is_empty() {
                    return bad("points is empty".into());
                }
                for (i, [t, c]) in points.iter().enumerate() {
                    if !t.is_finite() {
                        return bad(format!("points[{i}]: time {t} is not finite"));
                    }
                    check_temperature(&format!("points[{i}]:"), *c)?;
                }
                if let Some(i) = points.windows(2).position(|w| w[1][0] <= w[0][0]) {
                    return bad(format!(
                        "points[{}]: times must strictly increase ({} after {})",
                        i + 1,
                        points[i + 1][0],
                        points[i][0]
                    ));
                }
                Ok(())
            }
        }
    }

    /// The soak temperature, if the run is soaked.
    pub fn soak_c(&self) -> Option<f64> {
        match self {
            TemperatureHistory::Soak(c) => Some(*c),
            _ => None,
        }
    }

    /// T(t), °C.
    pub fn temperature_c(&self, t: f64) -> f64 {
        match self {
            TemperatureHistory::Soak(c) => *c,
            TemperatureHistory::Ramp {
                start_c,
                rate_c_per_min,
                max_c,
            } => {
                if *rate_c_per_min == 0.0 || t <= 0.0 {
                    return *start_c;
                }
                let c = start_c + rate_c_per_min * t / 60.0;
                if *rate_c_per_min > 0.0 {
                    c.min(*max_c)
                } else {
                    c.max(*max_c)
                }
            }
            TemperatureHistory::Points(points) => {
                let i = points.partition_point(|p| p[0] <= t);
                if i == 0 {
                    return points[0][1];
                }
                if i == points.len() {
                    return points[i - 1][1];
                }
                let ([t0, c0], [t1, c1]) = (points[i - 1], points[i]);
                c0 + (c1 - c0) * (t - t0) / (t1 - t0)
            }
        }
    }

    /// The first time after `t` where T(t) has a kink (a ramp starts or
    /// stops, a point), s.
    pub fn next_break_after(&self, t: f64) -> Option<f64> {
        match self {
            TemperatureHistory::Soak(_) => None,
            TemperatureHistory::Ramp {
                start_c,
                rate_c_per_min,
                max_c,
            } => {
                if *rate_c_per_min == 0.0 {
                    return None;
                }
                let end_s = (max_c - start_c) / rate_c_per_min * 60.0;
                [0.0, end_s].into_iter().find(|b| *b > t)
            }
            TemperatureHistory::Points(points) => points
                .get(points.partition_point(|p| p[0] <= t))
                .map(|p| p[0]),
        }
    }

    /// Ṫ(t), °C/min: the slope of the piece holding t, the piece that
    /// starts at t where two meet.
    pub fn rate_c_per_min(&self, t: f64) -> f64 {
        match self {
            TemperatureHistory::Soak(_) => 0.0,
            TemperatureHistory::Ramp {
                start_c,
                rate_c_per_min,
                max_c,
            } => {
                if *rate_c_per_min == 0.0 || t < 0.0 {
                    return 0.0;
                }
                let end_s = (max_c - start_c) / rate_c_per_min * 60.0;
                if t < end_s {
                    *rate_c_per_min
                } else {
                    0.0
                }
            }
            TemperatureHistory::Points(points) => {
                let i = points.partition_point(|p| p[0] <= t);
                if i == 0 || i == points.len() {
                    return 0.0;
                }
                let ([t0, c0], [t1, c1]) = (points[i - 1], points[i]);
                (c1 - c0) / (t1 - t0) * 60.0
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn history(json: &str) -> Result<TemperatureHistory, serde_json::Error> {
        serde_json::from_str(json)
    }

    #[test]
    fn spec_thermal_example_reads_and_writes_back() {
        let json = r#"{"linear": {"gyro_bias_x": 0.001, "accel_scale_z": -0.5},
                       "quadratic": {"accel_bias_y": 0.02}, "gyro_bias_rate": [0.01, 0, -0.02]}"#;
        let m: ThermalTruth = serde_json::from_str(json).unwrap();
        assert_eq!(m.linear(0), 0.001);
        assert_eq!(m.linear(index_of("accel_scale_z").unwrap()), -0.5);
        assert_eq!(m.quadratic(index_of("accel_bias_y").unwrap()), 0.02);
        let back: ThermalTruth = serde_json::from_value(serde_json::to_value(m).unwrap()).unwrap();
        assert_eq!(back, m);
        assert!(serde_json::from_str::<ThermalTruth>("{}")
            .unwrap()
            .is_zero());
    }

    #[test]
    fn unknown_names_and_fields_and_non_finite_rates_are_refused() {
        let err = serde_json::from_str::<ThermalTruth>(r#"{"linear": {"gyro_bias_w": 1}}"#)
            .unwrap_err()
            .to_string();
        assert!(err.contains("gyro_bias_w"), "{err}");
        assert!(serde_json::from_str::<ThermalTruth>(r#"{"cubic": {}}"#).is_err());
        let nan = f64::NAN;
        let map = BTreeMap::from([("gyro_scale_x".to_string(), nan)]);
        assert_eq!(
            ThermalTruth::from_canonical(&map, &BTreeMap::new(), [0.0; 3]),
            Err(ThermalError::NotFinite {
                term: "linear",
                name: "gyro_scale_x".into()
            })
        );
        assert_eq!(
            ThermalTruth::from_canonical(&BTreeMap::new(), &BTreeMap::new(), [0.0, nan, 0.0]),
            Err(ThermalError::BiasRateNotFinite)
        );
    }

    #[test]
    fn parameters_move_by_the_polynomial_in_canonical_units() {
        let m: ThermalTruth = serde_json::from_str(
            r#"{"linear": {"gyro_bias_x": 0.002, "accel_bias_z": 3},
                "quadratic": {"accel_bias_z": 0.1}}"#,
        )
        .unwrap();
        let p = ErrorParameters::paper();
        assert_eq!(m.params_at(&p, REFERENCE_C), p);
        let hot = m.params_at(&p, 45.0);
        let gx = hot.canonical(0) - p.canonical(0);
        assert!((gx - 0.04).abs() < 1e-12, "{gx}");
        let az = index_of("accel_bias_z").unwrap();
        let daz = hot.canonical(az) - p.canonical(az);
        assert!((daz - (60.0 + 40.0)).abs() < 1e-9, "{daz}");
        // One parameter untouched.
        assert_eq!(hot.si[5], p.si[5]);
    }

    #[test]
    fn the_rate_term_integrates_exactly_to_the_change_in_temperature() {
        let m = ThermalTruth::from_canonical(&BTreeMap::new(), &BTreeMap::new(), [1.0, 0.0, -2.0])
            .unwrap();
        // 0.5 °C/min for 120 s is 1 °C.
        let rate = m.gyro_bias_from_rate(0.5) * 120.0;
        let change = m.gyro_angle_from_change(1.0);
        assert!((rate - change).norm() < 1e-20);
        assert!((change.x - 60.0 * DEG_PER_H).abs() < 1e-18);
    }

    #[test]
    fn ramp_rises_then_holds_and_cools_when_asked() {
        let h = history(r#"{"start_c": 10, "rate_c_per_min": 0.25, "max_c": 60}"#).unwrap();
        assert_eq!(h.temperature_c(-5.0), 10.0);
        assert_eq!(h.temperature_c(0.0), 10.0);
        assert!((h.temperature_c(600.0) - 12.5).abs() < 1e-12);
        // 50 °C at 0.25 °C/min takes 200 min.
        assert_eq!(h.temperature_c(200.0 * 60.0 + 1.0), 60.0);
        assert_eq!(h.rate_c_per_min(600.0), 0.25);
        assert_eq!(h.rate_c_per_min(12_000.0), 0.0);
        assert_eq!(h.rate_c_per_min(-1.0), 0.0);
        assert_eq!(h.next_break_after(-1.0), Some(0.0));
        assert_eq!(h.next_break_after(0.0), Some(12_000.0));
        assert_eq!(h.next_break_after(12_000.0), None);
        let cool = history(r#"{"start_c": 40, "rate_c_per_min": -1, "max_c": 20}"#).unwrap();
        assert_eq!(cool.temperature_c(30.0 * 60.0), 20.0);
        assert!((cool.temperature_c(60.0) - 39.0).abs() < 1e-12);
        assert!(history(r#"{"start_c": 40, "rate_c_per_min": 1, "max_c": 20}"#).is_err());
        assert!(history(r#"{"start_c": 40, "rate_c_per_min": 0, "max_c": 20}"#).is_err());
        assert!(history(r#"{"start_c": 400, "rate_c_per_min": 1, "max_c": 500}"#).is_err());
    }

    #[test]
    fn points_interpolate_and_hold_outside() {
        let h = history(r#"{"points": [[100, 20], [700, 30], [1300, 30], [1900, 25]]}"#).unwrap();
        assert_eq!(h.temperature_c(0.0), 20.0);
        assert!((h.temperature_c(400.0) - 25.0).abs() < 1e-12);
        assert_eq!(h.temperature_c(1000.0), 30.0);
        assert_eq!(h.temperature_c(5000.0), 25.0);
        assert!((h.rate_c_per_min(400.0) - 1.0).abs() < 1e-12);
        assert_eq!(h.rate_c_per_min(700.0), 0.0);
        assert!((h.rate_c_per_min(1600.0) + 0.5).abs() < 1e-12);
        assert_eq!(h.rate_c_per_min(50.0), 0.0);
        assert_eq!(h.next_break_after(100.0), Some(700.0));
        assert_eq!(h.next_break_after(1900.0), None);
        for bad in [
            r#"{"points": []}"#,
            r#"{"points": [[0, 20], [0, 21]]}"#,
            r#"{"points": [[0, 20], [10, -150]]}"#,
            r#"{"points": [[0, 20]], "extra": 1}"#,
        ] {
            assert!(history(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_bare_number_is_a_soak() {
        let h = history("40").unwrap();
        assert_eq!(h.soak_c(), Some(40.0));
        assert_eq!(h.temperature_c(1e4), 40.0);
        assert_eq!(h.rate_c_per_min(1e4), 0.0);
        assert_eq!(serde_json::to_string(&h).unwrap(), "40.0");
        assert!(history("250").is_err());
    }
}
