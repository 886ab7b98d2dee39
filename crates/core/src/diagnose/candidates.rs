//! The library of candidate effects: every SPEC §3 effect, parameterised
//! as the realistic sizes suggest, each parameter with the error state
//! whose column (from the run's own motion) is its signature.

use crate::calib::effect_model::Effect;
use crate::estimation::effect_columns::EffectParameter;
use crate::model::effects::{BiasDrift, LeverArms};
use crate::model::{Effects, Group, PARAMETERS};

/// One parameter of a candidate effect, in the effect's JSON unit.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectParam {
    pub name: String,
    pub unit: String,
    /// The unit of the fit's effect states (JSON unit): a realistic size,
    /// so the states of every candidate are of one order.
    pub signature_size: f64,
    /// The error state it is.
    pub state: EffectParameter,
}

impl EffectParam {
    /// One signature size in SI: the scale of the parameter's state.
    pub fn signature_si(&self) -> f64 {
        self.signature_size * self.state.si_per_unit()
    }
}

/// A candidate effect: its own name, the SPEC §3 effect it models, and
/// its parameters. Two candidates may model one effect (the lever arm
/// along the accelerometers' own axes, and in full).
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    pub name: &'static str,
    pub effect: &'static str,
    pub params: Vec<EffectParam>,
}

/// The library's parameter for `state`, its signature size `size` in the
/// state's reporting unit.
fn p(state: EffectParameter, size: f64) -> EffectParam {
    EffectParam {
        name: state.name(),
        unit: state.unit().to_string(),
        signature_size: size,
        state,
    }
}

/// Every state of `effect` at one signature size.
fn family(effect: Effect, size: f64) -> Vec<EffectParam> {
    effect.states().into_iter().map(|s| p(s, size)).collect()
}

/// Every candidate, in SPEC §3 order.
///
/// - `accel_lever_arm`: each accelerometer displaced along its own axis
///   (3 parameters), or across its axes (`accel_lever_arm_cross`, 6). An
///   accelerometer displaced across its axis senses the tangential
///   acceleration of a turn instead; the along-axis form is the size
///   effect of a triad whose sensors sit on their own axes. On velocity
///   steps between dwells the along-axis arms l are the cross-axis arms
///   of the same triad seen from a reference point moved by l, so the
///   cross form contains the along-axis one and reports arms with the
///   along-axis components at zero; the score's charge for its three
///   extra parameters lets the along-axis form win when it suffices.
/// - `gyro_g_sensitivity`: the full 3 × 3 G (9).
/// - `accel_delay`: τ (1).
/// - `bias_drift`: 3 gyro + 3 accelerometer drift rates (6).
/// - `gyro_scale_asymmetry`: A per gyro (3).
///
/// A run whose temperature moves adds `thermal` ([`library_with`]).
pub fn library() -> Vec<Candidate> {
    library_with(false)
}

/// The library, and with `thermal` the SPEC §3a candidate: the linear
/// temperature coefficients of the biases, scale factors and mountings and
/// the gyro bias against Ṫ (24), whose signature is the parameters'
/// columns times the run's own ΔT(t), and Ṫ(t). Offered only for a run
/// whose temperature column spans a few °C: on a run at one temperature
/// the coefficients' columns are the parameters' own times a constant, and
/// the fit cannot tell them from the parameters.
pub fn library_with(thermal: bool) -> Vec<Candidate> {
    let mut all = motion_library();
    if thermal {
        all.push(Candidate {
            name: "thermal",
            effect: "thermal",
            params: Effect::Thermal
                .states()
                .into_iter()
                .map(|s| p(s, thermal_signature(s)))
                .collect(),
        });
    }
    all
}

