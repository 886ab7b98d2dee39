//! The discrepancy workflow's temperature candidate (SPEC §3a): a run whose
//! chamber rises 2 °C/min from 10 to 30 °C and holds, of a unit whose
//! parameters move with temperature and whose gyro biases follow Ṫ (the
//! truth of `tests/suite/thermal_support`), has its gap named `thermal` and
//! shrunk to the noise; the same run of a unit without a temperature
//! dependence names nothing.

use crate::thermal_support;

use std::sync::atomic::AtomicBool;

use sinscal_core::calib::sources::SimSource;
use sinscal_core::calib::RunInfo;
use sinscal_core::diagnose::{diagnose, DiagnoseOptions, DiagnoseReport};
use sinscal_core::model::thermal::{TemperatureHistory, ThermalTruth};
use sinscal_core::sim::{Noise, Scheme, SimConfig};

/// The paper's 9+9 scheme with 120 s dwells (~45 min) at 20 Hz,
/// navigation-grade noise, the chamber ramp above; `thermal` the unit's.
fn ramped(thermal: Option<ThermalTruth>, seed: u64) -> SimConfig {
    SimConfig {
        scheme: Scheme::builtin("ten-position-9+9", 120.0).unwrap(),
        noise: Noise::default_navigation_grade(),
        thermal,
        temperature: Some(TemperatureHistory::Ramp {
            start_c: 10.0,
            rate_c_per_min: 2.0,
            max_c: 30.0,
        }),
        ..thermal_support::soak_config(25.0, seed)
    }
}

fn diagnosed(cfg: SimConfig) -> DiagnoseReport {
    let run = RunInfo {
        site: cfg.site,
        sample_rate_hz: cfg.sample_rate_hz,
    };
    let opts = DiagnoseOptions::default();
    diagnose(
        &SimSource(cfg),
        &run,
        &opts,
        &mut |_| {},
        &AtomicBool::new(false),
    )
    .unwrap()
}

#[test]
fn a_unit_that_moves_with_temperature_is_named_thermal() {
    let report = diagnosed(ramped(Some(thermal_support::ramp_truth()), 3));
    eprintln!(
        "named {:?}; gap {:.3e} → {:.3e} m/s, floor {:.3e}",
        report.named, report.gap_rms_before, report.gap_rms_after, report.noise_floor_rms
    );
    assert_eq!(report.named, ["thermal"], "{}", report.verdict);
    assert!(report.gap_excess_after < 0.2 * report.gap_excess_before);
    // The calibration with the effect carries the coefficients: k within
    // 4σ of the truth.
    let k = &report.calibration.effects;
    let kx = k
        .get("thermal.gyro_bias_rate.x")
        .unwrap_or_else(|| panic!("{k:?}"));
    let z = (kx.value - thermal_support::GYRO_BIAS_RATE[0]) / kx.sigma;
    assert!(z.abs() < 4.0, "k_x {kx:?}: {z:.2}σ");
}

#[test]
fn a_unit_that_does_not_is_not() {
    let report = diagnosed(ramped(None, 4));
    assert!(report.named.is_empty(), "{}", report.verdict);
}
