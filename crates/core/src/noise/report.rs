//! NOISE.json: the noise terms of each sensor axis in reporting units, the
//! Allan deviation curves they were read from, and what the analysis ran
//! over.

use serde::{Deserialize, Serialize};

use super::channel::ChannelFit;
use super::departures::Departure;
use super::fit::NoiseTerms;
use super::term::{Reach, Term};
use crate::model::units::{ARCSEC, DEG_PER_H, DEG_PER_RT_H, UG, UG_PER_RT_HZ};

/// √h in s^½: turns a per-√s density into per √h.
const RT_HOUR_S: f64 = 60.0;

/// One value per sensor axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Triad<T> {
    pub x: T,
    pub y: T,
    pub z: T,
}

impl<T> Triad<T> {
    pub fn from_fn(mut f: impl FnMut(usize) -> T) -> Self {
        Triad {
            x: f(0),
            y: f(1),
            z: f(2),
        }
    }

    pub fn iter(&self) -> impl Iterator<Item = (&'static str, &T)> {
        [("x", &self.x), ("y", &self.y), ("z", &self.z)].into_iter()
    }
}

/// A gyro axis's noise terms.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GyroNoise {
    /// Angle random walk N, deg/√h.
    pub arw_deg_rt_h: Term,
    /// Bias instability B, deg/h: the flicker floor of the Allan deviation
    /// is 0.664·B (IEEE Std 952/1293).
    pub bias_instability_deg_h: Term,
    /// Rate random walk K, deg/h/√h.
    pub rate_random_walk_deg_h_rt_h: Term,
    /// Angle quantization Q, arcsec (σ² = 3Q²/τ²).
    pub angle_quantization_arcsec: Term,
    /// The pulse quantum q every record is a whole number of, arcsec;
    /// absent when some record is not (or the axis never moved).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quantum_arcsec: Option<f64>,
    /// How closely the model follows the curve where it was fitted (see
    /// [`super::fit::TermFit::rms_z`]).
    pub fit_rms_z: f64,
    /// Bands of τ where the curve departs from the model.
    #[serde(default)]
    pub departures: Vec<Departure>,
}

/// An accelerometer axis's noise terms.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AccelNoise {
    /// Velocity random walk N, µg/√Hz.
    pub vrw_ug_rt_hz: Term,
    /// Bias instability B, µg (flicker floor 0.664·B).
    pub bias_instability_ug: Term,
    /// Acceleration random walk K, µg/√h.
    pub acceleration_random_walk_ug_rt_h: Term,
    /// Velocity quantization Q, mm/s.
    pub velocity_quantization_mm_s: Term,
    /// The pulse quantum q, m/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quantum_mps: Option<f64>,
    pub fit_rms_z: f64,
    #[serde(default)]
    pub departures: Vec<Departure>,
}

/// Report units of Q, N, B, K: SI per unit and the unit's name.
const GYRO_UNITS: [(f64, &str); 4] = [
    (ARCSEC, "arcsec"),
    (DEG_PER_RT_H, "deg/sqrt(h)"),
    (DEG_PER_H, "deg/h"),
    (DEG_PER_H / RT_HOUR_S, "deg/h/sqrt(h)"),
];
const ACCEL_UNITS: [(f64, &str); 4] = [
    (1e-3, "mm/s"),
    (UG_PER_RT_HZ, "ug/sqrt(Hz)"),
    (UG, "ug"),
    (UG / RT_HOUR_S, "ug/sqrt(h)"),
];
const REACH: [Reach; 4] = [Reach::Short, Reach::Short, Reach::Long, Reach::Long];

/// Q, N, B, K of an axis in report units.
fn terms_of(read: &ChannelFit, units: &[(f64, &str); 4], covered: [f64; 2]) -> [Term; 4] {
    std::array::from_fn(|k| {
        Term::from_estimate(
            &read.fit.estimates[k],
            units[k],
            read.bands[k],
            covered,
            REACH[k],
            read.spoiled[k],
        )
    })
}

impl GyroNoise {
    /// An axis's reading in report units; `covered` the curve's τ range.
    pub fn from_channel(read: &ChannelFit, quantum: Option<f64>, covered: [f64; 2]) -> Self {
        let [q, n, b, k] = terms_of(read, &GYRO_UNITS, covered);
        GyroNoise {
            arw_deg_rt_h: n,
            bias_instability_deg_h: b,
            rate_random_walk_deg_h_rt_h: k,
            angle_quantization_arcsec: q,
            quantum_arcsec: quantum.map(|q| q / ARCSEC),
            fit_rms_z: read.fit.rms_z,
            departures: read.departures.clone(),
        }
    }

