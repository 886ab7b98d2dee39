//! A unit with a thermal truth at realistic sizes, calibrated from runs
//! soaked at five chamber temperatures (SPEC §3a): shared by the thermal
//! test and its benchmark.
#![allow(dead_code)]

use std::collections::BTreeMap;

use sinscal::calib::sources::calibrate_simulated;
use sinscal::calib::EstimateOptions;
use sinscal::model::{Effects, ErrorParameters, PARAMETERS};
use sinscal::nav::Site;
use sinscal::sim::{Noise, Scheme, SimConfig};
use sinscal::thermal::{SoakedRun, ThermalModel, REFERENCE_C};

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
