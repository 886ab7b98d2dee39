//! The calibration server as an application: `Application::build` (which
//! binds before it runs, so tests can bind port 0 and read the real port
//! back), graceful shutdown, and the `token create` command. It composes
//! `api`, `jobs` and `store` from a [`Config`]; nothing imports it but
//! `main`.

use std::future::Future;
use std::net::SocketAddr;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use tokio::net::TcpListener;
use tokio::sync::{Notify, Semaphore};

use crate::api::{self, auth, AppState};
use crate::config::{database_path, Config, ConfigError, ServeArgs};
use crate::jobs::{JobRunner, JobSettings, WorkerPool};
use crate::metrics::Metrics;
use crate::runfiles::RunFiles;
use crate::runstore::{RunStore, RunStoreError, Swept};
use crate::store::{Backend, DatabaseUrl, OnInadequate, Role, Store, StoreError};

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
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    RunStore(#[from] RunStoreError),
    #[error("no database at {0}: give the --data-dir the server runs with (it creates the database at its first start)")]
    NoDatabase(String),
}

fn io_err(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> ServerError {
    let what = what.into();
    move |source| ServerError::Io { what, source }
}

/// The database `--database-url` names, else SQLite in the data folder.
fn database_url(database_url: Option<&str>, data_dir: &Path) -> Result<DatabaseUrl, ServerError> {
    match database_url {
        Some(url) => DatabaseUrl::parse(url)
            .map_err(|e| ConfigError::Invalid(format!("--database-url: {e}")).into()),
        None => Ok(DatabaseUrl::Sqlite(database_path(data_dir))),
    }
}

/// Creates the data folders, opens the database (applying migrations).
async fn open_store(config: &Config, readers: u32) -> Result<Store, ServerError> {
    let data_dir = &config.data_dir;
    RunFiles::new(data_dir)
        .create_dirs()
        .map_err(io_err(format!("creating {}", data_dir.display())))?;
    let url = database_url(config.database_url.as_deref(), data_dir)?;
    Ok(Store::connect(&url, readers).await?)
}

/// How old an unreferenced run file must be before a process sharing its
/// database with others removes it: far longer than any upload takes from
/// its file's last write to its row's commit.
const SHARED_SWEEP_GRACE: Duration = Duration::from_secs(15 * 60);

/// Removes what a crash can leave behind (see [`RunStore::sweep_at_start`]):
/// a local folder's files at once on SQLite, where this process is alone on
/// its data folder, and after [`SHARED_SWEEP_GRACE`] on PostgreSQL, where
/// other processes may be in the middle of an upload.
async fn sweep_orphans(store: &Store, runs: &RunStore) -> Result<Swept, ServerError> {
    let known = store.all_blob_paths().await?.into_iter().collect();
    let grace = match store.backend() {
        Backend::Sqlite => Duration::ZERO,
        Backend::Postgres => SHARED_SWEEP_GRACE,
    };
    Ok(runs.sweep_at_start(&known, grace).await?)
}
/// Sweeps an object store every `every` until the server stops: other
/// servers sharing the bucket may crash between a put and its rows, and
/// this one may run for months without a restart.
fn spawn_periodic_sweep(
    store: Store,
    runs: RunStore,
    every: Duration,
) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        let mut tick = tokio::time::interval(every);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        // The first tick is immediate, and the start has just swept.
        tick.tick().await;
        loop {
            tick.tick().await;
            let known = match store.all_blob_paths().await {
                Ok(paths) => paths.into_iter().collect(),
                Err(e) => {
                    tracing::warn!(error = %e, "run store sweep skipped: reading the blob paths");
                    continue;
                }
            };
            match runs.sweep_objects(&known).await {
                Ok(0) => {}
                Ok(orphans) => tracing::info!(orphans, "removed objects no run names"),
                Err(e) => tracing::warn!(error = %e, "run store sweep failed"),
            }
        }
    })
}

/// What a process serves over HTTP.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Serves {
    /// The API, the pages and the operations endpoints (`sinscal serve`).
    Api,
    /// Only `/healthz`, `/readyz` and `/metrics` (`sinscal worker`): a
    /// process that runs jobs and answers no client.
    Operations,
}

