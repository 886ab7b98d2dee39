//! Test harness: a real server on a random port with a fresh data folder
//! and SQLite file, a client with one method per endpoint, and simulated
//! runs to upload; `browser` drives a headless Chromium for the HTML pages.
#![allow(dead_code)]

pub mod browser;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use reqwest::{Response, StatusCode};
use serde_json::Value;
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::run::write_simulated_run;
use sinscal_core::model::{Effects, ErrorParameters};
use sinscal_core::nav::Site;
use sinscal_core::sim::{Noise, Scheme, SimConfig};
use sinscal_server::config::Config;
use sinscal_server::jobs::JobRunner;
use sinscal_server::server::Application;
use sinscal_server::store::Store;

pub mod pages;
pub mod postgres;
pub mod process;
pub mod s3;

pub struct TestApp {
    pub base: String,
    pub admin: String,
    pub http: reqwest::Client,
    pub data_dir: tempfile::TempDir,
    pub runner: Arc<JobRunner>,
    pub store: Store,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: Option<tokio::task::JoinHandle<()>>,
}

/// Test defaults: a short lease so reclaim tests are quick, no retry wait.
pub fn test_config(data_dir: &Path, workers: usize) -> Config {
    let mut c = Config::new(data_dir);
    c.bind = "127.0.0.1:0".into();
    c.workers = workers;
    c.lease = Duration::from_secs(2);
    c.retry_backoff = Duration::from_millis(0);
    c.shutdown_grace = Duration::from_secs(5);
    c
}

pub async fn spawn_app(workers: usize) -> TestApp {
    spawn_app_with(workers, |_| {}).await
}

pub async fn spawn_app_with(workers: usize, tweak: impl FnOnce(&mut Config)) -> TestApp {
    spawn_app_in(tempfile::tempdir().expect("temp dir"), workers, tweak).await
}

/// A server whose data folder is `data_dir` (e.g. a small filesystem
/// mounted there).
pub async fn spawn_app_in(
    data_dir: tempfile::TempDir,
    workers: usize,
    tweak: impl FnOnce(&mut Config),
) -> TestApp {
    let mut config = test_config(data_dir.path(), workers);
    config.database_url = test_database_url().await;
    tweak(&mut config);
    let app = Application::build(config).await.expect("build app");
    let admin = app
        .first_admin_token()
        .expect("first start makes an admin token")
        .to_string();
    let base = format!("http://{}/api/v1", app.addr());
    let runner = app.runner();
    let store = app.store();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let task = tokio::spawn(async move {
        app.run_until_stopped(async {
            let _ = stopped.await;
        })
        .await
        .expect("server ran");
    });
    TestApp {
        base,
        admin,
        http: reqwest::Client::new(),
        data_dir,
        runner,
        store,
        stop: Some(stop),
        task: Some(task),
    }
}

/// The environment variable that moves the suite onto PostgreSQL: the URL
/// of a server on which the tests may create databases (`.ci/run` starts a
/// throwaway cluster and sets it).
pub const POSTGRES_ENV: &str = "SINSCAL_TEST_DATABASE_URL";

/// The database of a test's server: `None` (SQLite in its data folder)
/// unless [`POSTGRES_ENV`] is set; then a new, empty database on that
/// server, so every test starts from the migrations as on SQLite. The
/// databases are left to the throwaway cluster.
pub async fn test_database_url() -> Option<String> {
    let admin = std::env::var(POSTGRES_ENV).ok()?;
    Some(postgres::create_database(&admin, "sinscal_test").await)
}

/// `postgres://u:p@h:port/any?opts` with the database `name`.
pub fn database_in(url: &str, name: &str) -> String {
    let (base, query) = match url.split_once('?') {
        Some((b, q)) => (b, format!("?{q}")),
        None => (url, String::new()),
    };
    let authority_end = base.find("://").map_or(0, |i| i + 3);
    let root = match base[authority_end..].find('/') {
        Some(i) => &base[..authority_end + i],
        None => base,
    };
    format!("{root}/{name}{query}")
}

/// A run's files on disk.
#[derive(Clone, Debug)]
pub struct SimRun {
    pub data: PathBuf,
    pub metadata: Vec<u8>,
    pub truth: ErrorParameters,
}

/// The result of calibrating `run`'s file directly (default options, as a
/// worker does), for comparing with what a server stored.
pub fn calibrate_directly(run: &SimRun) -> sinscal_core::calib::CalibrationResult {
    calibrate_directly_with(run, &sinscal_core::calib::EstimateOptions::default())
}

