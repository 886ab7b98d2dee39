//! The run's own noise, as the raw outputs show it: one more streaming
//! read after the pre-scan, the Allan curves of every axis over the dwells
//! it found and the pulse quanta every record shows (`noise::analyse`).
//!
//! The curves are where the model starts, not where it ends: a quantum is
//! exact (every record a whole number of it), and a white density or a
//! wander term the curve resolves is a good start, but a navigation-grade
//! gyro's ARW and bias instability lie under its quantization and its
//! white noise at every τ a dwell offers. The zero-velocity observations
//! settle them (`noise_fit`).

use std::sync::atomic::AtomicBool;

use super::error::CalibError;
use super::prescan::Prescan;
use super::run::{RecordSource, RunInfo};
use crate::estimation::noise_model::{NoiseModel, TriadNoise};
use crate::model::units::{ARCSEC, DEG_PER_H, HOUR, UG};
use crate::noise::{
    analyse, NoiseError, NoiseOptions, NoiseReport, Span, Stretches, Term, TermStatus,
};

/// The longest τ as a fraction of the longest dwell: half, the most an
/// overlapping Allan variance allows, since the fit that follows only
/// starts from these terms.
const MAX_TAU_FRACTION: f64 = 0.5;

/// Measures the run's noise over its dwells. A run whose dwells are too
/// short for an Allan curve keeps the pre-scan's white densities.
pub(crate) fn measure_noise(
    source: &dyn RecordSource,
    run: &RunInfo,
    scan: &Prescan,
    cancel: &AtomicBool,
) -> Result<NoiseModel, CalibError> {
    let windows = scan.dwells().map(|d| (d.t_start, d.t_end)).collect();
    let stretches = Stretches {
        span: Span::Dwells,
        windows,
    };
    let opts = NoiseOptions {
        max_tau_fraction: MAX_TAU_FRACTION,
        ..NoiseOptions::default()
    };
    let records = source
        .records()?
        .map(|r| r.map_err(|e| NoiseError::Source(e.to_string())));
    let fallback = NoiseModel::white(scan.arw, scan.vrw);
    match analyse(records, run.sample_rate_hz, &stretches, &opts, cancel) {
        Ok(report) => Ok(start_model(&report, &fallback, 1.0 / run.sample_rate_hz)),
        Err(NoiseError::TooShort { .. }) => Ok(fallback),
        Err(NoiseError::Cancelled) => Err(CalibError::Cancelled),
        Err(NoiseError::Source(m)) => Err(CalibError::Source(m)),
        Err(e) => Err(CalibError::Unusable(e.to_string())),
    }
}

/// A wander term's start value, SI (`per_unit` SI per report unit): as
/// read where the curve resolves it, else none.
fn start_value(term: &Term, per_unit: f64) -> Option<f64> {
    match term.status {
        TermStatus::Resolved | TermStatus::Fixed => term.value.map(|v| v * per_unit),
        TermStatus::NotResolved => None,
    }
}

/// The white density the pre-scan's first differences give, less what a
/// quantum q puts there: at rest a difference of two increments holds
/// 2N²Δt of white noise and, the remainders being uniform, q²/2 of
/// quantization, so the pre-scan's density² (its difference variance over
/// 2Δt) is N² + q²/(4Δt). Never below a twentieth of the uncorrected
/// value (the search that follows moves it anyway).
fn white_less_quantum(density: f64, quantum: f64, dt: f64) -> f64 {
    let corrected = density * density - quantum * quantum / (4.0 * dt);
    corrected.max((density / 20.0).powi(2)).sqrt()
}

/// A triad's bias instability where the curve resolved it on some axes
/// only: the others start at the resolved axes' mean. The fit scales each
/// triad's term keeping its axes' ratios, so an axis started at zero would
/// stay there, and whether the curve resolves an axis's floor can turn on
/// a single record (the first record of a run, left out when its interval
/// is not known, moved one axis of the reference unit from resolved to
/// not).
fn fill_unresolved(instability: &mut [f64; 3]) {
    let resolved: Vec<f64> = instability.iter().copied().filter(|b| *b > 0.0).collect();
    if resolved.is_empty() {
        return;
    }
    let mean = resolved.iter().sum::<f64>() / resolved.len() as f64;
    for b in instability.iter_mut().filter(|b| **b <= 0.0) {
        *b = mean;
    }
}

/// The start model: per axis, the quantum found, the white density from
/// the pre-scan's first differences less the quantum's share, and any
/// wander the curve resolves (an instability on the other axes of its
/// triad too, `fill_unresolved`).
fn start_model(report: &NoiseReport, fallback: &NoiseModel, dt: f64) -> NoiseModel {
    let rt_h = HOUR.sqrt();
    let mut m = NoiseModel::default();
    for (a, (_, g)) in report.gyro.iter().enumerate() {
        let t: &mut TriadNoise = &mut m.gyro;
        t.quantum[a] = g.quantum_arcsec.map_or(0.0, |q| q * ARCSEC);
        t.white[a] = white_less_quantum(fallback.gyro.white[a], t.quantum[a], dt);
        t.instability[a] = start_value(&g.bias_instability_deg_h, DEG_PER_H).unwrap_or(0.0);
        t.random_walk[a] =
            start_value(&g.rate_random_walk_deg_h_rt_h, DEG_PER_H / rt_h).unwrap_or(0.0);
    }
    for (a, (_, x)) in report.accel.iter().enumerate() {
        let t: &mut TriadNoise = &mut m.accel;
        t.quantum[a] = x.quantum_mps.unwrap_or(0.0);
        t.white[a] = white_less_quantum(fallback.accel.white[a], t.quantum[a], dt);
        t.instability[a] = start_value(&x.bias_instability_ug, UG).unwrap_or(0.0);
        t.random_walk[a] =
            start_value(&x.acceleration_random_walk_ug_rt_h, UG / rt_h).unwrap_or(0.0);
    }
    fill_unresolved(&mut m.gyro.instability);
    fill_unresolved(&mut m.accel.instability);
    m
}

#[cfg(test)]
mod tests {
    use super::fill_unresolved;

    #[test]
    fn an_unresolved_axis_starts_at_its_triads_resolved_mean() {
        let mut b = [0.0, 6.0e-5, 4.0e-5];
        fill_unresolved(&mut b);
        assert_eq!(b, [5.0e-5, 6.0e-5, 4.0e-5]);
        let mut none = [0.0; 3];
        fill_unresolved(&mut none);
        assert_eq!(none, [0.0; 3]);
    }
}
