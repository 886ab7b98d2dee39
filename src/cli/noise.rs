//! `sinscal noise`: the overlapping Allan deviation of a run's axes and the
//! noise terms read from it, written as NOISE.json with a summary table.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use sinscal_core::io::meta::{write_json, RunMetadata};
use sinscal_core::noise::{NoiseOptions, Span};
use sinscal_core::pipeline::noise_file;

#[derive(clap::Args)]
pub struct NoiseArgs {
    /// The run's data file (CSV, gzip CSV or f64le).
    pub run: PathBuf,
    /// Its metadata; default: the sidecar beside it (run.csv → run.json).
    #[arg(long)]
    pub meta: Option<PathBuf>,
    /// The run has no turns: analyse every record as one stretch, not
    /// only the dwells the pre-scan finds.
    #[arg(long = "static")]
    pub whole_run: bool,
    /// Write the analysis (NOISE.json: terms per axis, the curves, what
    /// they were computed over) here.
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run_noise(a: &NoiseArgs, meta: &RunMetadata) -> anyhow::Result<()> {
    let opts = NoiseOptions {
        span: if a.whole_run {
            Span::WholeRun
        } else {
            Span::Dwells
        },
        ..NoiseOptions::default()
    };
    let report = noise_file(&a.run, meta, &opts, &AtomicBool::new(false))?;
    print!("unit {}\n{}", meta.unit_serial, report.table());
    write_json(&a.out, &report)?;
    eprintln!("wrote {}", a.out.display());
    Ok(())
}