/// The same with `opts`.
pub fn calibrate_directly_with(
    run: &SimRun,
    opts: &sinscal_core::calib::EstimateOptions,
) -> sinscal_core::calib::CalibrationResult {
    let meta = sinscal_core::io::meta::RunMetadata::from_json(&run.metadata).unwrap();
    sinscal_core::pipeline::calibrate_file(
        &run.data,
        &meta,
        opts,
        &mut |_| {},
        &std::sync::atomic::AtomicBool::new(false),
    )
    .unwrap()
}

pub fn sim_config(seed: u64, params: ErrorParameters, scheme: &str, dwell_s: f64) -> SimConfig {
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: 100.0,
        scheme: Scheme::builtin(scheme, dwell_s).expect("built-in scheme"),
        params,
        effects: Effects::none(),
        noise: Noise {
            gyro_arw_deg_rt_h: 0.0003,
            accel_vrw_ug_rt_hz: 5.0,
            ..Noise::default()
        },
        initial_attitude_error_deg: [0.1, -0.1, 2.0],
        seed,
        thermal: None,
        temperature: None,
    }
}

/// The 9+9 scheme with 120 s dwells at 20 Hz, paper truth, navigation-grade
/// noise and `effects`: seconds to calibrate, and a 2 ms accelerometer
/// delay (`delayed_accelerometers`) stands out at every turn, so the model
/// check fails.
pub fn model_check_run(seed: u64, effects: Effects) -> SimConfig {
    let mut cfg = sim_config(seed, ErrorParameters::paper(), "ten-position-9+9", 120.0);
    cfg.sample_rate_hz = 20.0;
    cfg.scheme = Scheme::builtin("ten-position-9+9", 120.0).unwrap();
    cfg.noise = Noise::default_navigation_grade();
    cfg.effects = effects;
    cfg
}

/// A 2 ms accelerometer delay.
pub fn delayed_accelerometers() -> Effects {
    Effects {
        accel_delay: Some(2.0),
        ..Effects::none()
    }
}

/// Simulates a run into `dir`; `recorded_at` goes into its metadata.
pub fn simulate_run(
    dir: &Path,
    cfg: &SimConfig,
    format: DataFormat,
    gzip: bool,
    serial: &str,
    recorded_at: Option<&str>,
) -> SimRun {
    let files = write_simulated_run(cfg, dir, format, gzip, serial).expect("simulate");
    let mut meta: Value = serde_json::from_slice(&std::fs::read(&files.metadata).unwrap()).unwrap();
    if let Some(t) = recorded_at {
        meta["recorded_at"] = Value::String(t.into());
    }
    SimRun {
        data: files.data,
        metadata: serde_json::to_vec(&meta).unwrap(),
        truth: cfg.params,
    }
}

/// A short run (ten-position, 30 s dwells, ~6 min at 100 Hz) for tests
/// where accuracy is not the point.
pub fn short_run(dir: &Path, seed: u64, format: DataFormat, serial: &str) -> SimRun {
    let cfg = sim_config(seed, ErrorParameters::paper(), "ten-position", 30.0);
    simulate_run(dir, &cfg, format, false, serial, None)
}

/// Metadata JSON for a unit, by hand.
pub fn metadata(serial: &str, format: &str) -> Vec<u8> {
    serde_json::to_vec(&serde_json::json!({
        "unit_serial": serial, "sample_rate_hz": 100, "latitude_deg": 28.2215,
        "longitude_deg": 112.9924, "height_m": 50, "format": format
    }))
    .unwrap()
}

impl TestApp {
    pub fn url(&self, path: &str) -> String {
        format!("{}{}", self.base, path)
    }

