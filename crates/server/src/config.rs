//! The server's configuration: the `serve` flags (each also read from an
//! environment variable), their embedded defaults, written once in
//! [`defaults`], and the resolved [`Config`] that the API, the job runner
//! and the application share.
//!
//! A leaf: it knows the library's option types (`EstimateOptions`, the
//! parameter table) but nothing of the server that reads it, so `api`,
//! `jobs` and `server` can all depend on it without depending on each
//! other.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::runstore::RunStoreSpec;
use sinscal_core::calib::{Effect, ErrorModel, EstimateOptions};
use sinscal_core::model::{Group, PARAMETERS};

/// The embedded defaults: what `serve` uses with neither a flag nor its
/// environment variable, and what [`Config::new`] starts from. The flags
/// name these constants, so the two cannot drift apart.
pub mod defaults {
    /// Folder of the database and the run files.
    pub const DATA_DIR: &str = "./sinscal-data";
    /// Loopback only: exposing the server is a deliberate choice.
    pub const BIND: &str = "127.0.0.1:8080";
    /// A 3.2 h run at 200 Hz as CSV is about 1.5 GB.
    pub const MAX_BODY_BYTES: u64 = 2 << 30;
    pub const MAX_DECOMPRESSED_BYTES: u64 = 8 << 30;
    pub const MAX_QUEUE: i64 = 1000;
    pub const LEASE_SECS: f64 = 30.0;
    pub const MAX_ATTEMPTS: i64 = 3;
    pub const SHUTDOWN_GRACE_SECS: f64 = 20.0;
    pub const DIAGNOSE_INADEQUATE: bool = true;
    pub const THERMAL_AUTO: bool = true;
    pub const UPLOAD_IDLE_SECS: f64 = 30.0;
    /// A station on a slow line still sends 100 kB/s; 10 kB/s is a stall.
    pub const UPLOAD_MIN_RATE: u64 = 10_000;
    pub const UPLOAD_RATE_GRACE_SECS: f64 = 10.0;
    /// A 2 GiB CSV validates in about 20 s of CPU.
    pub const UPLOAD_MAX_CPU_SECS: f64 = 120.0;
    pub const MAX_COMMENT_LINES: u64 = 10_000;
    pub const MAX_EXPANSION_RATIO: u64 = 200;
    pub const MIN_FREE_BYTES: u64 = 256 << 20;
    /// A Table 1 design at navigation-grade noise takes 15–30 s here.
    pub const DESIGN_TIME_LIMIT_SECS: f64 = 60.0;
    /// A design job's limit: what the synchronous request's time-out
    /// points to, so long enough for any design a station needs.
    pub const DESIGN_JOB_TIME_LIMIT_SECS: f64 = 900.0;
    /// Not flags: the pause before a failed job is retried, and the
    /// concurrency limits of the HTTP layer.
    pub const RETRY_BACKOFF_SECS: u64 = 2;
    pub const MAX_CONCURRENT_UPLOADS: usize = 16;
    pub const MAX_CONCURRENT_REQUESTS: usize = 512;
}

