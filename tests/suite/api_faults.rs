//! Faults a production line meets: a full disk, stalled clients, costly
//! uploads, stations reading each other's runs, and the small refusals
//! (oversized heads, bad roles, runs too short to calibrate).

use crate::common;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use bytes::Bytes;
use common::*;
use reqwest::StatusCode;
use serde_json::Value;
use sinscal_core::io::data::DataFormat;
use sinscal_server::config::BodyPace;

/// A tmpfs of `mib` MiB mounted on a fresh temp dir, or `None` (said on
/// stderr) where this machine refuses the mount.
fn mount_tmpfs(mib: u32) -> Option<tempfile::TempDir> {
    let dir = tempfile::tempdir().unwrap();
    let status = std::process::Command::new("mount")
        .args(["-t", "tmpfs", "-o", &format!("size={mib}m"), "tmpfs"])
        .arg(dir.path())
        .stderr(std::process::Stdio::null())
        .status();
    match status {
        Ok(s) if s.success() => Some(dir),
        other => {
            eprintln!(
                "full disk: mounting a {mib} MiB tmpfs was refused ({other:?}); \
                 the full disk is covered by the injected storage error only"
            );
            None
        }
    }
}

/// Unmounts (lazily, so a still-open file does not stop it) when dropped,
/// a failed assertion included.
struct Unmount(PathBuf);

impl Drop for Unmount {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount")
            .arg("-l")
            .arg(&self.0)
            .status();
        let _ = std::fs::remove_dir(&self.0);
    }
}

/// Fills the filesystem holding `dir` with a ballast file until ENOSPC.
fn fill_disk(dir: &Path) -> PathBuf {
    let path = dir.join("ballast");
    let mut f = std::fs::File::create(&path).unwrap();
    for size in [1 << 20, 4096, 1] {
        let chunk = vec![0xa5u8; size];
        loop {
            match f.write_all(&chunk) {
                Ok(()) => {}
                Err(e) => {
                    assert_eq!(e.raw_os_error(), Some(libc::ENOSPC), "{e}");
                    break;
                }
            }
        }
    }
    path
}

async fn readyz(app: &TestApp) -> StatusCode {
    app.http
        .get(app.url("/readyz"))
        .send()
        .await
        .unwrap()
        .status()
}