/// A realistic size of a thermal state (its reporting unit): a
/// navigation-grade unit's coefficients (SPEC §3a).
fn thermal_signature(state: EffectParameter) -> f64 {
    match state {
        EffectParameter::ThermalLinear(i) => match PARAMETERS[i].group {
            Group::GyroBias => 0.001,
            Group::GyroScale => 0.2,
            Group::AccelBias => 2.0,
            Group::AccelScale => 0.5,
            Group::GyroMisalign | Group::AccelMisalign => 0.05,
            Group::AccelQuad => 0.5,
        },
        _ => 0.02,
    }
}

/// The SPEC §3 effects, which every run's motion shows.
fn motion_library() -> Vec<Candidate> {
    // Across the axes: the six off-axis components. The full nine are not
    // all observable: moving all three sensors by one vector r is moving
    // the point they sense, whose velocity is zero at every dwell.
    vec![
        Candidate {
            name: "accel_lever_arm",
            effect: "accel_lever_arm",
            params: (0..3)
                .map(|i| p(EffectParameter::LeverArm { accel: i, axis: i }, 10.0))
                .collect(),
        },
        Candidate {
            name: "accel_lever_arm_cross",
            effect: "accel_lever_arm",
            params: family(Effect::AccelLeverArm, 10.0),
        },
        Candidate {
            name: "gyro_g_sensitivity",
            effect: "gyro_g_sensitivity",
            params: family(Effect::GyroGSensitivity, 0.01),
        },
        Candidate {
            name: "accel_delay",
            effect: "accel_delay",
            params: family(Effect::AccelDelay, 1.0),
        },
        Candidate {
            name: "bias_drift",
            effect: "bias_drift",
            params: Effect::BiasDrift
                .states()
                .into_iter()
                .map(|s| {
                    let size = match s {
                        EffectParameter::GyroBiasDrift(_) => 0.01,
                        _ => 10.0,
                    };
                    p(s, size)
                })
                .collect(),
        },
        Candidate {
            name: "gyro_scale_asymmetry",
            effect: "gyro_scale_asymmetry",
            params: family(Effect::GyroScaleAsymmetry, 50.0),
        },
    ]
}

/// What a threshold in `unit` of candidate `candidate` is of, as a
/// reader says it ("a … ≥ 1 mm").
pub fn quantity(candidate: &Candidate, unit: &str) -> &'static str {
    match (candidate.name, unit) {
        ("accel_lever_arm", _) => "lever arm along the accelerometers' axes",
        ("accel_lever_arm_cross", _) => "lever arm across the accelerometers' axes",
        ("gyro_g_sensitivity", _) => "g-sensitivity",
        ("accel_delay", _) => "delay",
        ("bias_drift", "deg/h/h") => "gyro drift",
        ("bias_drift", _) => "accelerometer drift",
        ("gyro_scale_asymmetry", _) => "scale-factor asymmetry",
        ("thermal", "deg/h/(degC/min)") => "gyro bias against the temperature rate",
        ("thermal", _) => "temperature coefficient",
        _ => candidate.effect,
    }
}

/// The SPEC §3 effects of candidate `candidate` with parameter values `values`
/// (JSON units), added to `into`. `thermal` adds none: a temperature
/// dependence is not a SPEC §3 effect, and a simulation of the named
/// explanation (the separating turn's search) leaves it out.
pub fn add_effect(into: &mut Effects, candidate: &str, values: &[f64]) {
    match candidate {
        "accel_lever_arm" => {
            let mut l = into.accel_lever_arm.unwrap_or(LeverArms {
                x: [0.0; 3],
                y: [0.0; 3],
                z: [0.0; 3],
            });
            l.x[0] += values[0];
            l.y[1] += values[1];
            l.z[2] += values[2];
            into.accel_lever_arm = Some(l);
        }
        "accel_lever_arm_cross" => {
            let mut l = into.accel_lever_arm.unwrap_or(LeverArms {
                x: [0.0; 3],
                y: [0.0; 3],
                z: [0.0; 3],
            });
            l.x[1] += values[0];
            l.x[2] += values[1];
            l.y[0] += values[2];
            l.y[2] += values[3];
            l.z[0] += values[4];
            l.z[1] += values[5];
            into.accel_lever_arm = Some(l);
        }
        "gyro_g_sensitivity" => {
            let mut g = into.gyro_g_sensitivity.unwrap_or([0.0; 9]);
            for (gi, v) in g.iter_mut().zip(values) {
                *gi += v;
            }
            into.gyro_g_sensitivity = Some(g);
        }
        "accel_delay" => {
            into.accel_delay = Some(into.accel_delay.unwrap_or(0.0) + values[0]);
        }
        "bias_drift" => {
            let mut d = into.bias_drift.unwrap_or(BiasDrift {
                gyro: [0.0; 3],
                accel: [0.0; 3],
            });
            for i in 0..3 {
                d.gyro[i] += values[i];
                d.accel[i] += values[3 + i];
            }
            into.bias_drift = Some(d);
        }
        "gyro_scale_asymmetry" => {
            let mut a = into.gyro_scale_asymmetry.unwrap_or([0.0; 3]);
            for (ai, v) in a.iter_mut().zip(values) {
                *ai += v;
            }
            into.gyro_scale_asymmetry = Some(a);
        }
        _ => {}
    }
}

