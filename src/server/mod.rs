//! The calibration server as an application: configuration (flags,
//! environment, embedded defaults), `Application::build` (which binds before
//! it runs, so tests can bind port 0 and read the real port back), graceful
//! shutdown, and the `token create` command.

pub mod metrics;

use std::collections::BTreeMap;
use std::future::Future;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use tokio::net::TcpListener;
use tokio::sync::{Notify, Semaphore};

use crate::api::upload_guard::BodyPace;
use crate::api::{self, auth, AppState};
use crate::calib::EstimateOptions;
use crate::jobs::{JobRunner, JobSettings, WorkerPool};
use crate::model::{Group, PARAMETERS};
use crate::runfiles::{RunFiles, Swept};
use crate::store::{OnInadequate, Role, Store, StoreError};
use metrics::Metrics;

/// Errors starting or running the server.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("{what}: {source}")]
    Io {
        what: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Config(String),
}

fn io_err(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> ServerError {
    let what = what.into();
    move |source| ServerError::Io { what, source }
}

/// `sinscal serve` flags; each also reads an environment variable, and
/// with neither the embedded default applies.
#[derive(clap::Args, Clone, Debug)]
pub struct ServeArgs {
    /// Folder of the database (sinscal.db) and the run files (runs/).
    #[arg(long, env = "SINSCAL_DATA_DIR", default_value = "./sinscal-data")]
    pub data_dir: PathBuf,
    /// Address to listen on; port 0 picks a free port (printed at start).
    #[arg(long, env = "SINSCAL_BIND", default_value = "127.0.0.1:8080")]
    pub bind: String,
    /// Calibration workers; default one per core.
    #[arg(long, env = "SINSCAL_WORKERS")]
    pub workers: Option<usize>,
    /// Largest upload body, bytes (default 2 GiB).
    #[arg(long, env = "SINSCAL_MAX_BODY_BYTES", default_value_t = 2 << 30)]
    pub max_body_bytes: u64,
    /// Most bytes a gzip upload may expand to (stops gzip bombs).
    #[arg(long, env = "SINSCAL_MAX_DECOMPRESSED_BYTES", default_value_t = 8 << 30)]
    pub max_decompressed_bytes: u64,
    /// Queued jobs beyond which uploads are answered 503 + Retry-After.
    #[arg(long, env = "SINSCAL_MAX_QUEUE", default_value_t = 1000)]
    pub max_queue: i64,
    /// Job lease, seconds; a worker renews it every third of it.
    #[arg(long, env = "SINSCAL_LEASE_SECS", default_value_t = 30.0)]
    pub lease_secs: f64,
    /// Attempts per job before it fails for good.
    #[arg(long, env = "SINSCAL_MAX_ATTEMPTS", default_value_t = 3)]
    pub max_attempts: i64,
    /// At SIGTERM, how long running jobs may take to finish before they
    /// are handed back to the queue, seconds.
    #[arg(long, env = "SINSCAL_SHUTDOWN_GRACE_SECS", default_value_t = 20.0)]
    pub shutdown_grace_secs: f64,
    /// Queue a diagnose job for every run whose calibration fails its
    /// model check (`true` or `false`).
    #[arg(long, env = "SINSCAL_DIAGNOSE_INADEQUATE", default_value_t = true,
          action = clap::ArgAction::Set)]
    pub diagnose_inadequate: bool,
    /// An upload whose body sends nothing for this long is refused (408)
    /// and its slot freed, seconds.
    #[arg(long, env = "SINSCAL_UPLOAD_IDLE_SECS", default_value_t = 30.0)]
    pub upload_idle_secs: f64,
    /// Least mean upload rate, bytes/s, enforced after the grace period.
    #[arg(long, env = "SINSCAL_UPLOAD_MIN_RATE", default_value_t = 10_000)]
    pub upload_min_rate: u64,
    /// Seconds from the start of a body before the minimum rate applies.
    #[arg(long, env = "SINSCAL_UPLOAD_RATE_GRACE_SECS", default_value_t = 10.0)]
    pub upload_rate_grace_secs: f64,
    /// CPU seconds one upload's validation may use (a 2 GiB CSV needs
    /// about 20 s).
    #[arg(long, env = "SINSCAL_UPLOAD_MAX_CPU_SECS", default_value_t = 120.0)]
    pub upload_max_cpu_secs: f64,
    /// Most comment and blank lines in an uploaded CSV.
    #[arg(long, env = "SINSCAL_MAX_COMMENT_LINES", default_value_t = 10_000)]
    pub max_comment_lines: u64,
    /// Most decompressed bytes per compressed byte of a gzip upload
    /// (checked past 16 MiB decompressed).
    #[arg(long, env = "SINSCAL_MAX_EXPANSION_RATIO", default_value_t = 200)]
    pub max_expansion_ratio: u64,
    /// Free bytes the data folder's filesystem must keep: below it uploads
    /// are answered 507 and /readyz 503.
    #[arg(long, env = "SINSCAL_MIN_FREE_BYTES", default_value_t = 256 << 20)]
    pub min_free_bytes: u64,
    /// JSON object of repeatability tolerances by parameter name
    /// (canonical units), replacing the defaults it names.
    #[arg(long, env = "SINSCAL_TOLERANCES")]
    pub tolerances: Option<PathBuf>,
}

