//! Which effects outside the base model (SPEC §3) a calibration carries
//! as states, and what each state is called, measured in and allowed by
//! its prior: `base-24+accel_lever_arm+accel_delay` as the CLI, the
//! server's configuration and the result's `model` field write it.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::estimation::effect_columns::EffectParameter;
use crate::model::units::{DEG_PER_H, DEG_PER_H_PER_G, HOUR, PPM, UG};
use crate::model::{Grade, Group, PARAMETERS};

const AXES: [&str; 3] = ["x", "y", "z"];

/// The temperature span over which a quadratic thermal state's prior
/// matches its linear one's (°C).
const CURVATURE_PRIOR_SPAN_C: f64 = 20.0;

/// The families whose linear temperature coefficients the in-run thermal
/// states carry: the biases and scale factors, which move most with
/// temperature, and the mountings, whose hundredths of an arcsec per °C
/// make arcseconds over a chamber's range: left out, a run over 40 °C
/// fails its model check. The accelerometers' quadratic terms are left
/// out: a few tenths of a µg/g² across a range is below what a run
/// resolves of them.
pub const THERMAL_LINEAR: [Group; 6] = [
    Group::GyroBias,
    Group::GyroScale,
    Group::GyroMisalign,
    Group::AccelBias,
    Group::AccelScale,
    Group::AccelMisalign,
];

/// The families whose quadratic temperature coefficients are carried while
/// an in-run thermal calibration's noise is fitted: the biases and scale
/// factors (the mountings' curvature is left out to keep that pass
/// small).
pub const THERMAL_CURVATURE: [Group; 4] = [
    Group::GyroBias,
    Group::GyroScale,
    Group::AccelBias,
    Group::AccelScale,
];

/// A SPEC §3 effect, as a family of states.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Effect {
    /// The accelerometers' positions across their own axes (6 states).
    /// Moving all three sensors by one vector moves the point they sense,
    /// whose velocity is zero at every rest: that common part is not
    /// observable, and the along-axis components are fixed at zero by
    /// this choice of reference point.
    AccelLeverArm,
    /// The full 3 × 3 gyro g-sensitivity (9 states).
    GyroGSensitivity,
    /// The accelerometer channel's delay (1 state).
    AccelDelay,
    /// Gyro and accelerometer bias drift rates (6 states).
    BiasDrift,
    /// Gyro scale-factor asymmetry (3 states).
    GyroScaleAsymmetry,
    /// SPEC §3a in-run: the linear temperature coefficients of the biases
    /// and scale factors (12 states) and the gyro bias against the rate
    /// of change of temperature (3). Needs the run's temperature column.
    Thermal,
    /// SPEC §3a's quadratic coefficients of the biases and scale factors
    /// (12 states). Not a model a calibration reports: carried while the
    /// noise model of an in-run thermal calibration is fitted, so that the
    /// fitted wander does not take up a curvature the linear states lack
    /// (the model check is then left to see it). Not among `ALL`.
    ThermalCurvature,
}

impl Effect {
    pub const ALL: [Effect; 6] = [
        Effect::AccelLeverArm,
        Effect::GyroGSensitivity,
        Effect::AccelDelay,
        Effect::BiasDrift,
        Effect::GyroScaleAsymmetry,
        Effect::Thermal,
    ];

    /// The SPEC §3 effects: those a run's motion shows, which the
    /// discrepancy workflow and scheme design reason about; `Thermal`
    /// follows the run's temperature instead.
    pub const MOTION: [Effect; 5] = [
        Effect::AccelLeverArm,
        Effect::GyroGSensitivity,
        Effect::AccelDelay,
        Effect::BiasDrift,
        Effect::GyroScaleAsymmetry,
    ];

    /// The model effect (one of `ALL`) named `name`.
    pub fn from_name(name: &str) -> Option<Effect> {
        Effect::ALL.into_iter().find(|e| e.name() == name)
    }