    /// The terms the model draws with (resolved and fixed; 0 for those
    /// not resolved), SI.
    pub fn terms_si(&self) -> NoiseTerms {
        si(
            [
                &self.angle_quantization_arcsec,
                &self.arw_deg_rt_h,
                &self.bias_instability_deg_h,
                &self.rate_random_walk_deg_h_rt_h,
            ],
            &GYRO_UNITS,
        )
    }

    /// The fitted Allan deviation at τ, deg/h.
    pub fn model_adev_deg_h(&self, tau_s: f64) -> f64 {
        self.terms_si().allan_deviation(tau_s) / DEG_PER_H
    }
}

impl AccelNoise {
    pub fn from_channel(read: &ChannelFit, quantum: Option<f64>, covered: [f64; 2]) -> Self {
        let [q, n, b, k] = terms_of(read, &ACCEL_UNITS, covered);
        AccelNoise {
            vrw_ug_rt_hz: n,
            bias_instability_ug: b,
            acceleration_random_walk_ug_rt_h: k,
            velocity_quantization_mm_s: q,
            quantum_mps: quantum,
            fit_rms_z: read.fit.rms_z,
            departures: read.departures.clone(),
        }
    }

    pub fn terms_si(&self) -> NoiseTerms {
        si(
            [
                &self.velocity_quantization_mm_s,
                &self.vrw_ug_rt_hz,
                &self.bias_instability_ug,
                &self.acceleration_random_walk_ug_rt_h,
            ],
            &ACCEL_UNITS,
        )
    }

    /// The fitted Allan deviation at τ, µg.
    pub fn model_adev_ug(&self, tau_s: f64) -> f64 {
        self.terms_si().allan_deviation(tau_s) / UG
    }
}

fn si(terms: [&Term; 4], units: &[(f64, &str); 4]) -> NoiseTerms {
    let v: [f64; 4] = std::array::from_fn(|k| terms[k].model_value() * units[k].0);
    NoiseTerms {
        quantization: v[0],
        white: v[1],
        flicker: v[2],
        random_walk: v[3],
    }
}

/// A gyro axis's Allan deviation at each τ of [`AllanCurves::tau_s`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GyroCurve {
    pub adev_deg_h: Vec<f64>,
    /// Equivalent degrees of freedom of σ̂² at each τ, under the fitted
    /// model's mix of noise kinds: σ² lies within σ̂²·ν/χ²_ν quantiles.
    pub edf: Vec<f64>,
}

/// An accelerometer axis's Allan deviation at each τ.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AccelCurve {
    pub adev_ug: Vec<f64>,
    pub edf: Vec<f64>,
}

/// The overlapping Allan deviation curves.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AllanCurves {
    pub tau_s: Vec<f64>,
    /// Records per cluster at each τ.
    pub cluster_records: Vec<u64>,
    /// Terms (overlapping pairs of adjacent clusters) summed over the
    /// stretches analysed, at each τ.
    pub terms: Vec<u64>,
    pub gyro: Triad<GyroCurve>,
    pub accel: Triad<AccelCurve>,
}

/// What the run was analysed over.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Span {
    /// The dwells the pre-scan finds, turns (and the guards around them)
    /// left out.
    Dwells,
    /// Every record: a run with no turns.
    WholeRun,
}

/// One stretch of records analysed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stretch {
    pub t_start: f64,
    pub t_end: f64,
    pub records: u64,
}

/// What the curves and terms rest on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Coverage {
    pub span: Span,
    pub sample_rate_hz: f64,
    /// The stretches used (each dwell, or the whole run).
    pub stretches: Vec<Stretch>,
    /// Their total length, s (the time at rest for dwells).
    pub seconds_used: f64,
    pub records_used: u64,
    /// The longest τ analysed and why: a fraction of the longest stretch,
    /// at most a cluster-size cap.
    pub max_tau_s: f64,
    pub longest_stretch_s: f64,
}

/// The whole analysis (NOISE.json).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoiseReport {
    pub gyro: Triad<GyroNoise>,
    pub accel: Triad<AccelNoise>,
    pub curves: AllanCurves,
    pub computed_over: Coverage,
    /// How the terms were found, in words.
    pub method: String,
    #[serde(default)]
    pub warnings: Vec<String>,
}

