//! Effects a designed scheme must make visible (`sinscal design --detect
//! accel_lever_arm=2cm,accel_delay=0.5ms`).
//!
//! The discrepancy workflow names an effect when fitting its parameters
//! drops the gap's χ² past the BIC bar, bic_threshold + k ln n − k for k
//! parameters and n velocity observations (`diagnose::detect`). For a true
//! effect θ the expected drop is θᵀFθ, F the information of the effect's
//! parameters with the base parameters (and here the other goals'
//! effects) profiled out. The objective carries the goals' effects as
//! filter states beside the 24 (`information`), so F is the inverse of
//! their covariance block less their priors' information, and the
//! smallest effect named is √(bar / F_ii) along each parameter alone: a
//! 2 cm lever arm must be seen whichever accelerometer and axis it is on.
//!
//! At that size an effect is named in about half the runs. The goal is
//! the size over `DETECT_MARGIN`: at 1.5 times the threshold a run names
//! it in 9 or 10 runs of 10 (`benches/diagnose_detect.rs`, every quantity,
//! by hand and on a table).

use std::fmt;
use std::str::FromStr;

use nalgebra::DMatrix;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::information::Information;
use super::{DesignError, DesignRequest};
use crate::calib::plan::PlanInput;
use crate::calib::Effect;
use crate::diagnose::{thresholds_before_data, DiagnoseOptions};
use crate::estimation::effect_columns::EffectParameter;
use crate::model::Grade;
use crate::sim::Scheme;

/// How far below the requested size the predicted threshold must lie.
pub const DETECT_MARGIN: f64 = 1.5;

/// Searches run again after the workflow's check found a goal unmet.
pub const CHECK_ROUNDS: usize = 2;

/// Stretches between nodes per observed dwell in the gap fit (nodes at
/// the first, last and three evenly spaced windows of each dwell,
/// `calib::nodes`), for the BIC's n. Only its logarithm matters.
const STRETCHES_PER_OBSERVED_DWELL: f64 = 5.0;

/// Record rate of the noise-free run a design's detection is checked on:
/// hand turns need 100 Hz (CONTRACT §8.9), and a table run's thresholds
/// do not depend on it.
const CHECK_RATE_HZ: f64 = 100.0;

/// The selection's naming bar, as the discrepancy workflow sets it.
pub fn naming_bar() -> f64 {
    DiagnoseOptions::default().bic_threshold
}

/// One requirement: an effect of this size must be named.
#[derive(Clone, Debug, PartialEq)]
pub struct DetectGoal {
    pub effect: Effect,
    /// The unit of the effect's states the size is in (a drift is a gyro
    /// drift in deg/h/h or an accelerometer drift in ug/h).
    pub unit: &'static str,
    pub size: f64,
}

/// The units a size may be written in, per effect: (suffix, its value in
/// the states' unit, the states' unit).
fn units_of(effect: Effect) -> &'static [(&'static str, f64, &'static str)] {
    match effect {
        Effect::AccelLeverArm => &[("mm", 1.0, "mm"), ("cm", 10.0, "mm"), ("m", 1000.0, "mm")],
        Effect::AccelDelay => &[
            ("ms", 1.0, "ms"),
            ("us", 1e-3, "ms"),
            ("µs", 1e-3, "ms"),
            ("s", 1000.0, "ms"),
        ],
        Effect::GyroGSensitivity => &[("deg/h/g", 1.0, "deg/h/g")],
        Effect::BiasDrift => &[("deg/h/h", 1.0, "deg/h/h"), ("ug/h", 1.0, "ug/h")],
        Effect::GyroScaleAsymmetry => &[("ppm", 1.0, "ppm")],
        // Not a goal of scheme design: it follows the temperature, not
        // the turns (`Effect::MOTION` is what `--detect` accepts).
        Effect::Thermal | Effect::ThermalCurvature => &[],
    }
}

/// Why a `--detect` item was refused.
#[derive(Debug, thiserror::Error)]
#[error("--detect {given:?}: {why}")]
pub struct DetectParseError {
    given: String,
    why: String,
}

impl FromStr for DetectGoal {
    type Err = DetectParseError;