/// A built, bound server, not yet running.
pub struct Application {
    serves: Serves,
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
        Application::build_serving(config, Serves::Api).await
    }

    /// [`Application::build`] for a process that serves `serves`. Only an
    /// API process creates the first admin token (it is the one that
    /// prints it to an operator).
    pub async fn build_serving(config: Config, serves: Serves) -> Result<Application, ServerError> {
        let readers = (config.max_concurrent_requests.min(16)) as u32;
        let store = open_store(&config, readers).await?;
        let metrics = Arc::new(Metrics::default());
        let run_store =
            RunStore::open(&config.run_store, &config.data_dir, metrics.clone()).await?;
        tracing::info!(runs = %run_store.describe(), "run store open");
        let Swept {
            partial,
            orphans,
            scratch,
        } = sweep_orphans(&store, &run_store).await?;
        if partial + orphans + scratch > 0 {
            tracing::info!(
                partial,
                orphans,
                scratch,
                "removed files left by an earlier crash"
            );
        }
        let (token, hash) = auth::new_token();
        let id = uuid::Uuid::new_v4().to_string();
        let first_admin_token = match serves {
            Serves::Api => store.insert_first_token(&id, &hash).await?.then_some(token),
            Serves::Operations => None,
        };
        let listener = TcpListener::bind(&config.bind)
            .await
            .map_err(io_err(format!("binding {}", config.bind)))?;
        let addr = listener
            .local_addr()
            .map_err(io_err("reading the bound address"))?;
        let runner = Arc::new(JobRunner::new(
            store.clone(),
            JobSettings {
                run_store: run_store.clone(),
                lease: config.lease,
                estimate: config.estimate.clone(),
                retry_backoff: config.retry_backoff,
                on_inadequate: OnInadequate {
                    queue_diagnose: config.diagnose_inadequate,
                    max_attempts: config.max_attempts,
                },
                design_time_limit: config.design_job_time_limit,
            },
            metrics.clone(),
        ));
        let state = AppState {
            store,
            run_store,
            uploads: Arc::new(Semaphore::new(config.max_concurrent_uploads)),
            designs: Arc::new(Semaphore::new(1)),
            // One at a time: an analysis takes a core for about a second
            // per 3 h of 100 Hz run, and the workers need theirs.
            noise_analyses: Arc::new(Semaphore::new(1)),
            config: Arc::new(config),
            metrics,
            wake: Arc::new(Notify::new()),
            stopping: Arc::new(AtomicBool::new(false)),
        };
        Ok(Application {
            serves,
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
        let hints = listen_for_jobs(&self.state.store, self.state.wake.clone()).await;
        let sweeper = self.state.run_store.sweep_every().map(|every| {
            spawn_periodic_sweep(
                self.state.store.clone(),
                self.state.run_store.clone(),
                every,
            )
        });
        let state = self.state.clone();
        let app = match self.serves {
            Serves::Api => api::router(
                self.state.clone(),
                crate::web::router(self.state.config.max_body_bytes),
            ),
            Serves::Operations => api::operations_router(self.state.clone()),
        };
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
        if let Some(h) = hints {
            h.abort();
        }
        if let Some(sweeper) = sweeper {
            sweeper.abort();
        }
        self.state.store.close().await;
        served.map_err(io_err("serving"))
    }
}

/// On PostgreSQL, wakes this process's idle workers when any process
/// queues a job (`LISTEN`). Only a hint: a lost notification (the
/// listener reconnecting) costs at most one poll period, so errors are
/// logged and the listener retried, never fatal.
async fn listen_for_jobs(store: &Store, wake: Arc<Notify>) -> Option<tokio::task::JoinHandle<()>> {
    let mut hints = match store.job_hints().await {
        Ok(Some(h)) => h,
        Ok(None) => return None,
        Err(e) => {
            tracing::warn!(error = %e, "no job notifications: workers poll only");
            return None;
        }
    };
    Some(tokio::spawn(async move {
        loop {
            match hints.next().await {
                Ok(()) => wake.notify_waiters(),
                Err(e) => {
                    tracing::warn!(error = %e, "job notifications interrupted; reconnecting");
                    tokio::time::sleep(Duration::from_secs(1)).await;
                }
            }
        }
    }))
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

fn init_logging() {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                tracing_subscriber::EnvFilter::new("info,sqlx=warn,tower_http=warn")
            }),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .try_init();
}

/// `sinscal serve`: prints the listening address (and a first admin token)
/// on stdout, logs on stderr, runs until SIGTERM/Ctrl-C.
pub fn serve(args: &ServeArgs) -> Result<(), ServerError> {
    run_process(args, Serves::Api)
}

/// `sinscal worker`: the workers alone, claiming jobs from the shared
/// database; `--bind` serves only the operations endpoints. Prints the
/// address, runs until SIGTERM/Ctrl-C, then hands running jobs back as
/// `serve` does.
pub fn worker(args: &ServeArgs) -> Result<(), ServerError> {
    run_process(args, Serves::Operations)
}

fn run_process(args: &ServeArgs, serves: Serves) -> Result<(), ServerError> {
    init_logging();
    let config = Config::from_args(args)?;
    runtime()?.block_on(async move {
        let workers = config.workers;
        let data_dir = config.data_dir.clone();
        let app = Application::build_serving(config, serves).await?;
        if let Some(token) = app.first_admin_token() {
            println!("admin token (shown once, store it now): {token}");
        }
        let what = match serves {
            Serves::Api => "sinscal",
            Serves::Operations => "sinscal worker",
        };
        println!("{what} listening on http://{}", app.addr());
        tracing::info!(
            addr = %app.addr(), workers, data_dir = %data_dir.display(),
            database = %app.store().url().redacted(), ?serves, "process started"
        );
        app.run_until_stopped(termination_signal()).await
    })
}

/// `sinscal token create`: a new token of `role`, returned for printing.
pub fn create_token(
    data_dir: &Path,
    database_url_flag: Option<&str>,
    role: Role,
    label: Option<&str>,
) -> Result<String, ServerError> {
    let url = database_url(database_url_flag, data_dir)?;
    // A mistyped --data-dir must not create a new, empty database whose
    // token works on no server.
    if let DatabaseUrl::Sqlite(db) = &url {
        if !db.is_file() {
            return Err(ServerError::NoDatabase(db.display().to_string()));
        }
    }
    runtime()?.block_on(async move {
        let store = Store::connect(&url, 1).await?;
        let (token, hash) = auth::new_token();
        store
            .insert_token(&uuid::Uuid::new_v4().to_string(), &hash, role, label)
            .await?;
        store.close().await;
        Ok(token)
    })
}