    /// The SPEC §3 name.
    pub fn name(self) -> &'static str {
        match self {
            Effect::AccelLeverArm => "accel_lever_arm",
            Effect::GyroGSensitivity => "gyro_g_sensitivity",
            Effect::AccelDelay => "accel_delay",
            Effect::BiasDrift => "bias_drift",
            Effect::GyroScaleAsymmetry => "gyro_scale_asymmetry",
            Effect::Thermal => "thermal",
            Effect::ThermalCurvature => "thermal_curvature",
        }
    }

    /// Its states, in reporting order.
    pub fn states(self) -> Vec<EffectParameter> {
        use EffectParameter as S;
        match self {
            Effect::AccelLeverArm => (0..3)
                .flat_map(|accel| {
                    (0..3)
                        .filter(move |&axis| axis != accel)
                        .map(move |axis| S::LeverArm { accel, axis })
                })
                .collect(),
            Effect::GyroGSensitivity => (0..9)
                .map(|n| S::GSensitivity {
                    gyro: n / 3,
                    axis: n % 3,
                })
                .collect(),
            Effect::AccelDelay => vec![S::AccelDelay],
            Effect::BiasDrift => (0..3)
                .map(S::GyroBiasDrift)
                .chain((0..3).map(S::AccelBiasDrift))
                .collect(),
            Effect::GyroScaleAsymmetry => (0..3).map(S::GyroScaleAsymmetry).collect(),
            Effect::Thermal => THERMAL_LINEAR
                .iter()
                .flat_map(|g| g.range())
                .map(S::ThermalLinear)
                .chain((0..3).map(S::GyroBiasRate))
                .collect(),
            Effect::ThermalCurvature => THERMAL_CURVATURE
                .iter()
                .flat_map(|g| g.range())
                .map(S::ThermalQuadratic)
                .collect(),
        }
    }
}

impl EffectParameter {
    /// The name a result reports it under (the diagnosis uses the same).
    pub fn name(self) -> String {
        use EffectParameter as S;
        match self {
            S::LeverArm { accel, axis } => format!("accel_lever_arm_{}{}", AXES[accel], AXES[axis]),
            S::GSensitivity { gyro, axis } => {
                format!("gyro_g_sensitivity_{}{}", AXES[gyro], AXES[axis])
            }
            S::AccelDelay => "accel_delay".into(),
            S::AccelDelaySquared => "accel_delay_squared".into(),
            S::GyroBiasDrift(i) => format!("bias_drift_gyro_{}", AXES[i]),
            S::AccelBiasDrift(i) => format!("bias_drift_accel_{}", AXES[i]),
            S::GyroScaleAsymmetry(i) => format!("gyro_scale_asymmetry_{}", AXES[i]),
            S::ThermalLinear(i) => format!("thermal.linear.{}", PARAMETERS[i].name),
            S::ThermalQuadratic(i) => format!("thermal.quadratic.{}", PARAMETERS[i].name),
            S::GyroBiasRate(i) => format!("thermal.gyro_bias_rate.{}", AXES[i]),
        }
    }