/// The resolved configuration.
#[derive(Clone, Debug)]
pub struct Config {
    pub data_dir: PathBuf,
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

impl Config {
    /// The embedded defaults with `data_dir`; what `serve` uses with no
    /// flags, and what tests start from.
    pub fn new(data_dir: impl Into<PathBuf>) -> Config {
        Config {
            data_dir: data_dir.into(),
            bind: "127.0.0.1:8080".into(),
            workers: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
            max_body_bytes: 2 << 30,
            max_decompressed_bytes: 8 << 30,
            max_queue: 1000,
            lease: Duration::from_secs(30),
            max_attempts: 3,
            shutdown_grace: Duration::from_secs(20),
            retry_backoff: Duration::from_secs(2),
            max_concurrent_uploads: 16,
            max_concurrent_requests: 512,
            upload_pace: BodyPace {
                idle: Duration::from_secs(30),
                min_bytes_per_s: 10_000,
                grace: Duration::from_secs(10),
            },
            upload_max_cpu: Duration::from_secs(120),
            max_comment_lines: 10_000,
            max_expansion_ratio: 200,
            min_free_bytes: 256 << 20,
            tolerances: default_tolerances(),
            estimate: EstimateOptions::default(),
            diagnose_inadequate: true,
        }
    }

    pub fn from_args(a: &ServeArgs) -> Result<Config, ServerError> {
        let mut c = Config::new(&a.data_dir);
        c.bind = a.bind.clone();
        if let Some(w) = a.workers {
            c.workers = w;
        }
        c.max_body_bytes = a.max_body_bytes;
        c.max_decompressed_bytes = a.max_decompressed_bytes;
        c.max_queue = a.max_queue;
        if !(a.lease_secs.is_finite() && a.lease_secs >= 0.3) {
            return Err(ServerError::Config(format!(
                "--lease-secs must be ≥ 0.3, got {}",
                a.lease_secs
            )));
        }
        c.lease = Duration::from_secs_f64(a.lease_secs);
        if a.max_attempts < 1 {
            return Err(ServerError::Config("--max-attempts must be ≥ 1".into()));
        }
        c.max_attempts = a.max_attempts;
        c.diagnose_inadequate = a.diagnose_inadequate;
        if !(a.shutdown_grace_secs.is_finite() && a.shutdown_grace_secs >= 0.0) {
            return Err(ServerError::Config(
                "--shutdown-grace-secs must be ≥ 0".into(),
            ));
        }
        c.shutdown_grace = Duration::from_secs_f64(a.shutdown_grace_secs);
        let secs = |name: &str, v: f64, min: f64| {
            if v.is_finite() && v >= min {
                Ok(Duration::from_secs_f64(v))
            } else {
                Err(ServerError::Config(format!(
                    "--{name} must be ≥ {min}, got {v}"
                )))
            }
        };
        c.upload_pace = BodyPace {
            idle: secs("upload-idle-secs", a.upload_idle_secs, 0.1)?,
            min_bytes_per_s: a.upload_min_rate,
            grace: secs("upload-rate-grace-secs", a.upload_rate_grace_secs, 0.0)?,
        };
        c.upload_max_cpu = secs("upload-max-cpu-secs", a.upload_max_cpu_secs, 0.1)?;
        c.max_comment_lines = a.max_comment_lines;
        if a.max_expansion_ratio < 2 {
            return Err(ServerError::Config(
                "--max-expansion-ratio must be ≥ 2".into(),
            ));
        }
        c.max_expansion_ratio = a.max_expansion_ratio;
        c.min_free_bytes = a.min_free_bytes;
        if let Some(path) = &a.tolerances {
            let text =
                std::fs::read(path).map_err(io_err(format!("reading {}", path.display())))?;
            let given: BTreeMap<String, f64> = serde_json::from_slice(&text)
                .map_err(|e| ServerError::Config(format!("{}: {e}", path.display())))?;
            for (name, tol) in given {
                if !c.tolerances.contains_key(&name) {
                    return Err(ServerError::Config(format!(
                        "tolerances: unknown parameter {name:?}"
                    )));
                }
                c.tolerances.insert(name, tol);
            }
        }
        Ok(c)
    }