/// A configuration value out of its range, or an unreadable tolerances
/// file. The message names the flag.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{0}")]
    Invalid(String),
    #[error("reading {path}: {source}")]
    Read {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

/// `sinscal serve` flags; each also reads an environment variable, and
/// with neither the embedded default applies.
#[derive(clap::Args, Clone, Debug)]
pub struct ServeArgs {
    /// Folder of the database (sinscal.db) and the run files (runs/).
    #[arg(long, env = "SINSCAL_DATA_DIR", default_value = defaults::DATA_DIR)]
    pub data_dir: PathBuf,
    /// The database: `sqlite:PATH` (default: `sinscal.db` in the data
    /// folder) or `postgres://USER:PASSWORD@HOST/DB`, which any number of
    /// servers and workers on other machines can share.
    #[arg(long, env = "SINSCAL_DATABASE_URL")]
    pub database_url: Option<String>,
    /// Address to listen on; port 0 picks a free port (printed at start).
    #[arg(long, env = "SINSCAL_BIND", default_value = defaults::BIND)]
    pub bind: String,
    /// Calibration workers in this process; default one per core, 0 for
    /// a server that only answers the API (workers run elsewhere:
    /// `sinscal worker`).
    #[arg(long, env = "SINSCAL_WORKERS")]
    pub workers: Option<usize>,
    /// Largest upload body, bytes (default 2 GiB).
    #[arg(long, env = "SINSCAL_MAX_BODY_BYTES", default_value_t = defaults::MAX_BODY_BYTES)]
    pub max_body_bytes: u64,
    /// Most bytes a gzip upload may expand to (stops gzip bombs).
    #[arg(long, env = "SINSCAL_MAX_DECOMPRESSED_BYTES",
          default_value_t = defaults::MAX_DECOMPRESSED_BYTES)]
    pub max_decompressed_bytes: u64,
    /// Queued jobs beyond which uploads are answered 503 + Retry-After.
    #[arg(long, env = "SINSCAL_MAX_QUEUE", default_value_t = defaults::MAX_QUEUE)]
    pub max_queue: i64,
    /// Job lease, seconds; a worker renews it every third of it.
    #[arg(long, env = "SINSCAL_LEASE_SECS", default_value_t = defaults::LEASE_SECS)]
    pub lease_secs: f64,
    /// Attempts per job before it fails for good.
    #[arg(long, env = "SINSCAL_MAX_ATTEMPTS", default_value_t = defaults::MAX_ATTEMPTS)]
    pub max_attempts: i64,
    /// At SIGTERM, how long running jobs may take to finish before they
    /// are handed back to the queue, seconds.
    #[arg(long, env = "SINSCAL_SHUTDOWN_GRACE_SECS",
          default_value_t = defaults::SHUTDOWN_GRACE_SECS)]
    pub shutdown_grace_secs: f64,
    /// The error model of every calibrate job: `base`, or `base+` SPEC §3
    /// effects joined by `+` (e.g. `base+accel_lever_arm+accel_delay`),
    /// estimated as filter states beside the 24 parameters.
    #[arg(long, env = "SINSCAL_MODEL", default_value = "base")]
    pub model: ErrorModel,
    /// Calibrate a run whose temperature column spans 3 °C or more with
    /// the in-run thermal states (SPEC §3a) as well (`true` or `false`);
    /// with `false` its result only proposes them.
    #[arg(long, env = "SINSCAL_THERMAL_AUTO",
          default_value_t = defaults::THERMAL_AUTO, action = clap::ArgAction::Set)]
    pub thermal_auto: bool,
    /// Queue a diagnose job for every run whose calibration fails its
    /// model check (`true` or `false`).
    #[arg(long, env = "SINSCAL_DIAGNOSE_INADEQUATE",
          default_value_t = defaults::DIAGNOSE_INADEQUATE, action = clap::ArgAction::Set)]
    pub diagnose_inadequate: bool,
    /// An upload whose body sends nothing for this long is refused (408)
    /// and its slot freed, seconds.
    #[arg(long, env = "SINSCAL_UPLOAD_IDLE_SECS", default_value_t = defaults::UPLOAD_IDLE_SECS)]
    pub upload_idle_secs: f64,
    /// Least mean upload rate, bytes/s, enforced after the grace period.
    #[arg(long, env = "SINSCAL_UPLOAD_MIN_RATE", default_value_t = defaults::UPLOAD_MIN_RATE)]
    pub upload_min_rate: u64,
    /// Seconds from the start of a body before the minimum rate applies.
    #[arg(long, env = "SINSCAL_UPLOAD_RATE_GRACE_SECS",
          default_value_t = defaults::UPLOAD_RATE_GRACE_SECS)]
    pub upload_rate_grace_secs: f64,
    /// CPU seconds one upload's validation may use (a 2 GiB CSV needs
    /// about 20 s).
    #[arg(long, env = "SINSCAL_UPLOAD_MAX_CPU_SECS",
          default_value_t = defaults::UPLOAD_MAX_CPU_SECS)]
    pub upload_max_cpu_secs: f64,
    /// Most comment and blank lines in an uploaded CSV.
    #[arg(long, env = "SINSCAL_MAX_COMMENT_LINES", default_value_t = defaults::MAX_COMMENT_LINES)]
    pub max_comment_lines: u64,
    /// Most decompressed bytes per compressed byte of a gzip upload
    /// (checked past 16 MiB decompressed).
    #[arg(long, env = "SINSCAL_MAX_EXPANSION_RATIO",
          default_value_t = defaults::MAX_EXPANSION_RATIO)]
    pub max_expansion_ratio: u64,
    /// Free bytes the data folder's filesystem must keep: below it uploads
    /// are answered 507 and /readyz 503.
    #[arg(long, env = "SINSCAL_MIN_FREE_BYTES", default_value_t = defaults::MIN_FREE_BYTES)]
    pub min_free_bytes: u64,
    /// Wall time one scheme design over HTTP may take, seconds.
    #[arg(long, env = "SINSCAL_DESIGN_TIME_LIMIT_SECS",
          default_value_t = defaults::DESIGN_TIME_LIMIT_SECS)]
    pub design_time_limit_secs: f64,
    /// Wall time one design job (`POST /designs`, the design page) may
    /// take, seconds.
    #[arg(long, env = "SINSCAL_DESIGN_JOB_TIME_LIMIT_SECS",
          default_value_t = defaults::DESIGN_JOB_TIME_LIMIT_SECS)]
    pub design_job_time_limit_secs: f64,
    /// JSON object of repeatability tolerances by parameter name
    /// (canonical units), replacing the defaults it names.
    #[arg(long, env = "SINSCAL_TOLERANCES")]
    pub tolerances: Option<PathBuf>,
    /// Where run files are kept: absent (or `local`), `runs/` in the data
    /// folder; `s3://bucket/prefix`, objects under that prefix of an
    /// S3-compatible store, its endpoint, region and credentials from
    /// AWS_ENDPOINT_URL, AWS_REGION, AWS_ACCESS_KEY_ID,
    /// AWS_SECRET_ACCESS_KEY (and AWS_ALLOW_HTTP=true for a plain-HTTP
    /// endpoint).
    #[arg(long, env = "SINSCAL_RUN_STORE")]
    pub run_store: Option<RunStoreSpec>,
}