    /// The unit it is reported in (SPEC §3's JSON units).
    pub fn unit(self) -> &'static str {
        use EffectParameter as S;
        match self {
            S::LeverArm { .. } => "mm",
            S::GSensitivity { .. } => "deg/h/g",
            S::AccelDelay => "ms",
            S::AccelDelaySquared => "ms^2",
            S::GyroBiasDrift(_) => "deg/h/h",
            S::AccelBiasDrift(_) => "ug/h",
            S::GyroScaleAsymmetry(_) => "ppm",
            S::ThermalLinear(i) => match PARAMETERS[i].group {
                Group::GyroBias => "deg/h/degC",
                Group::AccelBias => "ug/degC",
                Group::GyroScale | Group::AccelScale => "ppm/degC",
                Group::GyroMisalign | Group::AccelMisalign => "arcsec/degC",
                Group::AccelQuad => "ug/g^2/degC",
            },
            S::ThermalQuadratic(i) => match PARAMETERS[i].group {
                Group::GyroBias => "deg/h/degC^2",
                Group::AccelBias => "ug/degC^2",
                Group::GyroScale | Group::AccelScale => "ppm/degC^2",
                Group::GyroMisalign | Group::AccelMisalign => "arcsec/degC^2",
                Group::AccelQuad => "ug/g^2/degC^2",
            },
            S::GyroBiasRate(_) => "deg/h/(degC/min)",
        }
    }

    /// One reporting unit in SI.
    pub fn si_per_unit(self) -> f64 {
        use EffectParameter as S;
        match self {
            S::LeverArm { .. } | S::AccelDelay => 1e-3,
            S::AccelDelaySquared => 1e-6,
            S::GSensitivity { .. } => DEG_PER_H_PER_G,
            S::GyroBiasDrift(_) => DEG_PER_H / HOUR,
            S::AccelBiasDrift(_) => UG / HOUR,
            S::GyroScaleAsymmetry(_) => PPM,
            // Per °C: the parameter's own unit.
            S::ThermalLinear(i) | S::ThermalQuadratic(i) => PARAMETERS[i].si_per_unit,
            // (deg/h) per (°C/min) is DEG_PER_H rad/s per (1/60 °C/s).
            S::GyroBiasRate(_) => DEG_PER_H * 60.0,
        }
    }

    /// Prior 1-σ of the state as a calibration of a unit of `grade`
    /// carries it (reporting unit): the navigation-grade prior
    /// ([`Self::navigation_prior_sigma`]), widened for the effects that
    /// grow with the grade's errors by as much as its datasheets widen the
    /// family they belong to. A MEMS gyro's g-sensitivity is a bias that
    /// follows the specific force (imu_tk's Xsens recording: 100–560
    /// deg/h/g, where a ring-laser gyro shows hundredths), its drift a bias
    /// that moves, its scale asymmetry a part of its scale factor; the
    /// navigation priors would hold them at a ten-thousandth of their size.
    /// Lever arms, delays and the thermal states keep their priors: a
    /// board's geometry and a logger's skew do not scale with the sensors.
    /// So do the g-sensitivity's diagonal terms: G_ii f_i turns the unit
    /// about the vertical only (SPEC §3), which a run whose Earth rate is
    /// below the noise sees only through the heading error's second-order
    /// coupling into tilt; widened, they ran to −4900 ± 270 deg/h/g on
    /// simulated consumer units whose truth was within ±100, taking the
    /// cross terms 12–20σ with them.
    pub fn prior_sigma(self, grade: Grade) -> f64 {
        use EffectParameter as S;
        let widened = |group: Group| grade.magnitude(group) / Grade::Navigation.magnitude(group);
        let factor = match self {
            S::GSensitivity { gyro, axis } if gyro != axis => widened(Group::GyroBias),
            S::GyroBiasDrift(_) => widened(Group::GyroBias),
            S::AccelBiasDrift(_) => widened(Group::AccelBias),
            S::GyroScaleAsymmetry(_) => widened(Group::GyroScale),
            _ => 1.0,
        };
        factor * self.navigation_prior_sigma()
    }

    /// Prior 1-σ at navigation grade (reporting unit): several times the
    /// largest a navigation-grade unit shows (SPEC §3's realistic ranges:
    /// arms to 10 cm, delays to 5 ms, drift to 0.02 deg/h/h and 20 µg/h,
    /// g-sensitivity to 0.02 deg/h/g, asymmetry to 100 ppm), so the prior
    /// bounds only what the run cannot see.
    fn navigation_prior_sigma(self) -> f64 {
        use EffectParameter as S;
        match self {
            S::LeverArm { .. } => 300.0,
            S::GSensitivity { .. } => 0.1,
            S::AccelDelay => 20.0,
            S::AccelDelaySquared => 400.0,
            S::GyroBiasDrift(_) => 0.1,
            S::AccelBiasDrift(_) => 100.0,
            S::GyroScaleAsymmetry(_) => 500.0,
            // Several times a navigation-grade unit's largest coefficients
            // (thousandths of a deg/h and tenths of a ppm per °C for the
            // gyros, µg and ppm per °C for the accelerometers).
            S::ThermalLinear(i) => match PARAMETERS[i].group {
                Group::GyroBias => 0.01,
                Group::GyroScale => 2.0,
                Group::AccelBias => 20.0,
                Group::AccelScale => 10.0,
                // Ten arcsec per °C, loose on purpose: the passes centre
                // each filter's prior on the estimate so far, so a prior
                // that informs a direction leaves that direction's σ with
                // information the estimate no longer uses. A ramp over a
                // few positions learns the coefficients that turn both
                // triads together (with k) mostly from the prior at 1″/°C:
                // their errors ran 1.75 times their σ, 1.34 at 10″/°C and
                // at 100″/°C alike.
                Group::GyroMisalign | Group::AccelMisalign => 10.0,
                Group::AccelQuad => 5.0,
            },
            // The linear coefficient's prior over 20 °C, the largest |ΔT|
            // from 25 °C a chamber run spends most of its time at: a
            // curvature several times the size that bends a 40 °C ramp by
            // its linear term's tenth.
            S::ThermalQuadratic(i) => {
                S::ThermalLinear(i).navigation_prior_sigma() / CURVATURE_PRIOR_SPAN_C
            }
            // RLG biases move by hundredths of a deg/h at a chamber's
            // fastest ramps (a few °C/min).
            S::GyroBiasRate(_) => 0.1,
        }
    }
}