    /// `EFFECT=SIZE` with the size's unit attached: `accel_lever_arm=2cm`,
    /// `accel_delay=0.5ms`, `bias_drift=0.005deg/h/h`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let refuse = |why: String| DetectParseError {
            given: s.to_string(),
            why,
        };
        let (name, size) = s
            .split_once('=')
            .ok_or_else(|| refuse("expected EFFECT=SIZE, e.g. accel_lever_arm=2cm".into()))?;
        let effect = Effect::MOTION
            .into_iter()
            .find(|e| e.name() == name.trim())
            .ok_or_else(|| {
                refuse(format!(
                    "{name:?} is not a SPEC §3 effect ({})",
                    Effect::MOTION.map(Effect::name).join(", ")
                ))
            })?;
        let size = size.trim();
        let mut units: Vec<_> = units_of(effect).to_vec();
        // "2mm" also ends in "m": the longest suffix decides.
        units.sort_by_key(|(suffix, _, _)| std::cmp::Reverse(suffix.len()));
        let listed = || {
            units_of(effect)
                .iter()
                .map(|u| u.0)
                .collect::<Vec<_>>()
                .join(", ")
        };
        let (number, factor, unit) = units
            .iter()
            .find_map(|&(suffix, factor, unit)| {
                size.strip_suffix(suffix).map(|n| (n.trim(), factor, unit))
            })
            .ok_or_else(|| refuse(format!("the size needs a unit: one of {}", listed())))?;
        let value: f64 = number
            .parse()
            .map_err(|_| refuse(format!("{number:?} is not a number")))?;
        let size = value * factor;
        if !(size.is_finite() && size > 0.0) {
            return Err(refuse("the size must be a positive number".into()));
        }
        Ok(DetectGoal { effect, unit, size })
    }
}

impl fmt::Display for DetectGoal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}={}{}", self.effect.name(), self.size, self.unit)
    }
}

impl Serialize for DetectGoal {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for DetectGoal {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d)?
            .parse()
            .map_err(serde::de::Error::custom)
    }
}

/// The goals as the objective scores them.
#[derive(Clone, Debug)]
pub struct Detection {
    pub goals: Vec<DetectGoal>,
    /// The states carried: every goal's whole effect, once.
    pub states: Vec<EffectParameter>,
    /// The selection's naming bar (`DiagnoseOptions::bic_threshold`).
    pub bic_threshold: f64,
    /// The unit's grade, which sizes the states' priors.
    pub grade: Grade,
    /// Per goal, what the objective's threshold is multiplied by before
    /// it is held against the goal: 1, or larger where the workflow's
    /// check named less than the objective promised.
    pub correction: Vec<f64>,
}

impl Detection {
    pub fn new(goals: &[DetectGoal], bic_threshold: f64, grade: Grade) -> Self {
        let mut effects: Vec<Effect> = goals.iter().map(|g| g.effect).collect();
        effects.sort();
        effects.dedup();
        Detection {
            goals: goals.to_vec(),
            states: effects.into_iter().flat_map(Effect::states).collect(),
            bic_threshold,
            grade,
            correction: vec![1.0; goals.len()],
        }
    }

    /// Threshold over goal per goal, corrected: at most 1 when met.
    pub fn ratios(&self, info: &Information) -> Vec<f64> {
        self.thresholds(info)
            .into_iter()
            .zip(&self.goals)
            .zip(&self.correction)
            .map(|((t, g), c)| t * c * DETECT_MARGIN / g.size)
            .collect()
    }

    /// Where the workflow's check of a design found a goal unmet, makes
    /// the objective as strict as the check was (and 2 % more, so that the
    /// next design does not land on the edge again). Whether anything
    /// changed.
    pub fn correct(&mut self, outcomes: &[DetectOutcome]) -> bool {
        let mut changed = false;
        for (c, o) in self.correction.iter_mut().zip(outcomes) {
            if let Some(checked) = o.checked_threshold.filter(|_| !o.met) {
                let needed = 1.02 * checked / o.threshold;
                if needed > *c {
                    *c = needed;
                    changed = true;
                }
            }
        }
        changed
    }

    /// Per goal, the smallest effect of its quantity the scheme would
    /// name, along its least visible parameter, in the goal's unit.
    pub fn thresholds(&self, info: &Information) -> Vec<f64> {
        let n_obs = 3.0 * STRETCHES_PER_OBSERVED_DWELL * info.observed_dwells.max(1) as f64;
        self.goals
            .iter()
            .map(|goal| {
                let a: Vec<usize> = (0..self.states.len())
                    .filter(|&i| goal.effect.states().contains(&self.states[i]))
                    .collect();
                let f = self.information(&info.effect_covariance_si, &a);
                let k = a.len() as f64;
                let bar = (self.bic_threshold + k * n_obs.ln() - k).max(1.0);
                a.iter()
                    .enumerate()
                    .filter(|(_, &i)| self.states[i].unit() == goal.unit)
                    .map(|(r, _)| (bar / f[(r, r)].max(f64::MIN_POSITIVE)).sqrt())
                    .fold(0.0, f64::max)
            })
            .collect()
    }

    /// Information of states `a` (reporting units), the rest profiled out:
    /// the inverse of their covariance block, less their priors'.
    fn information(&self, cov_si: &DMatrix<f64>, a: &[usize]) -> DMatrix<f64> {
        let si = |i: usize| self.states[a[i]].si_per_unit();
        let block = DMatrix::from_fn(a.len(), a.len(), |i, j| {
            cov_si[(a[i], a[j])] / (si(i) * si(j))
        });
        let eig = block.symmetric_eigen();
        let largest = eig.eigenvalues.amax().max(f64::MIN_POSITIVE);
        let inv = eig.eigenvalues.map(|l| 1.0 / l.max(largest * f64::EPSILON));
        let mut f = &eig.eigenvectors * DMatrix::from_diagonal(&inv) * eig.eigenvectors.transpose();
        for (i, &s) in a.iter().enumerate() {
            f[(i, i)] -= self.states[s].prior_sigma(self.grade).powi(-2);
        }
        f
    }
}

