//! `sinscal import`: logs of other formats written as runs of the contract.

use std::path::{Path, PathBuf};

use sinscal_core::io::data::DataFormat;
use sinscal_core::io::imu_tk::{import_imu_tk, ImuTkImport, NominalTriad};
use sinscal_core::io::mcap::{import_mcap, Clock, McapImport};
use sinscal_core::io::psins::import_psins;
use sinscal_core::nav::Site;

#[derive(clap::Subcommand)]
pub enum ImportCommand {
    /// A PSINS SIMU text log (`imufile.m`: three header lines, then six
    /// whole counts a record and an optional time dither in µs): the run's
    /// increments (rad, m/s) and run.json with its site, g and rate.
    Psins(PsinsArgs),
    /// A ROS 2 recording (MCAP, uncompressed chunks) of one
    /// `sensor_msgs/msg/Imu` topic in CDR: the run's rates (rad/s, m/s²) at
    /// the header stamps, and run.json with the given site and the rate
    /// from the median step.
    Mcap(McapArgs),
    /// An imu_tk recording (two text files of `t x y z`, accelerometer and
    /// gyro, raw samples at the same stamps): run.csv of the counts as
    /// recorded and run.json with the datasheet's nominal conversion.
    ImuTk(ImuTkArgs),
}

#[derive(clap::Args)]
pub struct McapArgs {
    /// The recording (.mcap).
    pub recording: PathBuf,
    /// The Imu topic.
    #[arg(long, default_value = "/imu")]
    pub topic: String,
    /// The folder to write run.csv and run.json into.
    #[arg(long)]
    pub out: PathBuf,
    /// The unit's serial in run.json; default: MCAP- and the file's name.
    #[arg(long, visible_alias = "serial")]
    pub unit_serial: Option<String>,
    /// Where the unit stood, deg (a recording does not say).
    #[arg(long, allow_hyphen_values = true)]
    pub latitude: f64,
    #[arg(long, allow_hyphen_values = true)]
    pub longitude: f64,
    /// Ellipsoidal height, m.
    #[arg(long, allow_hyphen_values = true)]
    pub height: f64,
    /// Measured local gravity, m/s² (SPEC §1); default: the formula's.
    #[arg(long)]
    pub gravity: Option<f64>,
}

#[derive(clap::Args)]
pub struct ImuTkArgs {
    /// The accelerometer file (e.g. imu_tk's xsens_acc.mat).
    #[arg(long)]
    pub accel: PathBuf,
    /// The gyro file.
    #[arg(long)]
    pub gyro: PathBuf,
    /// The folder to write run.csv and run.json into.
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long)]
    pub unit_serial: String,
    #[arg(long, allow_hyphen_values = true)]
    pub latitude: f64,
    #[arg(long, allow_hyphen_values = true)]
    pub longitude: f64,
    #[arg(long, allow_hyphen_values = true)]
    pub height: f64,
    /// Local gravity, m/s² (default: SPEC §1's model at the site).
    #[arg(long)]
    pub gravity: Option<f64>,
    /// The accelerometer counts that read zero, x,y,z.
    #[arg(long, value_parser = triad, allow_hyphen_values = true)]
    pub accel_offset: [f64; 3],
    /// Accelerometer counts per m/s², x,y,z.
    #[arg(long, value_parser = triad, allow_hyphen_values = true)]
    pub accel_scale: [f64; 3],
    /// The gyro counts that read zero, x,y,z.
    #[arg(long, value_parser = triad, allow_hyphen_values = true)]
    pub gyro_offset: [f64; 3],
    /// Gyro counts per rad/s, x,y,z.
    #[arg(long, value_parser = triad, allow_hyphen_values = true)]
    pub gyro_scale: [f64; 3],
}

/// A flag's three values, `x,y,z`.
fn triad(text: &str) -> Result<[f64; 3], String> {
    let values = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("`{v}`: {e}")))
        .collect::<Result<Vec<f64>, String>>()?;
    let n = values.len();
    values
        .try_into()
        .map_err(|_| format!("three values x,y,z, not {n}"))
}

fn run_imu_tk(a: &ImuTkArgs) -> anyhow::Result<()> {
    let how = ImuTkImport {
        unit_serial: a.unit_serial.clone(),
        site: Site {
            gravity_mps2: a.gravity,
            ..Site::new(a.latitude, a.longitude, a.height)
        },
        accel: NominalTriad {
            offset: a.accel_offset,
            counts_per_unit: a.accel_scale,
        },
        gyro: NominalTriad {
            offset: a.gyro_offset,
            counts_per_unit: a.gyro_scale,
        },
    };
    let run = import_imu_tk(&a.accel, &a.gyro, &a.out, &how)?;
    println!(
        "{} records at {:.3} Hz (the median step of the first stamps)",
        run.records, run.sample_rate_hz
    );
    eprintln!(
        "wrote {} and {}",
        run.data.display(),
        run.metadata.display()
    );
    Ok(())
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
        ImportCommand::ImuTk(a) => run_imu_tk(a),
        ImportCommand::Psins(a) => {
            let serial = a
                .unit_serial
                .clone()
                .unwrap_or_else(|| default_serial("PSINS", &a.log));
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
        ImportCommand::Mcap(a) => run_mcap(a),
    }
}

/// `PREFIX-` and the file's name, made a valid serial.
fn default_serial(prefix: &str, file: &Path) -> String {
    let stem = file
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
    format!("{prefix}-{clean}")
}

fn run_mcap(a: &McapArgs) -> anyhow::Result<()> {
    let serial = a
        .unit_serial
        .clone()
        .unwrap_or_else(|| default_serial("MCAP", &a.recording));
    let site = Site {
        gravity_mps2: a.gravity,
        ..Site::new(a.latitude, a.longitude, a.height)
    };
    let options = McapImport {
        topic: &a.topic,
        unit_serial: &serial,
        site,
    };
    let run = import_mcap(&a.recording, &a.out, &options)?;
    let s = &run.source;
    println!(
        "{} messages of {} at {} Hz (median step {} ns, {:.1} s), frame {:?}, times from {}",
        s.messages,
        s.topic,
        run.sample_rate_hz,
        s.median_step_ns,
        run.duration_s,
        s.frame_id,
        match s.clock {
            Clock::HeaderStamp => "the header stamps",
            Clock::LogTime => "the log time (header stamps zero)",
        }
    );
    eprintln!(
        "wrote {} and {}",
        run.data.display(),
        run.metadata.display()
    );
    Ok(())
}