/// The error model a calibration estimates: the 24 base parameters and
/// any SPEC §3 effects as further states.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ErrorModel {
    /// In `Effect::ALL` order, without repeats.
    effects: Vec<Effect>,
}

impl ErrorModel {
    /// The base model alone.
    pub fn base() -> Self {
        Self::default()
    }

    pub fn with(effects: &[Effect]) -> Self {
        let mut effects = effects.to_vec();
        effects.sort_unstable();
        effects.dedup();
        ErrorModel { effects }
    }

    pub fn effects(&self) -> &[Effect] {
        &self.effects
    }

    pub fn is_base(&self) -> bool {
        self.effects.is_empty()
    }

    pub fn has(&self, effect: Effect) -> bool {
        self.effects.contains(&effect)
    }

    /// This model with `effect` added.
    pub fn and(&self, effect: Effect) -> Self {
        let mut effects = self.effects.clone();
        effects.push(effect);
        ErrorModel::with(&effects)
    }

    /// Every effect state, in order.
    pub fn states(&self) -> Vec<EffectParameter> {
        self.effects.iter().flat_map(|e| e.states()).collect()
    }
}

impl fmt::Display for ErrorModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("base-24")?;
        for e in &self.effects {
            write!(f, "+{}", e.name())?;
        }
        Ok(())
    }
}

/// Why a model string was refused.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("model {given:?}: {why} (write base, or base+<effect>+…, effects among {known})")]
pub struct ModelParseError {
    given: String,
    why: String,
    known: String,
}

impl FromStr for ErrorModel {
    type Err = ModelParseError;

    /// `base`, `base-24`, or either followed by `+<SPEC §3 effect>`s.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let refuse = |why: String| ModelParseError {
            given: s.to_string(),
            why,
            known: Effect::ALL.map(Effect::name).join(", "),
        };
        let mut parts = s.trim().split('+');
        match parts.next() {
            Some("base") | Some("base-24") => {}
            other => {
                return Err(refuse(format!(
                    "it must start with the base model, not {:?}",
                    other.unwrap_or("")
                )))
            }
        }
        let mut effects = Vec::new();
        for part in parts {
            let e = Effect::from_name(part.trim())
                .ok_or_else(|| refuse(format!("{part:?} is not a SPEC §3 effect nor thermal")))?;
            effects.push(e);
        }
        Ok(ErrorModel::with(&effects))
    }
}

impl Serialize for ErrorModel {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for ErrorModel {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_read_and_write_as_the_cli_and_the_result_spell_them() {
        let m: ErrorModel = "base+accel_delay+accel_lever_arm".parse().unwrap();
        assert_eq!(m.to_string(), "base-24+accel_lever_arm+accel_delay");
        assert_eq!(m.states().len(), 7);
        assert_eq!("base".parse::<ErrorModel>().unwrap(), ErrorModel::base());
        assert_eq!(ErrorModel::base().to_string(), "base-24");
        let every = Effect::ALL.map(Effect::name).join("+");
        let all: ErrorModel = format!("base+{every}").parse().unwrap();
        assert_eq!(all.states().len(), 6 + 9 + 1 + 6 + 3 + 24);
        assert!("accel_delay".parse::<ErrorModel>().is_err());
        assert!("base+accel_dleay".parse::<ErrorModel>().is_err());
        let json = serde_json::to_string(&m).unwrap();
        assert_eq!(serde_json::from_str::<ErrorModel>(&json).unwrap(), m);
    }

    #[test]
    fn priors_widen_with_the_grade_for_the_sensors_effects_only() {
        let g = EffectParameter::GSensitivity { gyro: 1, axis: 0 };
        let arm = ErrorModel::with(&[Effect::AccelLeverArm]).states()[0];
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9 * b;
        assert!(close(g.prior_sigma(Grade::Navigation), 0.1));
        assert!(close(g.prior_sigma(Grade::Tactical), 50.0));
        assert!(close(g.prior_sigma(Grade::Consumer), 3600.0));
        assert_eq!(
            arm.prior_sigma(Grade::Consumer),
            arm.prior_sigma(Grade::Navigation)
        );
    }

    #[test]
    fn state_names_are_unique_and_carry_units() {
        let all = ErrorModel::with(&Effect::ALL).states();
        let mut names: Vec<String> = all.iter().map(|p| p.name()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), all.len());
        assert!(all
            .iter()
            .all(|p| p.si_per_unit() > 0.0 && Grade::ALL.iter().all(|&g| p.prior_sigma(g) > 0.0)));
    }
}