/// How slow an upload body may be.
#[derive(Clone, Copy, Debug)]
pub struct BodyPace {
    /// Longest wait for the next chunk.
    pub idle: Duration,
    /// Least mean rate over the body so far, bytes/s …
    pub min_bytes_per_s: u64,
    /// … enforced from this long after the body started.
    pub grace: Duration,
}

/// The resolved configuration.
#[derive(Clone, Debug)]
pub struct Config {
    pub data_dir: PathBuf,
    /// `--database-url` as given; `None`: SQLite in the data folder.
    pub database_url: Option<String>,
    pub bind: String,
    pub workers: usize,
    pub max_body_bytes: u64,
    pub max_decompressed_bytes: u64,
    pub max_queue: i64,
    pub lease: Duration,
    pub max_attempts: i64,
    pub shutdown_grace: Duration,
    pub retry_backoff: Duration,
    pub max_concurrent_uploads: usize,
    pub max_concurrent_requests: usize,
    /// Idle timeout, minimum rate and grace of an upload body.
    pub upload_pace: BodyPace,
    /// CPU time one upload's validation may use.
    pub upload_max_cpu: Duration,
    /// Most comment and blank lines in an uploaded CSV.
    pub max_comment_lines: u64,
    /// Most decompressed bytes per compressed byte of a gzip upload.
    pub max_expansion_ratio: u64,
    /// Free bytes the data folder must keep (uploads 507, /readyz 503 below).
    pub min_free_bytes: u64,
    /// Repeatability tolerance by parameter name, canonical units.
    pub tolerances: BTreeMap<String, f64>,
    pub estimate: EstimateOptions,
    /// Queue a diagnose job when a calibration's model check fails.
    pub diagnose_inadequate: bool,
    /// Wall time one scheme design over HTTP may take.
    pub design_time_limit: Duration,
    /// Wall time one design job may take.
    pub design_job_time_limit: Duration,
    /// Where run files are kept.
    pub run_store: RunStoreSpec,
}

