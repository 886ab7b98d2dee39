//! `sinscal import`: logs of other formats written as runs of the contract.

use std::path::PathBuf;

use sinscal_core::io::data::DataFormat;
use sinscal_core::io::psins::import_psins;

#[derive(clap::Subcommand)]
pub enum ImportCommand {
    /// A PSINS SIMU text log (`imufile.m`: three header lines, then six
    /// whole counts a record and an optional time dither in µs): the run's
    /// increments (rad, m/s) and run.json with its site, g and rate.
    Psins(PsinsArgs),
}

#[derive(clap::Args)]
pub struct PsinsArgs {
    /// The log (.imu).
    pub log: PathBuf,
    /// The folder to write run.csv (or run.bin) and run.json into.
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long, value_enum, default_value_t = DataFormat::Csv)]
    pub format: DataFormat,
    /// The unit's serial in run.json; default: PSINS- and the log's name.
    #[arg(long)]
    pub unit_serial: Option<String>,
}

pub fn run_import(c: &ImportCommand) -> anyhow::Result<()> {
    match c {
        ImportCommand::Psins(a) => {
            let serial = a.unit_serial.clone().unwrap_or_else(|| {
                let stem = a
                    .log
                    .file_stem()
                    .map_or("log".into(), |s| s.to_string_lossy().into_owned());
                let clean: String = stem
                    .chars()
                    .map(|c| {
                        if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                            c
                        } else {
                            '-'
                        }
                    })
                    .collect();
                format!("PSINS-{clean}")
            });
            let run = import_psins(&a.log, &a.out, a.format, &serial)?;
            let h = &run.header;
            println!(
                "{} records at {} Hz ({:.1} s), site {:.6}°, {:.6}°, {} m, g {} m/s²; \
                 gyro {:?} arcsec/count, accel {:?} ug*s/count{}",
                run.records,
                1000.0 / h.interval_ms,
                run.records as f64 * h.interval_ms * 1e-3,
                h.latitude_deg,
                h.longitude_deg,
                h.height_m,
                h.gravity_mps2,
                h.gyro_arcsec_per_count,
                h.accel_ug_s_per_count,
                if h.dither_column {
                    "; stamps dithered"
                } else {
                    ""
                }
            );
            eprintln!(
                "wrote {} and {}",
                run.data.display(),
                run.metadata.display()
            );
            Ok(())
        }
    }
}
