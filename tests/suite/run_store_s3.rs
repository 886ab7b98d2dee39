//! Runs kept in an S3-compatible object store (`--run-store s3://…`),
//! against a real S3 server (moto's, see `common::s3`): upload, the job's
//! read, the noise page's read and deletion go through the bucket; the
//! sweep deletes objects no row names once older than the grace period and
//! leaves younger ones; a large run goes up in parts and comes back whole;
//! a missing bucket or refused credentials stop the server with a message
//! naming what failed.

use crate::common;

use std::io::Write;
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::s3::S3Server;
use common::{problem, short_run, spawn_app_with};
use reqwest::StatusCode;
use serde_json::Value;
use sha2::{Digest, Sha256};
use sinscal_core::io::data::DataFormat;
use sinscal_server::metrics::Metrics;
use sinscal_server::runfiles::RunFiles;
use sinscal_server::runstore::RunStore;

const PREFIX: &str = "fleet/a";

/// The key of a row's blob path under the test's prefix.
fn key(blob_path: &str) -> String {
    format!("{PREFIX}/{blob_path}")
}

/// Uploads `run` and returns (run id, job id).
async fn upload(app: &common::TestApp, serial: &str, run: &common::SimRun) -> (String, String) {
    let r = app.upload_run(serial, run).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let up: Value = r.json().await.unwrap();
    (
        up["run_id"].as_str().unwrap().to_string(),
        up["job_id"].as_str().unwrap().to_string(),
    )
}

/// Files in the data folder's `dir` (`scratch`, `runs/tmp`).
fn files_in(app: &common::TestApp, dir: &str) -> usize {
    std::fs::read_dir(app.data_dir.path().join(dir))
        .map(|d| d.count())
        .unwrap_or(0)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn runs_live_in_the_bucket_from_upload_through_calibration_to_deletion_and_the_sweep() {
    let mut s3 = S3Server::start().await;
    let bucket_name = s3.create_bucket("sinscal-runs").await;
    let bucket = s3.client(&bucket_name);
    let grace = Duration::from_secs(8);
    let spec = s3.run_store(&bucket_name, PREFIX, grace, Duration::from_millis(500));
    let app = spawn_app_with(1, |c| c.run_store = spec).await;
    let dir = tempfile::tempdir().unwrap();

    // A stored run: its object sits at the prefix and the blob path the
    // local folder would use; nothing stays on the local disk.
    let run_a = short_run(dir.path(), 21, DataFormat::F64le, "RLG-S3A");
    let (run_a_id, job_a) = upload(&app, "RLG-S3A", &run_a).await;
    let blob_a = RunFiles::blob_path(&run_a_id, "bin");
    assert!(
        bucket.exists(&key(&blob_a)).await,
        "{:?}",
        bucket.keys(PREFIX).await
    );
    assert!(app.stored_files().is_empty(), "{:?}", app.stored_files());
    assert_eq!(files_in(&app, "runs/tmp"), 0);

    // Something else under the prefix, and an object no row names (as a
    // crash between put and commit leaves), both put now.
    bucket
        .put(&format!("{PREFIX}/notes/readme.txt"), b"not a run")
        .await;
    let orphan = key("runs/zz/zz-orphan.bin");
    bucket.put(&orphan, b"no row names me").await;
    let orphan_put = Instant::now();

    // The worker reads the run from the bucket, through a scratch copy
    // removed after the job.
    let job = app.wait_job(&job_a, Duration::from_secs(120)).await;
    assert_eq!(job["state"], "succeeded", "{job}");
    let result = app.get_result(&run_a_id).await;
    assert_eq!(result["model"], "base-24", "{result}");
    assert!(!result["convergence"]["t"].as_array().unwrap().is_empty());
    assert_eq!(files_in(&app, "scratch"), 0);

    // The noise page reads it the same way.
    let r = app
        .get(&app.admin, &format!("/runs/{run_a_id}/noise"))
        .await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(files_in(&app, "scratch"), 0);

    // The same bytes again: answered with the first run, no new object.
    let r = app.upload_run("RLG-S3A", &run_a).await;
    assert_eq!(r.status(), StatusCode::OK);
    let runs: Vec<String> = bucket
        .keys(&format!("{PREFIX}/runs"))
        .await
        .into_iter()
        .filter(|k| *k != orphan)
        .collect();
    assert_eq!(runs, [key(&blob_a)]);

    // Deleting a run deletes its object.
    let run_b = short_run(dir.path(), 22, DataFormat::Csv, "RLG-S3B");
    let (run_b_id, job_b) = upload(&app, "RLG-S3B", &run_b).await;
    let blob_b = RunFiles::blob_path(&run_b_id, "csv");
    assert!(bucket.exists(&key(&blob_b)).await);
    app.wait_job(&job_b, Duration::from_secs(120)).await;
    let r = app
        .http
        .delete(app.url(&format!("/runs/{run_b_id}")))
        .bearer_auth(&app.admin)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::NO_CONTENT);
    assert!(!bucket.exists(&key(&blob_b)).await);

    // The periodic sweep deletes the orphan once it is older than the
    // grace period; run A's object, older still, has a row and stays, and
    // so does what is outside the run area.
    let deadline = orphan_put + grace + Duration::from_secs(60);
    while bucket.exists(&orphan).await {
        assert!(Instant::now() < deadline, "the orphan was never swept");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    assert!(bucket.exists(&key(&blob_a)).await);
    assert!(bucket.exists(&format!("{PREFIX}/notes/readme.txt")).await);
    // A fresh orphan outlives several sweeps.
    let fresh = key("runs/zz/zz-fresh.bin");
    bucket.put(&fresh, b"perhaps another server's upload").await;
    tokio::time::sleep(Duration::from_millis(2000)).await;
    assert!(bucket.exists(&fresh).await, "a fresh object was swept");

    // Readiness and the metrics see the store.
    let ready = app.http.get(app.url("/readyz")).send().await.unwrap();
    assert_eq!(ready.status(), StatusCode::OK);
    let metrics = app.metrics().await;
    for op in ["put", "get", "delete", "list"] {
        let line = format!("sinscal_run_store_seconds_count{{op=\"{op}\"}} ");
        let count: u64 = metrics
            .lines()
            .find_map(|l| l.strip_prefix(&line))
            .unwrap_or_else(|| panic!("no {line} in\n{metrics}"))
            .parse()
            .unwrap();
        assert!(count > 0, "{line}{count}");
    }

    // A store that stops answering makes the server unready, named.
    s3.kill();
    let (status, body) = problem(app.http.get(app.url("/readyz")).send().await.unwrap()).await;
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE);
    let detail = body["detail"].as_str().unwrap();
    assert!(detail.contains(&bucket_name), "{detail}");
    app.stop().await;
}

