//! A unit with a thermal truth at realistic sizes, calibrated from runs
//! soaked at five chamber temperatures (SPEC §3a): shared by the thermal
//! test and its benchmark.
#![allow(dead_code)]

use std::collections::BTreeMap;

use nalgebra::Matrix3;
use sinscal_core::calib::sources::calibrate_simulated;
use sinscal_core::calib::thermal_states::RunThermal;
use sinscal_core::calib::EstimateOptions;
use sinscal_core::model::thermal::{TemperatureHistory, ThermalTruth};
use sinscal_core::model::{Effects, ErrorParameters, PARAMETERS};
use sinscal_core::nav::Site;
use sinscal_core::sim::trajectory::Motion;
use sinscal_core::sim::{Noise, Scheme, SimConfig, Trajectory};
use sinscal_core::thermal::{SoakedRun, ThermalModel, REFERENCE_C};

/// The chamber temperatures of the soaks, °C.
pub const SOAK_C: [f64; 5] = [-20.0, 5.0, 25.0, 45.0, 65.0];

/// Linear coefficients (per °C, canonical units): a navigation-grade
/// unit's sizes — thousandths of a deg/h and tenths of a ppm for the
/// gyros, µg and ppm for the accelerometers, hundredths of an arcsec for
/// the mountings. Accelerometer quadratic terms have none.
pub fn linear() -> BTreeMap<&'static str, f64> {
    BTreeMap::from([
        ("gyro_bias_x", 0.0008),
        ("gyro_bias_y", -0.0005),
        ("gyro_bias_z", 0.0006),
        ("gyro_scale_x", 0.2),
        ("gyro_scale_y", -0.15),
        ("gyro_scale_z", 0.25),
        ("gyro_misalign_xy", 0.05),
        ("gyro_misalign_yz", -0.04),
        ("accel_bias_x", 2.0),
        ("accel_bias_y", -1.5),
        ("accel_bias_z", 1.0),
        ("accel_scale_x", 0.5),
        ("accel_scale_y", -0.4),
        ("accel_scale_z", 0.3),
        ("accel_misalign_xy", 0.03),
        ("accel_misalign_zx", -0.03),
    ])
}

/// Quadratic coefficients (per °C²) on a few parameters.
pub fn quadratic() -> BTreeMap<&'static str, f64> {
    BTreeMap::from([
        ("gyro_scale_z", 0.008),
        ("accel_bias_x", 0.02),
        ("accel_scale_y", 0.006),
    ])
}

/// The unit's parameters at `temperature_c` (the paper's Table 1 values at
/// 25 °C).
pub fn parameters_at(temperature_c: f64) -> ErrorParameters {
    let dt = temperature_c - REFERENCE_C;
    let (lin, quad) = (linear(), quadratic());
    let mut map = ErrorParameters::paper().to_canonical();
    for (name, v) in map.iter_mut() {
        *v += lin.get(name.as_str()).copied().unwrap_or(0.0) * dt
            + quad.get(name.as_str()).copied().unwrap_or(0.0) * dt * dt;
    }
    ErrorParameters::from_canonical(&map).unwrap()
}

/// `ten-position` with 600 s dwells (1.7 h) at 20 Hz, navigation-grade
/// noise: the soak's run.
pub fn soak_config(temperature_c: f64, seed: u64) -> SimConfig {
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: 20.0,
        scheme: Scheme::builtin("ten-position", 600.0).unwrap(),
        params: parameters_at(temperature_c),
        effects: Effects::none(),
        noise: Noise {
            gyro_arw_deg_rt_h: 0.0003,
            accel_vrw_ug_rt_hz: 5.0,
            ..Noise::default()
        },
        initial_attitude_error_deg: [0.1, -0.1, 2.0],
        seed,
        thermal: None,
        temperature: None,
    }
}

/// The five soaks of one unit, calibrated.
pub fn soaked_runs(seed: u64) -> Vec<SoakedRun> {
    SOAK_C
        .iter()
        .enumerate()
        .map(|(k, &t)| {
            let cfg = soak_config(t, seed * 10 + k as u64);
            let r = calibrate_simulated(&cfg, &EstimateOptions::default()).unwrap();
            SoakedRun {
                label: format!("soak {t} °C"),
                temperature_c: t,
                parameters: r.parameters,
            }
        })
        .collect()
}