async fn wait_ready(app: &TestApp, timeout: Duration) {
    let start = Instant::now();
    while readyz(app).await != StatusCode::OK {
        assert!(start.elapsed() < timeout, "not ready after {timeout:?}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// Polls a job until `pred` holds for it.
async fn wait_job_until(app: &TestApp, id: &str, what: &str, pred: impl Fn(&Value) -> bool) {
    let start = Instant::now();
    loop {
        let job = app.get_job(id).await;
        if pred(&job) {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "job {id} never {what}: {job}"
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

async fn assert_storage_full(r: reqwest::Response, what: &str) {
    let retry_after = r
        .headers()
        .get("retry-after")
        .map(|v| v.to_str().unwrap().parse::<u64>().unwrap());
    let (status, p) = problem(r).await;
    assert_eq!(status, StatusCode::INSUFFICIENT_STORAGE, "{what}: {p}");
    assert!(retry_after.is_some_and(|s| s > 0), "{what}: no Retry-After");
}

async fn json_of(r: reqwest::Response, status: StatusCode) -> Value {
    assert_eq!(r.status(), status);
    r.json().await.unwrap()
}

/// Uploads `run` and steps the queue in the background until its job is
/// running: the upload's answer, the job's id and the step.
async fn upload_and_start(
    app: &TestApp,
    serial: &str,
    run: &SimRun,
) -> (
    Value,
    String,
    tokio::task::JoinHandle<Result<sinscal_server::jobs::Outcome, sinscal_server::jobs::JobError>>,
) {
    let a = json_of(app.upload_run(serial, run).await, StatusCode::ACCEPTED).await;
    let job = a["job_id"].as_str().unwrap().to_string();
    let runner = app.runner.clone();
    let step = tokio::spawn(async move { runner.try_run_next_job(0).await });
    wait_job_until(app, &job, "claimed", |j| j["state"] == "running").await;
    (a, job, step)
}

/// Once storage is back: the held job `job` ends as succeeded.
async fn assert_succeeds(
    step: tokio::task::JoinHandle<
        Result<sinscal_server::jobs::Outcome, sinscal_server::jobs::JobError>,
    >,
    job: &str,
) {
    let outcome = step.await.unwrap().unwrap();
    assert_eq!(
        outcome,
        sinscal_server::jobs::Outcome::Ran {
            job_id: job.parse().unwrap(),
            end: sinscal_server::jobs::JobEnd::Succeeded
        }
    );
}

/// A second upload is accepted and calibrated; both jobs succeeded at
/// their first attempt and exactly their two files are stored.
async fn assert_second_upload_calibrates(
    app: &TestApp,
    a: &Value,
    serial: &str,
    run_b: &SimRun,
) -> Value {
    let b = json_of(app.upload_run(serial, run_b).await, StatusCode::ACCEPTED).await;
    app.runner.try_run_next_job(0).await.unwrap();
    for run in [a, &b] {
        let j = app.get_job(run["job_id"].as_str().unwrap()).await;
        assert_eq!(j["state"], "succeeded", "{j}");
        assert_eq!(j["attempts"], 1, "{j}");
    }
    assert_eq!(app.stored_files().len(), 2, "{:?}", app.stored_files());
    b
}

/// The disk really fills (a 30 MiB tmpfs): an upload is 507 with
/// Retry-After, readiness 503, a job whose result meets the full disk
/// waits; once space is freed everything completes with no restart.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_real_full_disk_refuses_uploads_and_recovers_by_itself() {
    let Some(mount) = mount_tmpfs(30) else {
        return;
    };
    let mount_path = mount.path().to_path_buf();
    let _unmount = Unmount(mount_path.clone());
    let (dir_a, dir_b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let run_a = short_run(dir_a.path(), 1, DataFormat::Csv, "RLG-FULL");
    let run_b = short_run(dir_b.path(), 2, DataFormat::Csv, "RLG-FULL");
    // The floor is off so that the writes themselves meet ENOSPC and
    // SQLITE_FULL (the floor is tested apart). The test steps the queue.
    let app = spawn_app_in(mount, 0, |c| c.min_free_bytes = 0).await;
    // Job A is running: its result (≈ 0.5 MB) will meet the full disk.
    let (a, job_a, step) = upload_and_start(&app, "RLG-FULL", &run_a).await;
    let ballast = fill_disk(&mount_path);

    assert_storage_full(
        app.upload_run("RLG-FULL", &run_b).await,
        "upload on a full disk",
    )
    .await;
    assert_eq!(readyz(&app).await, StatusCode::SERVICE_UNAVAILABLE);
    // A small database write either fits or is 507; never a 500.
    let r = app
        .http
        .post(app.url("/tokens"))
        .bearer_auth(&app.admin)
        .json(&serde_json::json!({"role": "station"}))
        .send()
        .await
        .unwrap();
    assert!(
        matches!(r.status().as_u16(), 201 | 507),
        "token while full: {}",
        r.status()
    );

    // Job A finished its estimate; its result write is refused and
    // retried, not failed.
    let retries = || async {
        let m = app.metrics().await;
        let line = m
            .lines()
            .find(|l| l.starts_with("sinscal_storage_full_retries_total "))
            .unwrap()
            .to_string();
        line.rsplit(' ').next().unwrap().parse::<u64>().unwrap()
    };
    // Only where the database lives on the full disk (SQLite in the data
    // folder): on PostgreSQL the result's rows do not meet it.
    if app.store.backend() == sinscal_server::store::Backend::Sqlite {
        let start = Instant::now();
        while retries().await == 0 {
            assert!(start.elapsed() < Duration::from_secs(120), "no retry seen");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        assert_eq!(app.get_job(&job_a).await["state"], "running");
    }

    std::fs::remove_file(&ballast).unwrap();
    assert_succeeds(step, &job_a).await;
    wait_ready(&app, Duration::from_secs(30)).await;
    let b = assert_second_upload_calibrates(&app, &a, "RLG-FULL", &run_b).await;
    for run in [&a, &b] {
        let result = app.get_result(run["run_id"].as_str().unwrap()).await;
        assert_eq!(result["parameters"].as_object().unwrap().len(), 24);
    }
    // The writer is usable: a write after the full disk succeeds.
    app.create_token("engineer").await;
    app.stop().await;
}

/// The same path on any machine: the storage-full error injected where
/// `BEGIN IMMEDIATE` fails on a full disk. The worker keeps its result and
/// retries the write (the job is not failed), uploads are 507, readiness
/// 503, and everything completes once the fault clears.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_injected_storage_error_holds_the_result_until_the_write_succeeds() {
    let app = spawn_app(0).await;
    let (dir_a, dir_b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let run_a = short_run(dir_a.path(), 3, DataFormat::Csv, "RLG-SEAM");
    let run_b = short_run(dir_b.path(), 4, DataFormat::Csv, "RLG-SEAM");
    let (a, job_a, step) = upload_and_start(&app, "RLG-SEAM", &run_a).await;
    app.store.simulate_storage_full(true);

    assert_storage_full(app.upload_run("RLG-SEAM", &run_b).await, "upload").await;
    assert_eq!(readyz(&app).await, StatusCode::SERVICE_UNAVAILABLE);
    wait_job_until(&app, &job_a, "retrying its result", |j| {
        j["stage"]
            .as_str()
            .is_some_and(|s| s.contains("storage full, retrying"))
    })
    .await;
    assert_eq!(app.get_job(&job_a).await["state"], "running");

    app.store.simulate_storage_full(false);
    assert_succeeds(step, &job_a).await;
    assert_eq!(readyz(&app).await, StatusCode::OK);
    assert_second_upload_calibrates(&app, &a, "RLG-SEAM", &run_b).await;
    app.stop().await;
}

/// Below the free-space floor an upload is refused before its body is
/// read, and readiness fails.
#[tokio::test]
async fn below_the_free_space_floor_uploads_are_507_and_readiness_503() {
    let app = spawn_app_with(0, |c| c.min_free_bytes = u64::MAX).await;
    assert_eq!(readyz(&app).await, StatusCode::SERVICE_UNAVAILABLE);
    let r = app
        .upload_raw(
            &app.admin,
            "RLG-0042",
            &metadata("RLG-0042", "csv"),
            b"t,dthx,dthy,dthz,dvx,dvy,dvz\n".to_vec(),
        )
        .await;
    assert_storage_full(r, "below the floor").await;
    app.stop().await;
}

fn host_port(app: &TestApp) -> String {
    app.base
        .trim_start_matches("http://")
        .split('/')
        .next()
        .unwrap()
        .to_string()
}

/// Twenty clients send a head and a few body bytes, then stall: the slots
/// they hold are reclaimed, and a normal upload is answered.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stalled_uploads_are_dropped_and_a_normal_upload_is_answered() {
    let app = spawn_app_with(0, |c| {
        c.upload_pace = BodyPace {
            idle: Duration::from_secs(2),
            min_bytes_per_s: 10_000,
            grace: Duration::from_secs(2),
        };
    })
    .await;
    let addr = host_port(&app);
    let meta = String::from_utf8(metadata("RLG-STALL", "csv")).unwrap();
    let mut stalled = Vec::new();
    for _ in 0..20 {
        let mut s = TcpStream::connect(&addr).unwrap();
        write!(
            s,
            "POST /api/v1/units/RLG-STALL/runs HTTP/1.1\r\nHost: {addr}\r\n\
             Authorization: Bearer {}\r\nX-Sinscal-Metadata: {meta}\r\n\
             Content-Type: application/octet-stream\r\nContent-Length: 10000000\r\n\r\nt,dthx",
            app.admin
        )
        .unwrap();
        stalled.push(s);
    }
    let runs = tempfile::tempdir().unwrap();
    let run = short_run(runs.path(), 5, DataFormat::Csv, "RLG-STALL");
    let upload = app.upload_run("RLG-STALL", &run);
    let sent = Instant::now();
    let r = tokio::time::timeout(Duration::from_secs(30), upload)
        .await
        .expect("a normal upload is answered while stalled clients hold connections");
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    eprintln!(
        "stalled uploads: a normal upload behind 20 stalled ones answered in {:.1} s (idle timeout 2 s)",
        sent.elapsed().as_secs_f64()
    );
    // The stalled clients were answered 408 (problem+json) and let go.
    let mut s = stalled.pop().unwrap();
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    let mut head = [0u8; 64];
    let n = s.read(&mut head).unwrap();
    let head = String::from_utf8_lossy(&head[..n]);
    assert!(head.starts_with("HTTP/1.1 408"), "{head}");
    app.stop().await;
}

/// CPU time of this process, s (server and client share it; the client's
/// part here is sending bytes).
fn process_cpu_s() -> f64 {
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `ru` is a valid out-parameter.
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) };
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    tv(ru.ru_utime) + tv(ru.ru_stime)
}

/// Uploads `members` copies of one gzip member holding 1 MiB of `line`
/// repeated (members concatenate, so the body costs one small compression
/// to make); the refusal, the compressed size and the process CPU used.
async fn send_bomb(app: &TestApp, line: &str, members: usize) -> (StatusCode, Value, usize, f64) {
    let chunk = line.repeat((1 << 20) / line.len());
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    enc.write_all(chunk.as_bytes()).unwrap();
    let member = Bytes::from(enc.finish().unwrap());
    let compressed = member.len() * members;
    let body = futures_util::stream::iter(
        (0..members).map(move |_| Ok::<_, std::io::Error>(member.clone())),
    );
    let cpu0 = process_cpu_s();
    let r = app
        .http
        .post(app.url("/units/RLG-BOMB/runs"))
        .bearer_auth(&app.admin)
        .header("x-sinscal-metadata", metadata("RLG-BOMB", "csv"))
        .header("content-type", "application/octet-stream")
        .body(reqwest::Body::wrap_stream(body))
        .send()
        .await
        .unwrap();
    let (status, p) = problem(r).await;
    (status, p, compressed, process_cpu_s() - cpu0)
}

/// Gzip bombs of comment lines are refused after a bounded read: 10 GB of
/// short comment lines (10 MB of gzip) at the comment-line cap, long
/// comment lines (fewer of them) at the expansion-ratio cap.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn gzip_bombs_of_comment_lines_are_refused_after_a_bounded_read() {
    let app = spawn_app(0).await;
    let defaults = sinscal_server::config::Config::new(".");
    // 9537 MiB = 10 GB.
    let (status, p, compressed, cpu) = send_bomb(&app, "#\n", 9537).await;
    eprintln!(
        "comment bomb: {compressed} bytes of gzip (10 GB of comment lines) refused with \
         {status} after {cpu:.2} s of process CPU: {}",
        p["detail"]
    );
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{p}");
    assert_eq!(p["line"], defaults.max_comment_lines + 1, "{p}");
    assert!(
        p["detail"]
            .as_str()
            .unwrap()
            .contains("comment or blank lines"),
        "{p}"
    );

    let long = format!("#{}\n", "x".repeat(4094));
    let (status, p, compressed, cpu) = send_bomb(&app, &long, 2048).await;
    eprintln!(
        "long-line bomb: {compressed} bytes of gzip (2 GiB) refused with {status} after \
         {cpu:.2} s of process CPU: {}",
        p["detail"]
    );
    assert_eq!(status, StatusCode::PAYLOAD_TOO_LARGE, "{p}");
    assert!(
        p["detail"].as_str().unwrap().contains("expands more than"),
        "{p}"
    );
    // Refused within the first 16 MiB (+ one read-ahead window) of text.
    let line = p["line"].as_u64().unwrap();
    assert!(line <= (17 << 20) / 4096, "{p}");
    assert!(app.stored_files().is_empty());
    app.stop().await;
}

/// Station tokens read only their own runs and jobs; a duplicate by
/// another station discloses nothing; engineers and admins read all.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stations_read_only_their_own_runs_and_jobs() {
    let app = spawn_app(0).await;
    let station_a = app.create_token("station").await;
    let station_b = app.create_token("station").await;
    let engineer = app.create_token("engineer").await;
    let runs = tempfile::tempdir().unwrap();
    let run = short_run(runs.path(), 6, DataFormat::Csv, "RLG-0042");
    let data = std::fs::read(&run.data).unwrap();
    let up = app
        .upload_multipart(&station_a, "RLG-0042", &run.metadata, data.clone())
        .await;
    let up = json_of(up, StatusCode::ACCEPTED).await;
    let (run_id, job_id) = (
        up["run_id"].as_str().unwrap(),
        up["job_id"].as_str().unwrap(),
    );
    let run_path = format!("/runs/{run_id}");
    let job_path = format!("/jobs/{job_id}");

    for (who, token, status) in [
        ("station A", &station_a, StatusCode::OK),
        ("station B", &station_b, StatusCode::NOT_FOUND),
        ("engineer", &engineer, StatusCode::OK),
        ("admin", &app.admin, StatusCode::OK),
    ] {
        for path in [&run_path, &job_path] {
            let r = app.get(token, path).await;
            assert_eq!(r.status(), status, "{who} GET {path}");
        }
    }
    // Station B sends the same bytes: 409, and no id of A's run.
    let r = app
        .upload_multipart(&station_b, "RLG-0042", &run.metadata, data.clone())
        .await;
    let (status, p) = problem(r).await;
    assert_eq!(status, StatusCode::CONFLICT);
    let text = p.to_string();
    assert!(!text.contains(run_id) && !text.contains(job_id), "{text}");
    // Station A again: its own run, 200.
    let r = app
        .upload_multipart(&station_a, "RLG-0042", &run.metadata, data.clone())
        .await;
    let again = json_of(r, StatusCode::OK).await;
    assert_eq!(again["run_id"], run_id);
    // The same bytes with corrected metadata are refused, not answered
    // with the old run's metadata kept.
    let mut meta: Value = serde_json::from_slice(&run.metadata).unwrap();
    meta["recorded_at"] = "2026-03-01T08:00:00Z".into();
    let r = app
        .upload_multipart(
            &station_a,
            "RLG-0042",
            &serde_json::to_vec(&meta).unwrap(),
            data.clone(),
        )
        .await;
    let (status, p) = problem(r).await;
    assert_eq!(status, StatusCode::CONFLICT);
    assert!(
        p["detail"].as_str().unwrap().contains("different metadata"),
        "{p}"
    );
    // Results stay an engineer's read.
    let r = app.get(&station_a, &format!("/runs/{run_id}/result")).await;
    assert_eq!(r.status(), StatusCode::FORBIDDEN);
    app.stop().await;
}

/// A CSV of `n` records at rest sampled at `rate_hz` (one attitude).
fn rest_csv(n: usize, rate_hz: f64) -> Vec<u8> {
    let mut out = String::from("t,dthx,dthy,dthz,dvx,dvy,dvz\n");
    let dt = 0.01; // the increments of 100 Hz data
    for k in 0..n {
        let t = k as f64 / rate_hz;
        out.push_str(&format!(
            "{t:.6},0,{:e},{:e},0,0,{:e}\n",
            6.4e-5 * dt,
            3.4e-5 * dt,
            9.79 * dt
        ));
    }
    out.into_bytes()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn runs_that_cannot_calibrate_are_refused_with_the_reason() {
    let app = spawn_app(1).await;
    let meta = metadata("RLG-0042", "csv");
    for (what, body, status, words) in [
        ("one record", rest_csv(1, 100.0), 422, "spans 0.00 s"),
        ("20 s at rest", rest_csv(2001, 100.0), 422, "at least 40 s"),
        (
            "100.5 Hz data",
            rest_csv(6000, 100.5),
            422,
            "mean rate is 100.5",
        ),
    ] {
        let (s, p) = problem(app.upload_raw(&app.admin, "RLG-0042", &meta, body).await).await;
        assert_eq!(s.as_u16(), status, "{what}: {p}");
        assert!(p["detail"].as_str().unwrap().contains(words), "{what}: {p}");
    }
    // 60 s in one attitude passes ingestion, and the estimator refuses it
    // instead of storing the prior as a calibration.
    let up = app
        .upload_raw(&app.admin, "RLG-0042", &meta, rest_csv(6001, 100.0))
        .await;
    let up = json_of(up, StatusCode::ACCEPTED).await;
    let job = app
        .wait_job(up["job_id"].as_str().unwrap(), Duration::from_secs(120))
        .await;
    assert_eq!(job["state"], "failed", "{job}");
    assert!(
        job["error"].as_str().unwrap().contains("two attitudes"),
        "{job}"
    );
    let history = app.history("RLG-0042", "").await;
    assert_eq!(history["total"], 0, "{history}");

    // Gzip data followed by bytes that are not gzip: named as such.
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(&rest_csv(6001, 100.0)).unwrap();
    let mut gz = enc.finish().unwrap();
    gz.extend_from_slice(b"garbage\n");
    let (s, p) = problem(app.upload_raw(&app.admin, "RLG-0042", &meta, gz).await).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{p}");
    assert!(
        p["detail"].as_str().unwrap().contains("not gzip data"),
        "{p}"
    );
    app.stop().await;
}

#[tokio::test]
async fn oversized_heads_and_bad_token_roles_answer_problem_json() {
    let app = spawn_app(0).await;
    let long = format!("/units?x={}", "a".repeat(20_000));
    let (s, _) = problem(app.get(&app.admin, &long).await).await;
    assert_eq!(s, StatusCode::URI_TOO_LONG);
    let mut req = app.http.get(app.url("/units")).bearer_auth(&app.admin);
    for i in 0..80 {
        req = req.header(format!("x-filler-{i}"), "v");
    }
    let (s, _) = problem(req.send().await.unwrap()).await;
    assert_eq!(s, StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE);
    let r = app
        .http
        .post(app.url("/tokens"))
        .bearer_auth(&app.admin)
        .json(&serde_json::json!({"role": "superuser"}))
        .send()
        .await
        .unwrap();
    let (s, _) = problem(r).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    let r = app
        .http
        .put(app.url("/units"))
        .bearer_auth(&app.admin)
        .send()
        .await
        .unwrap();
    let (s, _) = problem(r).await;
    assert_eq!(s, StatusCode::METHOD_NOT_ALLOWED);
    app.stop().await;
}

#[test]
fn token_create_refuses_a_data_dir_without_a_database() {
    let dir = tempfile::tempdir().unwrap();
    let typo = dir.path().join("sinscal-dta");
    let e = sinscal_server::server::create_token(
        &typo,
        None,
        sinscal_server::store::Role::Station,
        None,
    )
    .expect_err("no database there");
    assert!(e.to_string().contains("no database"), "{e}");
    assert!(!typo.exists(), "nothing is created");
}