/// A run larger than a part goes up as a multipart upload, streamed from
/// its temp file, and comes back whole through a scratch copy.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_large_run_goes_up_in_parts_and_comes_back_whole() {
    let s3 = S3Server::start().await;
    let bucket_name = s3.create_bucket("sinscal-parts").await;
    let bucket = s3.client(&bucket_name);
    let spec = s3.run_store(
        &bucket_name,
        PREFIX,
        Duration::from_secs(3600),
        Duration::from_secs(3600),
    );
    let data = tempfile::tempdir().unwrap();
    let store = RunStore::open(&spec, data.path(), Arc::new(Metrics::default()))
        .await
        .expect("open the store");

    // 20 MiB and a bit, not a multiple of anything: three parts.
    let (pending, file) = store.create_temp().unwrap();
    let mut file = std::io::BufWriter::new(file);
    let mut hasher = Sha256::new();
    let mut x = 0x9e37_79b9_7f4a_7c15_u64;
    for _ in 0..(20 * (1 << 20) + 12_345) / 8 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        file.write_all(&x.to_le_bytes()).unwrap();
        hasher.update(x.to_le_bytes());
    }
    file.into_inner().unwrap().sync_all().unwrap();
    let sent = hex::encode(hasher.finalize());

    let blob = RunFiles::blob_path("ab12-large", "bin");
    let stored = store.commit(pending, &blob).await.expect("upload");
    stored.keep();
    assert_eq!(bucket.keys(PREFIX).await, [key(&blob)]);
    assert_eq!(
        std::fs::read_dir(data.path().join("runs/tmp"))
            .unwrap()
            .count(),
        0
    );

    let copy = store.local_copy(&blob).await.expect("download");
    let got = hex::encode(Sha256::digest(std::fs::read(copy.path()).unwrap()));
    assert_eq!(got, sent);
    let scratch = copy.path().to_path_buf();
    drop(copy);
    assert!(!scratch.exists());

    store.remove(&blob).await.unwrap();
    assert!(bucket.keys(PREFIX).await.is_empty());
    // Removing it again (a retried delete) is not an error.
    store.remove(&blob).await.unwrap();
}

/// Starts `sinscal serve` on `run_store` with `s3`'s settings, expecting
/// it to stop by itself: its stderr.
async fn refused_serve(s3: &S3Server, run_store: &str) -> String {
    let data = tempfile::tempdir().unwrap();
    let mut serve = std::process::Command::new(env!("CARGO_BIN_EXE_sinscal"));
    serve
        .args(["serve", "--bind", "127.0.0.1:0", "--workers", "1"])
        .arg("--data-dir")
        .arg(data.path())
        .args(["--run-store", run_store])
        .env("RUST_LOG", "error")
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    for (k, v) in s3.env() {
        serve.env(k, v);
    }
    let mut child = serve.spawn().unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("the server neither started nor stopped within two minutes");
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(String::from_utf8_lossy(&out.stdout).is_empty());
    stderr
}

/// `sinscal serve` with a bucket that does not exist stops at once with
/// an error naming the bucket, the endpoint and what failed.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_missing_bucket_stops_the_server_with_a_clear_error() {
    let s3 = S3Server::start().await;
    let stderr = refused_serve(&s3, "s3://sinscal-no-such-bucket/fleet").await;
    for needed in [
        "s3://sinscal-no-such-bucket/fleet",
        s3.endpoint.as_str(),
        "the bucket does not exist",
    ] {
        assert!(stderr.contains(needed), "{needed:?} missing from: {stderr}");
    }
}

/// A store that refuses the credentials stops the start with a message
/// that says so and names the variables to check, never the secret.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn refused_credentials_stop_the_server_with_a_clear_error() {
    let s3 = S3Server::start_refusing_credentials().await;
    let stderr = refused_serve(&s3, "s3://sinscal-fleet/line-1").await;
    for needed in [
        "s3://sinscal-fleet/line-1",
        s3.endpoint.as_str(),
        "access refused",
        "AWS_ACCESS_KEY_ID",
    ] {
        assert!(stderr.contains(needed), "{needed:?} missing from: {stderr}");
    }
    for (k, v) in s3.env() {
        if k == "AWS_SECRET_ACCESS_KEY" {
            assert!(!stderr.contains(&v), "the secret leaked: {stderr}");
        }
    }
}
