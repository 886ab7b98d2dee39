//! `sinscal calibrate`: one run's 24 parameters with their 1-σ, printed as
//! a table and written as the full result; `--thermal` adds the in-run
//! thermal states (SPEC §3a).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use sinscal_core::calib::{Effect, ErrorModel, EstimateOptions, EstimatorKind};
use sinscal_core::io::meta::{write_json, RunMetadata};
use sinscal_core::model::Grade;
use sinscal_core::pipeline::calibrate_file;

use super::noise_file::read_noise_file;

#[derive(clap::Args)]
pub struct CalibrateArgs {
    /// The run's data file (CSV, gzip CSV or f64le).
    pub run: PathBuf,
    /// Its metadata; default: the sidecar beside it (run.csv → run.json).
    #[arg(long)]
    pub meta: Option<PathBuf>,
    /// Write the full result (SPEC §5 and more) as JSON here.
    #[arg(long)]
    out: Option<PathBuf>,
    #[arg(long, value_enum, default_value_t = EstimatorKind::default())]
    estimator: EstimatorKind,
    /// Skip the cross-check with the other estimator.
    #[arg(long)]
    no_cross_check: bool,
    /// The error model: `base`, or `base+` SPEC §3 effects joined by `+`
    /// (e.g. `base+accel_lever_arm+accel_delay`), estimated as filter
    /// states beside the 24 parameters.
    #[arg(long, default_value = "base")]
    model: ErrorModel,
    /// Also estimate the biases' and scale factors' linear temperature
    /// coefficients and the gyro bias against Ṫ (SPEC §3a) from the run's
    /// temperature column: model `+thermal`.
    #[arg(long)]
    thermal: bool,
    /// The unit's grade, which sizes the priors; default: the grade the
    /// run's gyro noise names.
    #[arg(long, value_enum)]
    grade: Option<Grade>,
    /// The unit's noise model, known beforehand (e.g. from a long static
    /// recording): a JSON object with the truth file's `noise` terms
    /// (SPEC §2, §2a), used as given; default: measured from the run and
    /// fitted to it.
    #[arg(long)]
    noise: Option<PathBuf>,
    /// The noise model held for the unit (the same JSON as `--noise`),
    /// tested against the run's own fitted model instead of used: the
    /// result says whether the run's noise is still that model
    /// (`noise_model.reference`, and a warning when it is not).
    #[arg(long, conflicts_with = "noise")]
    noise_reference: Option<PathBuf>,
    /// Fit the noise to the run even where its dwells show white noise
    /// alone, when its innovations ask for wander (a bias random walk a
    /// dwell cannot show). Off by default, since a missing effect asks for
    /// wander too: use it where the discrepancy workflow named no effect
    /// for a failed check whose result proposed it.
    #[arg(long, conflicts_with = "noise")]
    fit_unseen_wander: bool,
}

pub fn run_calibrate(a: CalibrateArgs, meta: RunMetadata) -> anyhow::Result<()> {
    let noise = a.noise.as_deref().map(read_noise_file).transpose()?;
    let noise_reference = a
        .noise_reference
        .as_deref()
        .map(read_noise_file)
        .transpose()?;
    let opts = EstimateOptions {
        estimator: a.estimator,
        cross_check: !a.no_cross_check,
        model: if a.thermal {
            a.model.and(Effect::Thermal)
        } else {
            a.model
        },
        grade: a.grade,
        noise,
        noise_reference,
        fit_unseen_wander: a.fit_unseen_wander,
        ..EstimateOptions::default()
    };
    let cancel = AtomicBool::new(false);
    let mut last_stage = String::new();
    let result = calibrate_file(
        &a.run,
        &meta,
        &opts,
        &mut |p| super::print_stage(&p, &mut last_stage),
        &cancel,
    )?;
    print!("unit {}\n{}", meta.unit_serial, result.table());
    if let Some(out) = &a.out {
        write_json(out, &result)?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}