/// Default repeatability tolerances (1-σ over runs, and largest change
/// between runs), per family, in canonical units: a tenth of the seed
/// paper's Table 1 magnitudes, about what its Table 2 shows for a good unit.
pub fn default_tolerances() -> BTreeMap<String, f64> {
    PARAMETERS
        .iter()
        .map(|p| {
            let tol = match p.group {
                Group::GyroBias => 0.005,
                Group::GyroScale | Group::AccelScale => 50.0,
                Group::GyroMisalign | Group::AccelMisalign => 20.0,
                Group::AccelBias => 20.0,
                Group::AccelQuad => 50.0,
            };
            (p.name.to_string(), tol)
        })
        .collect()
}

/// The database file inside a data folder: what `serve` opens and
/// `token create` requires.
pub fn database_path(data_dir: &Path) -> PathBuf {
    data_dir.join("sinscal.db")
}

/// `v` seconds as a duration, refused with the flag's name unless finite
/// and at least `min`.
fn seconds_flag(flag: &str, v: f64, min: f64) -> Result<Duration, ConfigError> {
    if v.is_finite() && v >= min {
        Ok(Duration::from_secs_f64(v))
    } else {
        Err(ConfigError::Invalid(format!(
            "--{flag} must be ≥ {min}, got {v}"
        )))
    }
}

impl Config {
    /// The embedded defaults with `data_dir`; what `serve` uses with no
    /// flags, and what tests start from.
    pub fn new(data_dir: impl Into<PathBuf>) -> Config {
        Config {
            data_dir: data_dir.into(),
            database_url: None,
            bind: defaults::BIND.into(),
            workers: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
            max_body_bytes: defaults::MAX_BODY_BYTES,
            max_decompressed_bytes: defaults::MAX_DECOMPRESSED_BYTES,
            max_queue: defaults::MAX_QUEUE,
            lease: Duration::from_secs_f64(defaults::LEASE_SECS),
            max_attempts: defaults::MAX_ATTEMPTS,
            shutdown_grace: Duration::from_secs_f64(defaults::SHUTDOWN_GRACE_SECS),
            retry_backoff: Duration::from_secs(defaults::RETRY_BACKOFF_SECS),
            max_concurrent_uploads: defaults::MAX_CONCURRENT_UPLOADS,
            max_concurrent_requests: defaults::MAX_CONCURRENT_REQUESTS,
            upload_pace: BodyPace {
                idle: Duration::from_secs_f64(defaults::UPLOAD_IDLE_SECS),
                min_bytes_per_s: defaults::UPLOAD_MIN_RATE,
                grace: Duration::from_secs_f64(defaults::UPLOAD_RATE_GRACE_SECS),
            },
            upload_max_cpu: Duration::from_secs_f64(defaults::UPLOAD_MAX_CPU_SECS),
            max_comment_lines: defaults::MAX_COMMENT_LINES,
            max_expansion_ratio: defaults::MAX_EXPANSION_RATIO,
            min_free_bytes: defaults::MIN_FREE_BYTES,
            tolerances: default_tolerances(),
            estimate: EstimateOptions {
                thermal_auto: defaults::THERMAL_AUTO,
                ..EstimateOptions::default()
            },
            diagnose_inadequate: defaults::DIAGNOSE_INADEQUATE,
            design_time_limit: Duration::from_secs_f64(defaults::DESIGN_TIME_LIMIT_SECS),
            design_job_time_limit: Duration::from_secs_f64(defaults::DESIGN_JOB_TIME_LIMIT_SECS),
            run_store: RunStoreSpec::Local,
        }
    }