/// Every fitted coefficient's error over its σ: (parameter, term, z).
pub fn coefficient_z(model: &ThermalModel) -> Vec<(String, &'static str, f64)> {
    let (lin, quad) = (linear(), quadratic());
    let paper = ErrorParameters::paper();
    let mut out = Vec::new();
    for (i, p) in PARAMETERS.iter().enumerate() {
        let m = &model.parameters[p.name];
        out.push((
            p.name.to_string(),
            "value",
            (m.value - paper.canonical(i)) / m.sigma,
        ));
        let l = m.linear.unwrap();
        let truth = lin.get(p.name).copied().unwrap_or(0.0);
        out.push((p.name.to_string(), "linear", (l.value - truth) / l.sigma));
        if let Some(q) = m.quadratic {
            let truth = quad.get(p.name).copied().unwrap_or(0.0);
            out.push((p.name.to_string(), "quadratic", (q.value - truth) / q.sigma));
        }
    }
    out
}

/// Quadratic terms the fit kept where the truth has none, and those it
/// missed where the truth has one.
pub fn quadratic_errors(model: &ThermalModel) -> (Vec<String>, Vec<String>) {
    let quad = quadratic();
    let mut invented = Vec::new();
    let mut missed = Vec::new();
    for (name, m) in &model.parameters {
        match (m.quadratic.is_some(), quad.contains_key(name.as_str())) {
            (true, false) => invented.push(name.clone()),
            (false, true) => missed.push(name.clone()),
            _ => {}
        }
    }
    (invented, missed)
}

/// k per gyro, deg/h per (°C/min): an RLG's bias under a temperature
/// gradient, a few hundredths at most.
pub const GYRO_BIAS_RATE: [f64; 3] = [0.02, -0.015, 0.01];

/// The chamber's profile for the in-run test: 10 °C rising 0.2 °C/min to
/// 50 °C (200 min), then held.
pub fn ramp_history() -> TemperatureHistory {
    TemperatureHistory::Ramp {
        start_c: 10.0,
        rate_c_per_min: 0.2,
        max_c: 50.0,
    }
}

/// `ten-position-9+9` three times over with 300 s dwells (57 dwells, 4.8
/// h): the turns that show the scale factors and mountings at many
/// temperatures along the ramp.
pub fn ramp_scheme() -> Scheme {
    let once = Scheme::builtin("ten-position-9+9", 300.0).unwrap();
    let mut steps = once.steps.clone();
    for _ in 1..3 {
        // Each repeat starts where the last ended; its first dwell would
        // double the last one.
        steps.extend(once.steps[1..].iter().copied());
    }
    Scheme {
        name: "ten-position-9+9 x3".into(),
        steps,
    }
}

/// The unit's SPEC §3a truth for a run across temperature: every linear
/// coefficient of [`linear`] and the gyro bias against Ṫ; no quadratic
/// terms, which the in-run states do not carry (soaks find them).
pub fn ramp_truth() -> ThermalTruth {
    let lin: BTreeMap<String, f64> = linear()
        .into_iter()
        .map(|(n, v)| (n.to_string(), v))
        .collect();
    ThermalTruth::from_canonical(&lin, &BTreeMap::new(), GYRO_BIAS_RATE).unwrap()
}

/// [`ramp_scheme`] at 20 Hz while the chamber ramps 10 → 50 °C and
/// holds, navigation-grade noise; the parameters at 25 °C are the
/// paper's Table 1 values.
pub fn ramp_config(seed: u64) -> SimConfig {
    SimConfig {
        scheme: ramp_scheme(),
        params: ErrorParameters::paper(),
        thermal: Some(ramp_truth()),
        temperature: Some(ramp_history()),
        ..soak_config(REFERENCE_C, seed)
    }
}

/// A ramp result's thermal coefficients against the truth: (name, z) for
/// the 21 linear coefficients the states carry and the three k.
pub fn ramp_coefficient_z(thermal: &RunThermal) -> Vec<(String, f64)> {
    chamber_errors(thermal, &ramp_truth())
        .into_iter()
        .map(|(name, err, sigma, _)| (name, err / sigma))
        .collect()
}