    pub fn db_path(&self) -> PathBuf {
        self.data_dir.join("sinscal.db")
    }
}

/// Creates the data folders, opens the database (applying migrations).
async fn open_store(data_dir: &Path, readers: u32) -> Result<Store, ServerError> {
    RunFiles::new(data_dir)
        .create_dirs()
        .map_err(io_err(format!("creating {}", data_dir.display())))?;
    Ok(Store::open(&data_dir.join("sinscal.db"), readers).await?)
}

/// Removes what a crash can leave behind (see [`RunFiles::sweep`]).
async fn sweep_orphans(store: &Store, data_dir: &Path) -> Result<Swept, ServerError> {
    let known = store.all_blob_paths().await?.into_iter().collect();
    RunFiles::new(data_dir)
        .sweep(&known)
        .map_err(io_err("sweeping the run files"))
}

/// A built, bound server, not yet running.
pub struct Application {
    listener: TcpListener,
    addr: SocketAddr,
    state: AppState,
    runner: Arc<JobRunner>,
    first_admin_token: Option<String>,
}

impl Application {
    /// Opens the data folder and database, sweeps crash leftovers, creates
    /// the first admin token if there is no token, and binds the listener.
    pub async fn build(config: Config) -> Result<Application, ServerError> {
        let readers = (config.max_concurrent_requests.min(16)) as u32;
        let store = open_store(&config.data_dir, readers).await?;
        let Swept { partial, orphans } = sweep_orphans(&store, &config.data_dir).await?;
        if partial + orphans > 0 {
            tracing::info!(partial, orphans, "removed files left by an earlier crash");
        }
        let (token, hash) = auth::new_token();
        let id = uuid::Uuid::new_v4().to_string();
        let first_admin_token = store.insert_first_token(&id, &hash).await?.then_some(token);
        let listener = TcpListener::bind(&config.bind)
            .await
            .map_err(io_err(format!("binding {}", config.bind)))?;
        let addr = listener
            .local_addr()
            .map_err(io_err("reading the bound address"))?;
        let metrics = Arc::new(Metrics::default());
        let runner = Arc::new(JobRunner::new(
            store.clone(),
            JobSettings {
                data_dir: config.data_dir.clone(),
                lease: config.lease,
                estimate: config.estimate.clone(),
                retry_backoff: config.retry_backoff,
                on_inadequate: OnInadequate {
                    queue_diagnose: config.diagnose_inadequate,
                    max_attempts: config.max_attempts,
                },
            },
            metrics.clone(),
        ));
        let state = AppState {
            store,
            uploads: Arc::new(Semaphore::new(config.max_concurrent_uploads)),
            config: Arc::new(config),
            metrics,
            wake: Arc::new(Notify::new()),
            stopping: Arc::new(AtomicBool::new(false)),
        };
        Ok(Application {
            listener,
            addr,
            state,
            runner,
            first_admin_token,
        })
    }

    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    pub fn port(&self) -> u16 {
        self.addr.port()
    }

