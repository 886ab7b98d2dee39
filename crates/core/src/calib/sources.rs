//! Record sources that need no files: a simulation regenerated on every
//! pass (tests, planning), and any in-memory slice (short runs).

use std::sync::atomic::AtomicBool;

use super::error::CalibError;
use super::estimate::estimate;
use super::options::EstimateOptions;
use super::result::CalibrationResult;
use super::run::{RecordSource, RunInfo};
use super::temperature::TemperatureCurve;
use crate::estimation::NoiseDensity;
use crate::record::Record;
use crate::sim::{simulate, Noise, SimConfig};

/// A simulated run, generated afresh (and identically) for every pass.
pub struct SimSource(pub SimConfig);

impl RecordSource for SimSource {
    fn records(
        &self,
    ) -> Result<Box<dyn Iterator<Item = Result<Record, CalibError>> + '_>, CalibError> {
        let sim = simulate(&self.0).map_err(|e| CalibError::Source(e.to_string()))?;
        Ok(Box::new(sim.map(Ok)))
    }

    /// The simulated temperature once a second, as a file's column
    /// decimates it (each point in the middle of its second).
    fn temperature(&self) -> Result<Option<TemperatureCurve>, CalibError> {
        if !self.0.temperature_column() {
            return Ok(None);
        }
        let sim = simulate(&self.0).map_err(|e| CalibError::Source(e.to_string()))?;
        let duration_s = sim.n_records() as f64 * sim.dt();
        let points = (0..duration_s.floor() as u64)
            .filter_map(|s| {
                let t = s as f64 + 0.5;
                sim.temperature_c(t).map(|c| (t, c))
            })
            .collect();
        Ok(TemperatureCurve::from_points(points))
    }
}

/// Calibrates a simulated run with `opts` at the simulation's own site
/// and rate, with no progress reports and no cancellation: what planning,
/// the tests and the benchmarks do with a simulation.
pub fn calibrate_simulated(
    cfg: &SimConfig,
    opts: &EstimateOptions,
) -> Result<CalibrationResult, CalibError> {
    let run = RunInfo {
        site: cfg.site,
        sample_rate_hz: cfg.sample_rate_hz,
    };
    estimate(
        &SimSource(cfg.clone()),
        &run,
        opts,
        &mut |_| {},
        &AtomicBool::new(false),
    )
}

/// [`calibrate_simulated`] with the run simulated once and held in memory
/// rather than simulated afresh for every pass: the same records and the
/// same result, a third less work. For tests and benchmarks of runs that
/// fit in memory; it carries no temperature column.
pub fn calibrate_in_memory(
    cfg: &SimConfig,
    opts: &EstimateOptions,
) -> Result<CalibrationResult, CalibError> {
    let records: Vec<Record> = simulate(cfg)
        .map_err(|e| CalibError::Source(e.to_string()))?
        .collect();
    let run = RunInfo {
        site: cfg.site,
        sample_rate_hz: cfg.sample_rate_hz,
    };
    estimate(
        &SliceSource(&records),
        &run,
        opts,
        &mut |_| {},
        &AtomicBool::new(false),
    )
}

/// Records already in memory.
pub struct SliceSource<'a>(pub &'a [Record]);

impl RecordSource for SliceSource<'_> {
    fn records(
        &self,
    ) -> Result<Box<dyn Iterator<Item = Result<Record, CalibError>> + '_>, CalibError> {
        Ok(Box::new(self.0.iter().copied().map(Ok)))
    }
}

/// The noise model of a simulated unit, as a filter told the truth would
/// assume it (`--known-noise` in the benchmarks).
impl From<&Noise> for NoiseDensity {
    fn from(n: &Noise) -> Self {
        NoiseDensity {
            gyro_arw_deg_rt_h: n.gyro_arw_deg_rt_h,
            accel_vrw_ug_rt_hz: n.accel_vrw_ug_rt_hz,
            gyro_bias_instability_deg_h: n.gyro_bias_instability_deg_h,
            accel_bias_instability_ug: n.accel_bias_instability_ug,
            gyro_rrw_deg_h_rt_h: n.gyro_rrw_deg_h_rt_h,
            accel_rw_ug_rt_h: n.accel_rw_ug_rt_h,
            gyro_quantum_arcsec: n.gyro_quantum_arcsec,
            accel_quantum_mps: n.accel_quantum_mps,
        }
    }
}