impl NoiseReport {
    /// The summary the command line prints.
    pub fn table(&self) -> String {
        let c = &self.computed_over;
        let what = match c.span {
            Span::Dwells => format!("{} dwells", c.stretches.len()),
            Span::WholeRun => "the whole run".to_string(),
        };
        let tau = &self.curves.tau_s;
        let mut out = format!(
            "overlapping Allan deviation over {what}: {:.1} s, {} records; tau {:.3}–{:.1} s ({} points)\n",
            c.seconds_used,
            c.records_used,
            tau.first().copied().unwrap_or(0.0),
            tau.last().copied().unwrap_or(0.0),
            tau.len()
        );
        out.push_str(
            "gyro   ARW deg/sqrt(h)     bias inst. deg/h    RRW deg/h/sqrt(h)   Q arcsec     quantum arcsec  fit rms z\n",
        );
        for (axis, g) in self.gyro.iter() {
            out.push_str(&format!(
                "  {axis}    {:<18}  {:<18}  {:<18}  {:<11}  {:<14}  {:>9.2}\n",
                g.arw_deg_rt_h.cell(),
                g.bias_instability_deg_h.cell(),
                g.rate_random_walk_deg_h_rt_h.cell(),
                g.angle_quantization_arcsec.cell(),
                g.quantum_arcsec.map_or("-".into(), |q| format!("{q:.6}")),
                g.fit_rms_z
            ));
        }
        out.push_str(
            "accel  VRW ug/sqrt(Hz)     bias inst. ug       acc. RW ug/sqrt(h)  Q mm/s       quantum m/s     fit rms z\n",
        );
        for (axis, a) in self.accel.iter() {
            out.push_str(&format!(
                "  {axis}    {:<18}  {:<18}  {:<18}  {:<11}  {:<14}  {:>9.2}\n",
                a.vrw_ug_rt_hz.cell(),
                a.bias_instability_ug.cell(),
                a.acceleration_random_walk_ug_rt_h.cell(),
                a.velocity_quantization_mm_s.cell(),
                a.quantum_mps.map_or("-".into(), |q| format!("{q:.6e}")),
                a.fit_rms_z
            ));
        }
        out.push_str("(v±s: resolved, 1-sigma; <b: not resolved, 95 % upper bound; =v: held from the quantum)\n");
        for w in &self.warnings {
            out.push_str(&format!("warning: {w}\n"));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::fit::{Estimate, TermFit};

    /// The report's units and back give the model's terms, so a plotted
    /// model curve is the fit's own; a bound adds nothing to it.
    #[test]
    fn terms_round_trip_through_the_report_units() {
        let read = ChannelFit {
            fit: TermFit {
                terms: NoiseTerms::default(),
                estimates: [
                    Estimate::Fixed { value: 2e-6 },
                    Estimate::Resolved {
                        value: 3e-7,
                        sigma: 1e-8,
                    },
                    Estimate::Bound { upper: 4e-8 },
                    Estimate::Resolved {
                        value: 5e-9,
                        sigma: 1e-9,
                    },
                ],
                edf: Vec::new(),
                rms_z: 0.0,
            },
            departures: Vec::new(),
            used: Vec::new(),
            bands: [[0.01, 1.0]; 4],
            spoiled: [false; 4],
        };
        for back in [
            GyroNoise::from_channel(&read, None, [0.01, 10.0]).terms_si(),
            AccelNoise::from_channel(&read, None, [0.01, 10.0]).terms_si(),
        ] {
            for (a, b) in [
                (back.quantization, 2e-6),
                (back.white, 3e-7),
                (back.random_walk, 5e-9),
            ] {
                assert!((a / b - 1.0).abs() < 1e-12, "{a} against {b}");
            }
            assert_eq!(back.flicker, 0.0);
        }
        let g = GyroNoise::from_channel(&read, None, [0.01, 10.0]);
        assert!(g
            .bias_instability_deg_h
            .text
            .starts_with("not resolved: below"));
        assert!(
            g.bias_instability_deg_h.text.ends_with("at tau <= 10.0 s"),
            "{}",
            g.bias_instability_deg_h.text
        );
        // White noise alone falls as 1/√τ.
        let white = NoiseTerms {
            white: 1.0,
            ..NoiseTerms::default()
        };
        assert!((white.allan_deviation(4.0) - 0.5).abs() < 1e-15);
    }
}
