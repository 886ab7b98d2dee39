//! NOISE.json: the noise terms of each sensor axis in reporting units, the
//! Allan deviation curves they were read from, and what the analysis ran
//! over.

use serde::{Deserialize, Serialize};

use super::fit::{NoiseTerms, TermFit};
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
    pub arw_deg_rt_h: f64,
    /// Bias instability B, deg/h: the flicker floor of the Allan deviation
    /// is 0.664·B (IEEE Std 952/1293).
    pub bias_instability_deg_h: f64,
    /// Rate random walk K, deg/h/√h.
    pub rate_random_walk_deg_h_rt_h: f64,
    /// Angle quantization Q, arcsec (σ² = 3Q²/τ²).
    pub angle_quantization_arcsec: f64,
    /// How closely the four-term model follows the curve (see
    /// [`TermFit::rms_z`]).
    pub fit_rms_z: f64,
}

/// An accelerometer axis's noise terms.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AccelNoise {
    /// Velocity random walk N, µg/√Hz.
    pub vrw_ug_rt_hz: f64,
    /// Bias instability B, µg (flicker floor 0.664·B).
    pub bias_instability_ug: f64,
    /// Acceleration random walk K, µg/√h.
    pub acceleration_random_walk_ug_rt_h: f64,
    /// Velocity quantization Q, mm/s.
    pub velocity_quantization_mm_s: f64,
    pub fit_rms_z: f64,
}

impl GyroNoise {
    pub fn from_fit(fit: &TermFit) -> Self {
        let t: &NoiseTerms = &fit.terms;
        GyroNoise {
            arw_deg_rt_h: t.white / DEG_PER_RT_H,
            bias_instability_deg_h: t.flicker / DEG_PER_H,
            rate_random_walk_deg_h_rt_h: t.random_walk * RT_HOUR_S / DEG_PER_H,
            angle_quantization_arcsec: t.quantization / ARCSEC,
            fit_rms_z: fit.rms_z,
        }
    }
}

impl GyroNoise {
    /// The identified terms back in SI (the inverse of [`Self::from_fit`]).
    pub fn terms_si(&self) -> NoiseTerms {
        NoiseTerms {
            quantization: self.angle_quantization_arcsec * ARCSEC,
            white: self.arw_deg_rt_h * DEG_PER_RT_H,
            flicker: self.bias_instability_deg_h * DEG_PER_H,
            random_walk: self.rate_random_walk_deg_h_rt_h * DEG_PER_H / RT_HOUR_S,
        }
    }

    /// The fitted Allan deviation at τ, deg/h.
    pub fn model_adev_deg_h(&self, tau_s: f64) -> f64 {
        self.terms_si().allan_deviation(tau_s) / DEG_PER_H
    }
}

impl AccelNoise {
    /// The identified terms back in SI (the inverse of [`Self::from_fit`]).
    pub fn terms_si(&self) -> NoiseTerms {
        NoiseTerms {
            quantization: self.velocity_quantization_mm_s * 1e-3,
            white: self.vrw_ug_rt_hz * UG_PER_RT_HZ,
            flicker: self.bias_instability_ug * UG,
            random_walk: self.acceleration_random_walk_ug_rt_h * UG / RT_HOUR_S,
        }
    }

    /// The fitted Allan deviation at τ, µg.
    pub fn model_adev_ug(&self, tau_s: f64) -> f64 {
        self.terms_si().allan_deviation(tau_s) / UG
    }
}

impl AccelNoise {
    pub fn from_fit(fit: &TermFit) -> Self {
        let t: &NoiseTerms = &fit.terms;
        AccelNoise {
            vrw_ug_rt_hz: t.white / UG_PER_RT_HZ,
            bias_instability_ug: t.flicker / UG,
            acceleration_random_walk_ug_rt_h: t.random_walk * RT_HOUR_S / UG,
            velocity_quantization_mm_s: t.quantization * 1e3,
            fit_rms_z: fit.rms_z,
        }
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
            "gyro   ARW deg/sqrt(h)   bias inst. deg/h   RRW deg/h/sqrt(h)   Q arcsec   fit rms z\n",
        );
        for (axis, g) in self.gyro.iter() {
            out.push_str(&format!(
                "  {axis}    {:>13.6}   {:>16.6}   {:>17.6}   {:>8.4}   {:>9.2}\n",
                g.arw_deg_rt_h,
                g.bias_instability_deg_h,
                g.rate_random_walk_deg_h_rt_h,
                g.angle_quantization_arcsec,
                g.fit_rms_z
            ));
        }
        out.push_str(
            "accel  VRW ug/sqrt(Hz)   bias inst. ug      acc. RW ug/sqrt(h)  Q mm/s     fit rms z\n",
        );
        for (axis, a) in self.accel.iter() {
            out.push_str(&format!(
                "  {axis}    {:>13.4}   {:>16.4}   {:>17.4}   {:>8.5}   {:>9.2}\n",
                a.vrw_ug_rt_hz,
                a.bias_instability_ug,
                a.acceleration_random_walk_ug_rt_h,
                a.velocity_quantization_mm_s,
                a.fit_rms_z
            ));
        }
        for w in &self.warnings {
            out.push_str(&format!("warning: {w}\n"));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit_of(terms: NoiseTerms) -> TermFit {
        TermFit {
            terms,
            edf: Vec::new(),
            rms_z: 0.0,
        }
    }

    /// The report's units and back give the fitted terms, so a plotted
    /// model curve is the fit's own.
    #[test]
    fn terms_round_trip_through_the_report_units() {
        let terms = NoiseTerms {
            quantization: 2e-6,
            white: 3e-7,
            flicker: 4e-8,
            random_walk: 5e-9,
        };
        for back in [
            GyroNoise::from_fit(&fit_of(terms)).terms_si(),
            AccelNoise::from_fit(&fit_of(terms)).terms_si(),
        ] {
            for (a, b) in [
                (back.quantization, terms.quantization),
                (back.white, terms.white),
                (back.flicker, terms.flicker),
                (back.random_walk, terms.random_walk),
            ] {
                assert!((a / b - 1.0).abs() < 1e-12, "{a} against {b}");
            }
        }
        // White noise alone falls as 1/√τ.
        let white = NoiseTerms {
            white: 1.0,
            ..NoiseTerms::default()
        };
        assert!((white.allan_deviation(4.0) - 0.5).abs() < 1e-15);
    }
}