/// A `--detect` goal and how the designed scheme meets it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectOutcome {
    pub goal: DetectGoal,
    pub unit: String,
    /// The smallest effect of the goal's quantity the scheme would name,
    /// along its least visible parameter, as the objective predicts it.
    pub threshold: f64,
    /// threshold × correction × `DETECT_MARGIN` / size: at most 1 when
    /// the objective says the goal is met.
    pub ratio: f64,
    /// What the search held the objective's threshold multiplied by: 1,
    /// or more after a check found the workflow naming less.
    pub correction: f64,
    /// The same from the discrepancy workflow itself on a noise-free
    /// simulated run of the scheme (`diagnose::thresholds_before_data`),
    /// which also weighs the effects outside the goals as rivals.
    pub checked_threshold: Option<f64>,
    /// Whether the checked threshold (the predicted one where the
    /// workflow reported none) is at most size / `DETECT_MARGIN`.
    pub met: bool,
}

impl DetectOutcome {
    /// "accel_lever_arm=20mm: named from 7.1 mm (checked 7.4 mm), ratio 0.53".
    pub fn describe(&self) -> String {
        let checked = self
            .checked_threshold
            .map(|c| format!(" (the workflow on a simulated run: {c:.3} {})", self.unit))
            .unwrap_or_default();
        let corrected = if self.correction > 1.0 {
            format!(" × {:.2} after a check", self.correction)
        } else {
            String::new()
        };
        format!(
            "detect {}: named from {:.3} {}{corrected}{checked}; ratio {:.2}{}",
            self.goal,
            self.threshold,
            self.unit,
            self.ratio,
            if self.met {
                ""
            } else {
                "; NOT MET: the workflow names less than the goal asks"
            }
        )
    }
}

/// The outcome of every goal on the designed scheme as it is run
/// (`run`, after hand turns), its predicted thresholds `predicted`.
pub fn outcomes(
    detection: &Detection,
    predicted: &[f64],
    run: &Scheme,
    req: &DesignRequest,
) -> Result<Vec<DetectOutcome>, DesignError> {
    let input = PlanInput {
        scheme: run.clone(),
        site: req.site,
        sample_rate_hz: CHECK_RATE_HZ,
        noise: req.noise,
        initial_attitude_error_deg: req.initial_attitude_deg,
    };
    let never = std::sync::atomic::AtomicBool::new(false);
    let checked = thresholds_before_data(&input, &never)?;
    Ok(detection
        .goals
        .iter()
        .zip(predicted)
        .zip(&detection.correction)
        .map(|((goal, &threshold), &correction)| {
            // The workflow's quantity of this goal: its effect's group in
            // the goal's unit, worst parameter alone.
            let checked_threshold = checked
                .iter()
                .filter(|t| t.effect == goal.effect.name() && t.unit == goal.unit)
                .flat_map(|t| t.per_parameter.iter().copied())
                .reduce(f64::max);
            DetectOutcome {
                goal: goal.clone(),
                unit: goal.unit.to_string(),
                threshold,
                ratio: threshold * correction * DETECT_MARGIN / goal.size,
                correction,
                checked_threshold,
                met: checked_threshold.unwrap_or(threshold) * DETECT_MARGIN <= goal.size,
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_read_in_any_of_their_units() {
        let g: DetectGoal = "accel_lever_arm=2cm".parse().unwrap();
        assert_eq!(
            (g.effect, g.unit, g.size),
            (Effect::AccelLeverArm, "mm", 20.0)
        );
        let g: DetectGoal = "accel_lever_arm=15mm".parse().unwrap();
        assert_eq!(g.size, 15.0);
        let g: DetectGoal = "accel_delay=500us".parse().unwrap();
        assert!((g.size - 0.5).abs() < 1e-12);
        let g: DetectGoal = "bias_drift=20ug/h".parse().unwrap();
        assert_eq!(g.unit, "ug/h");
        let again: DetectGoal = g.to_string().parse().unwrap();
        assert_eq!(again, g);
    }

    #[test]
    fn a_size_without_unit_or_effect_is_refused_saying_why() {
        let e = "accel_delay=0.5".parse::<DetectGoal>().unwrap_err();
        assert!(e.to_string().contains("ms"), "{e}");
        let e = "lever_arm=2cm".parse::<DetectGoal>().unwrap_err();
        assert!(e.to_string().contains("accel_lever_arm"), "{e}");
        assert!("accel_delay=-1ms".parse::<DetectGoal>().is_err());
        assert!("accel_delay=2deg/h/h".parse::<DetectGoal>().is_err());
    }
}
