//! The `sinscal` binary killed with SIGKILL: a job interrupted mid-way
//! finishes after restart with the same result, and a harness kills the
//! server twenty times at random moments while uploads and jobs are in
//! flight, then checks that nothing acknowledged was lost or duplicated and
//! nothing half-written remains.

use crate::common;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::*;
use rand::{Rng, SeedableRng};
use serde_json::Value;
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::ErrorParameters;
use sqlx::Row;

/// Starts `sinscal serve` on a free port; returns it and the admin token
/// if this start created one.
fn start(data: &Path, log: &Path, extra: &[&str]) -> (process::Process, Option<String>) {
    let mut cmd = process::sinscal(&["serve", "--bind", "127.0.0.1:0", "--data-dir"]);
    cmd.arg(data).args(extra);
    process::Process::start(cmd, log)
}

/// Asks the server to stop and checks that it stopped cleanly.
fn stop_cleanly(server: process::Process) {
    let status = server.sigterm();
    assert!(status.success(), "server exited with {status}");
}

async fn wait_final(
    http: &reqwest::Client,
    token: &str,
    base: &str,
    job_id: &str,
    timeout: Duration,
) -> Value {
    let start = Instant::now();
    loop {
        let job = process::get_json(http, token, &format!("{base}/jobs/{job_id}")).await;
        if matches!(
            job["state"].as_str(),
            Some("succeeded" | "failed" | "dead_letter" | "cancelled")
        ) {
            return job;
        }
        assert!(start.elapsed() < timeout, "job {job_id} not done: {job}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigkill_mid_job_then_restart_finishes_it_with_the_same_result() {
    let data = tempfile::tempdir().unwrap();
    let logs = tempfile::tempdir().unwrap();
    let log = logs.path().join("server.log");
    let args = ["--workers", "1", "--lease-secs", "1"];
    let (mut server, token) = start(data.path(), &log, &args);
    let token = token.unwrap();
    let http = reqwest::Client::new();
    let dir = tempfile::tempdir().unwrap();
    // 300 s dwells at 100 Hz: a job of seconds, killed as soon as it runs.
    let cfg = sim_config(5, ErrorParameters::paper(), "ten-position-9+9", 300.0);
    let run = simulate_run(dir.path(), &cfg, DataFormat::F64le, false, "RLG-0042", None);
    let r: Value = process::upload_run(
        &http,
        &server.api(),
        &token,
        "RLG-0042",
        &run.metadata,
        std::fs::read(&run.data).unwrap(),
    )
    .await
    .unwrap()
    .json()
    .await
    .unwrap();
    let job_url = format!("{}/jobs/{}", server.api(), r["job_id"].as_str().unwrap());
    loop {
        let job = process::get_json(&http, &token, &job_url).await;
        if job["state"] == "running" {
            break;
        }
        assert_eq!(
            job["state"], "queued",
            "the job ended before the kill: {job}"
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    server.sigkill();

    let (server, again) = start(data.path(), &log, &args);
    assert!(again.is_none(), "tokens survive a restart");
    let job = wait_final(
        &http,
        &token,
        &server.api(),
        r["job_id"].as_str().unwrap(),
        Duration::from_secs(120),
    )
    .await;
    assert_eq!(job["state"], "succeeded", "{job}");
    assert_eq!(job["attempts"], 2, "the killed attempt counts: {job}");
    let result = process::get_json(
        &http,
        &token,
        &format!(
            "{}/runs/{}/result",
            server.api(),
            r["run_id"].as_str().unwrap()
        ),
    )
    .await;
    stop_cleanly(server);

    // The same result as calibrating the file directly.
    let direct = calibrate_directly(&run);
    // Equal to the last bits the estimator itself is reproducible to (its
    // floating-point sums may associate differently between runs).
    assert_eq!(direct.parameters.len(), 24);
    for (name, p) in &direct.parameters {
        let got = &result["parameters"][name];
        for (field, want) in [("value", p.value), ("sigma", p.sigma)] {
            let v = got[field].as_f64().unwrap();
            assert!(
                (v - want).abs() <= 1e-12 * want.abs(),
                "{name}.{field}: {v} vs {want}"
            );
        }
    }
}

/// What the harness expects of an acknowledged upload.
#[derive(Clone, Debug)]
struct Acked {
    run_id: String,
    job_id: String,
    sha256: String,
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn kill_harness_twenty_sigkills_lose_nothing_acknowledged() {
    const KILLS: usize = 20;
    const CLIENTS: usize = 2;
    // Each client's pause after an acknowledged upload: uploads still come
    // faster than two workers calibrate them (a job runs at nearly every
    // kill), but the backlog the final start drains stays short (150 ms
    // left twice the uploads and half a minute of draining).
    const PACE_MS: u64 = 300;
    let data = tempfile::tempdir().unwrap();
    let logs = tempfile::tempdir().unwrap();
    let log = logs.path().join("server.log");
    let args = [
        "--workers",
        "2",
        "--lease-secs",
        "1",
        "--max-attempts",
        "50",
    ];
    let dir = tempfile::tempdir().unwrap();
    let base_run = short_run(dir.path(), 21, DataFormat::Csv, "RLG-0042");
    let base_csv = std::fs::read(&base_run.data).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20);
    let acked: Arc<Mutex<Vec<Acked>>> = Arc::default();
    let (mut refused_in_flight, mut kills_with_running_jobs) = (0usize, 0usize);
    let mut token = None;
    let mut next_upload = 0usize;
    let http = reqwest::Client::new();
    for round in 0..KILLS {
        let (mut server, t) = start(data.path(), &log, &args);
        if t.is_some() {
            token = t;
        }
        let token = token.clone().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let mut clients = Vec::new();
        for _ in 0..CLIENTS {
            let (http, base, token, stop, acked) = (
                http.clone(),
                server.api(),
                token.clone(),
                stop.clone(),
                acked.clone(),
            );
            let first = next_upload;
            next_upload += 1000;
            let base_csv = base_csv.clone();
            let meta = base_run.metadata.clone();
            clients.push(tokio::spawn(async move {
                let mut failed = 0;
                for k in first.. {
                    if stop.load(std::sync::atomic::Ordering::Relaxed) {
                        break;
                    }
                    // A comment makes every upload's bytes distinct.
                    let mut body = format!("# upload {k}\n").into_bytes();
                    body.extend_from_slice(&base_csv);
                    let sha = sha256_hex(&body);
                    match process::upload_run(&http, &base, &token, "RLG-0042", &meta, body).await {
                        Ok(r) if r.status() == 202 => {
                            // Paced, so the final drain stays short.
                            tokio::time::sleep(Duration::from_millis(PACE_MS)).await;
                            let v: Value = r.json().await.unwrap_or_default();
                            if v["run_id"].is_string() {
                                acked.lock().unwrap().push(Acked {
                                    run_id: v["run_id"].as_str().unwrap().into(),
                                    job_id: v["job_id"].as_str().unwrap().into(),
                                    sha256: sha,
                                });
                            }
                        }
                        Ok(r) => panic!("upload answered {}", r.status()),
                        Err(_) => {
                            failed += 1;
                            break;
                        }
                    }
                }
                failed
            }));
        }
        let wait = Duration::from_millis(rng.gen_range(300..2500));
        tokio::time::sleep(wait).await;
        // Was a job running at the moment of the kill?
        let metrics = http
            .get(format!("{}/metrics", server.api()))
            .bearer_auth(&token)
            .send()
            .await
            .unwrap()
            .text()
            .await
            .unwrap();
        if !metrics.contains("sinscal_jobs{state=\"running\"} 0") {
            kills_with_running_jobs += 1;
        }
        server.sigkill();
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
        for c in clients {
            refused_in_flight += c.await.unwrap();
        }
        eprintln!(
            "round {round}: killed after {wait:?}, {} acknowledged so far",
            acked.lock().unwrap().len()
        );
    }

    // A last start drains the queue.
    let token = token.unwrap();
    let (server, _) = start(data.path(), &log, &args);
    let acked = acked.lock().unwrap().clone();
    for a in &acked {
        let job = wait_final(
            &http,
            &token,
            &server.api(),
            &a.job_id,
            Duration::from_secs(300),
        )
        .await;
        assert_eq!(job["state"], "succeeded", "{job}");
    }
    let all_done = Instant::now();
    loop {
        let m = http
            .get(format!("{}/metrics", server.api()))
            .bearer_auth(&token)
            .send()
            .await
            .unwrap()
            .text()
            .await
            .unwrap();
        if m.contains("sinscal_jobs{state=\"queued\"} 0")
            && m.contains("sinscal_jobs{state=\"running\"} 0")
        {
            break;
        }
        assert!(
            all_done.elapsed() < Duration::from_secs(300),
            "queue never drained: {m}"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    stop_cleanly(server);

    // Inspect what is on disk.
    let db = sqlx::SqlitePool::connect(&format!(
        "sqlite://{}?mode=ro",
        data.path().join("sinscal.db").display()
    ))
    .await
    .unwrap();
    let runs: Vec<(String, String, String, String)> = sqlx::query(
        "SELECT r.id, r.sha256, r.blob_path, j.state FROM runs r JOIN jobs j ON j.run_id = r.id",
    )
    .fetch_all(&db)
    .await
    .unwrap()
    .into_iter()
    .map(|r| (r.get(0), r.get(1), r.get(2), r.get(3)))
    .collect();
    let by_id: HashMap<&str, &(String, String, String, String)> =
        runs.iter().map(|r| (r.0.as_str(), r)).collect();
    for a in &acked {
        let row = by_id
            .get(a.run_id.as_str())
            .unwrap_or_else(|| panic!("acknowledged run {} lost", a.run_id));
        assert_eq!(row.1, a.sha256, "stored hash of {}", a.run_id);
        let bytes = std::fs::read(data.path().join(&row.2)).unwrap();
        assert_eq!(sha256_hex(&bytes), a.sha256, "bytes of {}", a.run_id);
    }
    let jobs_total: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM jobs")
        .fetch_one(&db)
        .await
        .unwrap();
    assert_eq!(jobs_total as usize, runs.len(), "one job per run");
    for r in &runs {
        assert_eq!(r.3, "succeeded", "every stored run's job finished: {r:?}");
    }
    let results: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM results")
        .fetch_one(&db)
        .await
        .unwrap();
    assert_eq!(results as usize, runs.len(), "exactly one result per job");
    let blobs: i64 =
        sqlx::query_scalar("SELECT COUNT(*) FROM results WHERE length(param_values) = 192")
            .fetch_one(&db)
            .await
            .unwrap();
    assert_eq!(blobs as usize, runs.len(), "every result has its 24 values");
    let max_attempts: i64 = sqlx::query_scalar("SELECT MAX(attempts) FROM jobs")
        .fetch_one(&db)
        .await
        .unwrap();
    let retried: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM jobs WHERE attempts > 1")
        .fetch_one(&db)
        .await
        .unwrap();
    let dup: i64 = sqlx::query_scalar("SELECT COUNT(*) - COUNT(DISTINCT sha256) FROM runs")
        .fetch_one(&db)
        .await
        .unwrap();
    assert_eq!(dup, 0);

    // Files: nothing partial, nothing without a row, nothing missing.
    let runs_dir = data.path().join("runs");
    assert_eq!(
        std::fs::read_dir(runs_dir.join("tmp")).unwrap().count(),
        0,
        "partial uploads left"
    );
    let expected: HashSet<PathBuf> = runs.iter().map(|r| data.path().join(&r.2)).collect();
    let mut found = HashSet::new();
    for shard in std::fs::read_dir(&runs_dir).unwrap() {
        let shard = shard.unwrap().path();
        if shard.is_dir() && shard.file_name().unwrap() != "tmp" {
            for f in std::fs::read_dir(&shard).unwrap() {
                found.insert(f.unwrap().path());
            }
        }
    }
    assert_eq!(found, expected, "run files and rows agree");
    eprintln!(
        "kill harness: {KILLS} SIGKILLs ({kills_with_running_jobs} with a job running), {} uploads acknowledged, \
         {} stored runs ({} committed but unacknowledged), {refused_in_flight} uploads cut by a kill, \
         {retried} jobs re-run after a kill (max attempts {max_attempts}), all {} jobs succeeded once",
        acked.len(),
        runs.len(),
        runs.len() - acked.len(),
        runs.len()
    );
}