    /// The flags resolved and checked: every duration and ratio in its
    /// range, the tolerances file read and its names known.
    pub fn from_args(a: &ServeArgs) -> Result<Config, ConfigError> {
        let mut c = Config::new(&a.data_dir);
        c.bind = a.bind.clone();
        c.database_url = a.database_url.clone();
        if let Some(w) = a.workers {
            c.workers = w;
        }
        c.max_body_bytes = a.max_body_bytes;
        c.max_decompressed_bytes = a.max_decompressed_bytes;
        c.max_queue = a.max_queue;
        c.lease = seconds_flag("lease-secs", a.lease_secs, 0.3)?;
        if a.max_attempts < 1 {
            return Err(ConfigError::Invalid("--max-attempts must be ≥ 1".into()));
        }
        c.max_attempts = a.max_attempts;
        c.diagnose_inadequate = a.diagnose_inadequate;
        if a.model.has(Effect::Thermal) {
            return Err(ConfigError::Invalid(
                "--model: thermal states need a run's temperature column, which not every run \
                 has; --thermal-auto adds them to the runs whose temperature moves"
                    .into(),
            ));
        }
        c.estimate.model = a.model.clone();
        c.estimate.thermal_auto = a.thermal_auto;
        c.shutdown_grace = seconds_flag("shutdown-grace-secs", a.shutdown_grace_secs, 0.0)?;
        c.upload_pace = BodyPace {
            idle: seconds_flag("upload-idle-secs", a.upload_idle_secs, 0.1)?,
            min_bytes_per_s: a.upload_min_rate,
            grace: seconds_flag("upload-rate-grace-secs", a.upload_rate_grace_secs, 0.0)?,
        };
        c.upload_max_cpu = seconds_flag("upload-max-cpu-secs", a.upload_max_cpu_secs, 0.1)?;
        c.max_comment_lines = a.max_comment_lines;
        if a.max_expansion_ratio < 2 {
            return Err(ConfigError::Invalid(
                "--max-expansion-ratio must be ≥ 2".into(),
            ));
        }
        c.max_expansion_ratio = a.max_expansion_ratio;
        c.min_free_bytes = a.min_free_bytes;
        c.design_time_limit =
            seconds_flag("design-time-limit-secs", a.design_time_limit_secs, 1.0)?;
        c.design_job_time_limit = seconds_flag(
            "design-job-time-limit-secs",
            a.design_job_time_limit_secs,
            1.0,
        )?;
        c.run_store = a.run_store.clone().unwrap_or_default();
        if let Some(path) = &a.tolerances {
            let text = std::fs::read(path).map_err(|source| ConfigError::Read {
                path: path.display().to_string(),
                source,
            })?;
            let given: BTreeMap<String, f64> = serde_json::from_slice(&text)
                .map_err(|e| ConfigError::Invalid(format!("{}: {e}", path.display())))?;
            for (name, tol) in given {
                if !c.tolerances.contains_key(&name) {
                    return Err(ConfigError::Invalid(format!(
                        "tolerances: unknown parameter {name:?}"
                    )));
                }
                c.tolerances.insert(name, tol);
            }
        }
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Serve {
        #[command(flatten)]
        args: ServeArgs,
    }

    /// The flags' defaults and `Config::new` are the same configuration.
    #[test]
    fn flag_defaults_resolve_to_the_embedded_defaults() {
        let args = Serve::try_parse_from(["serve", "--data-dir", "d"])
            .unwrap()
            .args;
        let from_flags = Config::from_args(&args).unwrap();
        let embedded = Config::new("d");
        // Config holds Durations and f64 maps; compare its Debug form, which
        // shows every field, less `workers` (the flag's default is "per core").
        let show = |c: &Config| {
            format!(
                "{:?}",
                Config {
                    workers: 0,
                    ..c.clone()
                }
            )
        };
        assert_eq!(show(&from_flags), show(&embedded));
    }

    #[test]
    fn a_lease_below_its_floor_names_the_flag() {
        let args = Serve::try_parse_from(["serve", "--lease-secs", "0.1"])
            .unwrap()
            .args;
        let err = Config::from_args(&args).unwrap_err().to_string();
        assert_eq!(err, "--lease-secs must be ≥ 0.3, got 0.1");
    }
}
