//! `sinscal compensate` (a run through a calibration's exact inversion,
//! streaming) and `sinscal export` (the compensation file a navigation
//! computer loads, CONTRACT §5a).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};

use sinscal_core::compensation::{CompensationFile, Provenance};
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::io::run::metadata_sidecar;
use sinscal_core::pipeline::{compensate_file, CompensateTarget};

#[derive(clap::Args)]
pub struct CompensateArgs {
    /// A calibration result (`calibrate --out`) or a compensation file
    /// (`export`).
    pub source: PathBuf,
    /// The run's data file (CSV, gzip CSV or f64le).
    pub run: PathBuf,
    /// Its metadata; default: the sidecar beside it (run.csv → run.json).
    #[arg(long)]
    pub meta: Option<PathBuf>,
    /// The compensated run's data file; its metadata (the run's, with the
    /// applied compensation) goes to the sidecar beside it.
    #[arg(long)]
    pub out: PathBuf,
    /// Its format; default: the run's.
    #[arg(long, value_enum)]
    pub format: Option<DataFormat>,
    /// Gzip the CSV.
    #[arg(long)]
    pub gzip: bool,
    /// Apply a compensation file made for another unit serial.
    #[arg(long)]
    pub any_unit: bool,
}

#[derive(clap::Args)]
pub struct ExportArgs {
    /// A calibration result (`calibrate --out`).
    pub result: PathBuf,
    /// The compensation file: CSV when the name ends in `.csv`, else JSON.
    #[arg(long)]
    pub out: PathBuf,
    /// The unit the calibration is of, written into the file.
    #[arg(long)]
    pub serial: Option<String>,
    /// The run the result came from, written into the file.
    #[arg(long)]
    pub run_id: Option<String>,
}

/// A compensation file from either document, its source named by path.
fn load(path: &Path, provenance: Provenance) -> anyhow::Result<CompensationFile> {
    let text = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let provenance = Provenance {
        source: Some(path.display().to_string()),
        ..provenance
    };
    CompensationFile::load(&text, provenance).with_context(|| format!("in {}", path.display()))
}

pub fn run_compensate(a: &CompensateArgs, meta: &RunMetadata) -> anyhow::Result<()> {
    let meta_path = a.meta.clone().unwrap_or_else(|| metadata_sidecar(&a.run));
    if metadata_sidecar(&a.out) == meta_path {
        bail!(
            "--out {} would overwrite the run's metadata {}",
            a.out.display(),
            meta_path.display()
        );
    }
    let file = load(&a.source, Provenance::default())?;
    for effect in &file.provenance.effects_not_applied {
        eprintln!("warning: the calibration's effect state {effect} is not applied");
    }
    let target = CompensateTarget {
        data: a.out.clone(),
        format: a.format.unwrap_or(meta.format),
        gzip: a.gzip,
        any_unit: a.any_unit,
    };
    let written = compensate_file(&a.run, meta, &file, &target)?;
    eprintln!(
        "wrote {} compensated records to {} ({})",
        written.records,
        written.data.display(),
        written.metadata.display()
    );
    Ok(())
}

pub fn run_export(a: &ExportArgs) -> anyhow::Result<()> {
    if let Some(serial) = &a.serial {
        sinscal_core::io::meta::validate_serial(serial).map_err(anyhow::Error::msg)?;
    }
    let provenance = Provenance {
        unit_serial: a.serial.clone(),
        run_id: a.run_id.clone(),
        ..Provenance::default()
    };
    let file = load(&a.result, provenance)?;
    write_file(&file, &a.out)
}

/// Writes a compensation file, as CSV when `out`'s name ends in `.csv`,
/// else as JSON (`export`'s rule, and `thermal --compensation`'s).
pub fn write_file(file: &CompensationFile, out: &Path) -> anyhow::Result<()> {
    let csv = out.extension().is_some_and(|e| e == "csv");
    let text = if csv { file.to_csv() } else { file.to_json() };
    std::fs::write(out, text).with_context(|| format!("writing {}", out.display()))?;
    eprintln!("wrote {}", out.display());
    Ok(())
}