/// A chamber profile for in-run thermal calibration at a line's rate:
/// `ten-position-9+9` with 600 s dwells (11 625 s) while the temperature
/// moves 40 °C over the first 7000 s and then holds (the hold starts
/// 241.5 s into the twelfth dwell).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChamberRamp {
    /// 10 → 50 °C.
    Rising,
    /// 50 → 10 °C.
    Falling,
    /// 10 → 40 °C, stopping at the exact middle of the eighth dwell.
    StopsMidDwell,
}

/// The linear coefficients of the unit ramped in [`ChamberRamp`] runs
/// (per °C, canonical units): larger than [`linear`], the accelerometer
/// terms tens of µg and ppm over the ramp.
pub fn chamber_linear() -> BTreeMap<&'static str, f64> {
    BTreeMap::from([
        ("gyro_bias_x", 0.0012),
        ("gyro_bias_y", -0.0008),
        ("gyro_bias_z", 0.0015),
        ("gyro_scale_x", 0.6),
        ("gyro_scale_z", 0.5),
        ("accel_bias_x", 12.0),
        ("accel_bias_y", -8.0),
        ("accel_bias_z", 15.0),
        ("accel_scale_x", 9.0),
        ("accel_scale_z", 11.0),
    ])
}

/// k of the [`ChamberRamp`] unit, deg/h per (°C/min).
pub const CHAMBER_GYRO_BIAS_RATE: [f64; 3] = [0.01, -0.008, 0.012];

/// The [`ChamberRamp`] unit's SPEC §3a truth, with quadratic terms
/// (per °C², canonical units) the in-run states do not carry.
pub fn chamber_truth(quadratic: &[(&str, f64)]) -> ThermalTruth {
    let lin = chamber_linear()
        .into_iter()
        .map(|(n, v)| (n.to_string(), v))
        .collect();
    let quad = quadratic.iter().map(|(n, v)| (n.to_string(), *v)).collect();
    ThermalTruth::from_canonical(&lin, &quad, CHAMBER_GYRO_BIAS_RATE).unwrap()
}

/// A [`ChamberRamp`] run at `rate_hz` of the paper's Table 1 unit (at
/// 25 °C) with the [`chamber_truth`], started 0.2°, 0.1° off level and
/// 123° off in heading.
pub fn chamber_config(ramp: ChamberRamp, rate_hz: f64, noise: Noise, seed: u64) -> SimConfig {
    let scheme = Scheme::builtin("ten-position-9+9", 600.0).unwrap();
    let trajectory = Trajectory::new(&scheme, &Matrix3::identity(), &Site::REFERENCE).unwrap();
    let dwells: Vec<_> = trajectory
        .segments()
        .iter()
        .filter(|s| matches!(s.motion, Motion::Dwell))
        .map(|s| (s.t0, s.t1))
        .collect();
    let end = dwells.last().unwrap().1 + 100.0;
    let (from_c, to_c, stop_s) = match ramp {
        ChamberRamp::Rising => (10.0, 50.0, 7000.0),
        ChamberRamp::Falling => (50.0, 10.0, 7000.0),
        ChamberRamp::StopsMidDwell => (10.0, 40.0, 0.5 * (dwells[7].0 + dwells[7].1)),
    };
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: rate_hz,
        scheme,
        params: ErrorParameters::paper(),
        effects: Effects::none(),
        noise,
        initial_attitude_error_deg: [0.2, 0.1, 123.0],
        seed,
        thermal: Some(chamber_truth(&[])),
        temperature: Some(TemperatureHistory::Points(vec![
            [0.0, from_c],
            [stop_s, to_c],
            [end, to_c],
        ])),
    }
}

/// A ramp result's thermal coefficients against `truth`: (name, error,
/// σ, truth) for the linear coefficients the states carry and the three
/// k.
pub fn chamber_errors(thermal: &RunThermal, truth: &ThermalTruth) -> Vec<(String, f64, f64, f64)> {
    let mut out = Vec::new();
    for (i, p) in PARAMETERS.iter().enumerate() {
        if let Some(l) = thermal.parameters[p.name].linear {
            let t = truth.linear(i);
            out.push((format!("{} linear", p.name), l.value - t, l.sigma, t));
        }
    }
    for (axis, k) in ["x", "y", "z"].iter().zip(truth.gyro_bias_rate()) {
        let got = thermal.gyro_bias_rate[*axis];
        out.push((
            format!("gyro_bias_rate {axis}"),
            got.value - k,
            got.sigma,
            k,
        ));
    }
    out
}