    /// The admin token created at this start, if there was no token.
    pub fn first_admin_token(&self) -> Option<&str> {
        self.first_admin_token.as_deref()
    }

    /// The job runner, for tests that step the queue themselves.
    pub fn runner(&self) -> Arc<JobRunner> {
        self.runner.clone()
    }

    pub fn store(&self) -> Store {
        self.state.store.clone()
    }

    /// Serves until `shutdown` resolves; then stops accepting requests,
    /// lets running jobs finish within the grace period (else hands them
    /// back), and closes the database.
    pub async fn run_until_stopped(
        self,
        shutdown: impl Future<Output = ()> + Send + 'static,
    ) -> Result<(), ServerError> {
        let config = self.state.config.clone();
        let poll = (config.lease / 2).min(Duration::from_secs(1));
        let pool = WorkerPool::start(
            self.runner.clone(),
            config.workers,
            self.state.wake.clone(),
            poll,
        );
        let state = self.state.clone();
        let app = api::router(self.state.clone());
        let (stopped_tx, stopped_rx) = tokio::sync::oneshot::channel::<()>();
        let stop_signal = async move {
            shutdown.await;
            tracing::info!("shutdown requested: no new work");
            state.set_stopping();
            let _ = stopped_tx.send(());
        };
        let served = axum::serve(self.listener, app)
            .with_graceful_shutdown(stop_signal)
            .await;
        let _ = stopped_rx.await;
        pool.shutdown(config.shutdown_grace).await;
        self.state.store.close().await;
        served.map_err(io_err("serving"))
    }
}

/// Resolves on SIGTERM or Ctrl-C.
pub async fn termination_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = term => {}
    }
}

fn runtime() -> Result<tokio::runtime::Runtime, ServerError> {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(io_err("starting the async runtime"))
}

/// `sinscal serve`: prints the listening address (and a first admin token)
/// on stdout, logs on stderr, runs until SIGTERM/Ctrl-C.
pub fn serve(args: &ServeArgs) -> Result<(), ServerError> {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                tracing_subscriber::EnvFilter::new("info,sqlx=warn,tower_http=warn")
            }),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .try_init();
    let config = Config::from_args(args)?;
    runtime()?.block_on(async move {
        let workers = config.workers;
        let data_dir = config.data_dir.clone();
        let app = Application::build(config).await?;
        if let Some(token) = app.first_admin_token() {
            println!("admin token (shown once, store it now): {token}");
        }
        println!("sinscal listening on http://{}", app.addr());
        tracing::info!(addr = %app.addr(), workers, data_dir = %data_dir.display(), "server started");
        app.run_until_stopped(termination_signal()).await
    })
}

/// `sinscal token create`: a new token of `role`, returned for printing.
pub fn create_token(
    data_dir: &Path,
    role: Role,
    label: Option<&str>,
) -> Result<String, ServerError> {
    // A mistyped --data-dir must not create a new, empty database whose
    // token works on no server.
    let db = data_dir.join("sinscal.db");
    if !db.is_file() {
        return Err(ServerError::Config(format!(
            "no database at {}: give the --data-dir the server runs with (it creates the database at its first start)",
            db.display()
        )));
    }
    runtime()?.block_on(async move {
        let store = open_store(data_dir, 1).await?;
        let (token, hash) = auth::new_token();
        store
            .insert_token(&uuid::Uuid::new_v4().to_string(), &hash, role, label)
            .await?;
        store.close().await;
        Ok(token)
    })
}