/// The effects of one candidate parameter alone at its signature size.
pub fn unit_effect(candidate: &Candidate, param: usize) -> Effects {
    let mut values = vec![0.0; candidate.params.len()];
    values[param] = candidate.params[param].signature_size;
    let mut e = Effects::none();
    add_effect(&mut e, candidate.name, &values);
    e
}

/// The values of `candidate`'s parameters that `effects` holds, JSON
/// units (the truth of a simulated run, for comparison).
pub fn values_in(effects: &Effects, candidate: &str) -> Option<Vec<f64>> {
    match candidate {
        "accel_lever_arm" => effects
            .accel_lever_arm
            .map(|l| vec![l.x[0], l.y[1], l.z[2]]),
        "accel_lever_arm_cross" => effects
            .accel_lever_arm
            .map(|l| vec![l.x[1], l.x[2], l.y[0], l.y[2], l.z[0], l.z[1]]),
        "gyro_g_sensitivity" => effects.gyro_g_sensitivity.map(|g| g.to_vec()),
        "accel_delay" => effects.accel_delay.map(|d| vec![d]),
        "bias_drift" => effects
            .bias_drift
            .map(|d| d.gyro.iter().chain(d.accel.iter()).copied().collect()),
        "gyro_scale_asymmetry" => effects.gyro_scale_asymmetry.map(|a| a.to_vec()),
        _ => None,
    }
}

/// Which extra motion separates two candidates that fit this run's gap
/// equally well, from how their signatures depend on the motion.
pub fn separating_motion(a: &str, b: &str) -> String {
    let pair = |x: &str, y: &str| (a == x && b == y) || (a == y && b == x);
    if pair("accel_lever_arm", "accel_delay") {
        "rotations at a second rate: the lever arm's velocity step grows with the rate squared, the delay's with the rate".into()
    } else if pair("gyro_g_sensitivity", "bias_drift") {
        "the first positions repeated at the end of the run: drift changes with time, g-sensitivity only with attitude".into()
    } else if a == "thermal" || b == "thermal" {
        "a hold at a second temperature, or the same turns repeated while the temperature moves: temperature coefficients follow the temperature, not the time or the motion".into()
    } else if a == "gyro_scale_asymmetry" || b == "gyro_scale_asymmetry" {
        "each axis turned both ways by the same angle: asymmetry changes sign with the direction, scale factor does not".into()
    } else if pair("accel_delay", "gyro_g_sensitivity") {
        "a slower rotation about the same axis: the delay's step scales with the rate, g-sensitivity's tilt does not".into()
    } else {
        "rotations about all three body axes in both directions and at two rates".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A diagnosis's result states its model from the candidates it names.
    #[test]
    fn every_candidate_names_a_model_effect() {
        for c in library_with(true) {
            assert!(Effect::from_name(c.effect).is_some(), "{}", c.effect);
        }
    }
}