    pub async fn create_token(&self, role: &str) -> String {
        let r = self
            .http
            .post(self.url("/tokens"))
            .bearer_auth(&self.admin)
            .json(&serde_json::json!({"role": role, "label": "test"}))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), StatusCode::CREATED);
        r.json::<Value>().await.unwrap()["token"]
            .as_str()
            .unwrap()
            .to_string()
    }

    pub async fn upload_multipart(
        &self,
        token: &str,
        serial: &str,
        meta: &[u8],
        data: Vec<u8>,
    ) -> Response {
        let form = reqwest::multipart::Form::new()
            .part(
                "metadata",
                reqwest::multipart::Part::bytes(meta.to_vec())
                    .mime_str("application/json")
                    .unwrap(),
            )
            .part(
                "data",
                reqwest::multipart::Part::bytes(data).file_name("run.dat"),
            );
        self.http
            .post(self.url(&format!("/units/{serial}/runs")))
            .bearer_auth(token)
            .multipart(form)
            .send()
            .await
            .unwrap()
    }

    /// Raw body, metadata in the `X-Sinscal-Metadata` header.
    pub async fn upload_raw(
        &self,
        token: &str,
        serial: &str,
        meta: &[u8],
        data: Vec<u8>,
    ) -> Response {
        self.http
            .post(self.url(&format!("/units/{serial}/runs")))
            .bearer_auth(token)
            .header("x-sinscal-metadata", meta)
            .header("content-type", "application/octet-stream")
            .body(data)
            .send()
            .await
            .unwrap()
    }

    pub async fn upload_run(&self, serial: &str, run: &SimRun) -> Response {
        self.upload_multipart(
            &self.admin,
            serial,
            &run.metadata,
            std::fs::read(&run.data).unwrap(),
        )
        .await
    }

    pub async fn get(&self, token: &str, path: &str) -> Response {
        self.http
            .get(self.url(path))
            .bearer_auth(token)
            .send()
            .await
            .unwrap()
    }

    /// Asks for a run's diagnosis (POST /runs/{id}/diagnose).
    pub async fn post_diagnose(&self, token: &str, run_id: &str) -> Response {
        self.http
            .post(self.url(&format!("/runs/{run_id}/diagnose")))
            .bearer_auth(token)
            .send()
            .await
            .unwrap()
    }

    pub async fn get_json(&self, path: &str) -> Value {
        let r = self.get(&self.admin, path).await;
        assert_eq!(r.status(), StatusCode::OK, "GET {path}");
        r.json().await.unwrap()
    }

    pub async fn get_run(&self, id: &str) -> Value {
        self.get_json(&format!("/runs/{id}")).await
    }

    pub async fn get_result(&self, run_id: &str) -> Value {
        self.get_json(&format!("/runs/{run_id}/result")).await
    }

    pub async fn get_job(&self, id: &str) -> Value {
        self.get_json(&format!("/jobs/{id}")).await
    }

    pub async fn cancel_job(&self, id: &str) -> Response {
        self.http
            .post(self.url(&format!("/jobs/{id}/cancel")))
            .bearer_auth(&self.admin)
            .send()
            .await
            .unwrap()
    }

    pub async fn units(&self) -> Value {
        self.get_json("/units").await
    }

    pub async fn unit(&self, serial: &str) -> Value {
        self.get_json(&format!("/units/{serial}")).await
    }

    pub async fn history(&self, serial: &str, query: &str) -> Value {
        self.get_json(&format!("/units/{serial}/history{query}"))
            .await
    }

    pub async fn repeatability(&self, serial: &str, query: &str) -> Value {
        self.get_json(&format!("/units/{serial}/repeatability{query}"))
            .await
    }

    pub async fn metrics(&self) -> String {
        self.get(&self.admin, "/metrics")
            .await
            .text()
            .await
            .unwrap()
    }

    /// Polls a job until it is in a final state.
    /// Uploads `run` (admin), waits up to `timeout` for its calibrate job
    /// and asserts both went through: the run's id and the finished job.
    pub async fn upload_and_calibrate(
        &self,
        serial: &str,
        run: &SimRun,
        timeout: Duration,
    ) -> (String, Value) {
        let r = self.upload_run(serial, run).await;
        assert_eq!(r.status(), StatusCode::ACCEPTED);
        let up: Value = r.json().await.unwrap();
        let job = self.wait_job(up["job_id"].as_str().unwrap(), timeout).await;
        assert_eq!(job["state"], "succeeded", "{job}");
        (up["run_id"].as_str().unwrap().to_string(), job)
    }

    pub async fn wait_job(&self, id: &str, timeout: Duration) -> Value {
        let start = Instant::now();
        loop {
            let job = self.get_job(id).await;
            let state = job["state"].as_str().unwrap();
            if matches!(state, "succeeded" | "failed" | "dead_letter" | "cancelled") {
                return job;
            }
            assert!(
                start.elapsed() < timeout,
                "job {id} still {state} after {timeout:?}"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// Files under runs/ (tmp included), relative paths.
    pub fn stored_files(&self) -> Vec<PathBuf> {
        let mut out = Vec::new();
        let runs = self.data_dir.path().join("runs");
        for shard in std::fs::read_dir(&runs).unwrap() {
            let shard = shard.unwrap().path();
            if shard.is_dir() {
                for f in std::fs::read_dir(&shard).unwrap() {
                    out.push(f.unwrap().path().strip_prefix(&runs).unwrap().to_path_buf());
                }
            }
        }
        out
    }

    pub async fn stop(mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.task.take() {
            t.await.unwrap();
        }
    }
}

/// The status and problem+json body of a refusal.
pub async fn problem(r: Response) -> (StatusCode, Value) {
    let status = r.status();
    let ct = r
        .headers()
        .get("content-type")
        .map(|v| v.to_str().unwrap().to_string());
    assert_eq!(
        ct.as_deref(),
        Some("application/problem+json"),
        "status {status}"
    );
    (status, r.json().await.unwrap())
}

pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    hex::encode(Sha256::digest(bytes))
}
