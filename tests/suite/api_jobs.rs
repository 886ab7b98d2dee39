//! The queue's behaviour, driven step by step with `try_run_next_job`:
//! cancelling a running job, retries that keep their error, fencing of a
//! worker whose lease was reclaimed, hand-back at shutdown.

use crate::common;

use std::time::Duration;

use common::*;
use reqwest::StatusCode;
use serde_json::Value;
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::ErrorParameters;
use sinscal_server::jobs::{JobEnd, Outcome};

async fn upload_long(app: &TestApp) -> (Value, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    // The full 3.2 h run: a few seconds of estimation, time to act on it.
    let cfg = sim_config(3, ErrorParameters::paper(), "ten-position-9+9", 600.0);
    let run = simulate_run(dir.path(), &cfg, DataFormat::F64le, false, "RLG-0042", None);
    let r = app.upload_run("RLG-0042", &run).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    (r.json().await.unwrap(), dir)
}

async fn wait_running(app: &TestApp, job_id: &str) {
    for _ in 0..1000 {
        if app.get_job(job_id).await["state"] == "running" {
            return;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    panic!("job {job_id} never ran");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_running_job_can_be_cancelled() {
    let app = spawn_app(0).await;
    let (run, _dir) = upload_long(&app).await;
    let job_id = run["job_id"].as_str().unwrap().to_string();
    let runner = app.runner.clone();
    let step = tokio::spawn(async move { runner.try_run_next_job(0).await.unwrap() });
    wait_running(&app, &job_id).await;
    let r = app.cancel_job(&job_id).await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.json::<Value>().await.unwrap()["cancel_requested"], true);
    let outcome = step.await.unwrap();
    assert_eq!(
        outcome,
        Outcome::Ran {
            job_id: job_id.parse().unwrap(),
            end: JobEnd::Cancelled
        }
    );
    let job = app.get_job(&job_id).await;
    assert_eq!(job["state"], "cancelled");
    assert!(job["finished_at"].is_string());
    let r = app
        .get(
            &app.admin,
            &format!("/runs/{}/result", run["run_id"].as_str().unwrap()),
        )
        .await;
    assert_eq!(problem(r).await.0, StatusCode::CONFLICT);
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn failed_attempts_retry_up_to_the_limit_and_keep_their_error() {
    let app = spawn_app(0).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 9, DataFormat::F64le, "RLG-0042");
    let r: Value = app.upload_run("RLG-0042", &run).await.json().await.unwrap();
    let job_id = r["job_id"].as_str().unwrap().to_string();
    // The stored file disappears (a disk fault): every attempt fails to read it.
    for f in app.stored_files() {
        std::fs::remove_file(app.data_dir.path().join("runs").join(f)).unwrap();
    }
    let mut ends = Vec::new();
    for _ in 0..3 {
        match app.runner.try_run_next_job(0).await.unwrap() {
            Outcome::Ran { end, .. } => ends.push(end),
            Outcome::Empty => panic!("the job should be claimable again (zero backoff)"),
        }
    }
    assert_eq!(
        ends,
        [JobEnd::Retrying, JobEnd::Retrying, JobEnd::DeadLettered]
    );
    let job = app.get_job(&job_id).await;
    assert_eq!(job["state"], "dead_letter");
    assert_eq!(job["attempts"], 3);
    assert!(
        job["error"].as_str().unwrap().contains("cannot open"),
        "{job}"
    );
    assert_eq!(
        app.runner.try_run_next_job(0).await.unwrap(),
        Outcome::Empty
    );
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_whose_lease_was_reclaimed_cannot_write_its_result() {
    let app = spawn_app(0).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 11, DataFormat::F64le, "RLG-0042");
    let r: Value = app.upload_run("RLG-0042", &run).await.json().await.unwrap();
    let job_id = r["job_id"].as_str().unwrap().to_string();

    // Worker A claims with a lease that runs out at once (it stalled).
    let a = app
        .store
        .claim_job("worker-a", Duration::from_millis(1))
        .await
        .unwrap()
        .unwrap();
    tokio::time::sleep(Duration::from_millis(20)).await;
    // Worker B reclaims the expired job and finishes it.
    match app.runner.try_run_next_job(1).await.unwrap() {
        Outcome::Ran { end, .. } => assert_eq!(end, JobEnd::Succeeded),
        Outcome::Empty => panic!("expired job not reclaimed"),
    }
    let winner = app.get_result(r["run_id"].as_str().unwrap()).await;
    // A wakes up and tries to write: fenced out, on every path.
    let fake = sinscal_core::calib::CalibrationResult {
        estimator: sinscal_core::calib::ResultEstimator::Lsq,
        ..Default::default()
    };
    let sinscal_server::store::Subject::Run(run) = &a.subject else {
        panic!("a calibrate job's claim names its run")
    };
    assert!(!app
        .store
        .complete_job(
            (&a.fence, run),
            &fake,
            sinscal_server::store::OnInadequate {
                queue_diagnose: true,
                max_attempts: 3
            }
        )
        .await
        .unwrap());
    assert!(app
        .store
        .heartbeat(&a.fence, Duration::from_secs(30), 0.5, "x")
        .await
        .unwrap()
        .is_none());
    assert!(app
        .store
        .fail_job(&a.fence, "stale", true, Duration::ZERO)
        .await
        .unwrap()
        .is_none());
    assert!(!app.store.release_job(&a.fence).await.unwrap());
    assert!(!app.store.finish_cancelled(&a.fence).await.unwrap());
    let job = app.get_job(&job_id).await;
    assert_eq!(job["state"], "succeeded");
    assert_eq!(job["attempts"], 2);
    assert_eq!(app.get_result(r["run_id"].as_str().unwrap()).await, winner);
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_hands_a_running_job_back_and_a_new_server_finishes_it() {
    let data = tempfile::tempdir().unwrap();
    let mut config = test_config(data.path(), 1);
    config.shutdown_grace = Duration::from_millis(0);
    let app = sinscal_server::server::Application::build(config.clone())
        .await
        .unwrap();
    let admin = app.first_admin_token().unwrap().to_string();
    let base = format!("http://{}/api/v1", app.addr());
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(app.run_until_stopped(async {
        let _ = stopped.await;
    }));
    let dir = tempfile::tempdir().unwrap();
    let cfg = sim_config(3, ErrorParameters::paper(), "ten-position-9+9", 600.0);
    let run = simulate_run(dir.path(), &cfg, DataFormat::F64le, false, "RLG-0042", None);
    let http = reqwest::Client::new();
    let form = reqwest::multipart::Form::new()
        .part(
            "metadata",
            reqwest::multipart::Part::bytes(run.metadata.clone()),
        )
        .part(
            "data",
            reqwest::multipart::Part::bytes(std::fs::read(&run.data).unwrap()),
        );
    let r: Value = http
        .post(format!("{base}/units/RLG-0042/runs"))
        .bearer_auth(&admin)
        .multipart(form)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    let job_url = format!("{base}/jobs/{}", r["job_id"].as_str().unwrap());
    loop {
        let job: Value = http
            .get(&job_url)
            .bearer_auth(&admin)
            .send()
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        if job["state"] == "running" {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    stop.send(()).unwrap();
    server.await.unwrap().unwrap();

    // Handed back: queued again, the interrupted attempt not counted.
    let app = sinscal_server::server::Application::build(config)
        .await
        .unwrap();
    let store = app.store();
    let job = store
        .get_job(r["job_id"].as_str().unwrap().parse().unwrap())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(job.state, sinscal_server::store::JobState::Queued);
    assert_eq!(job.attempts, 0);
    assert_eq!(
        app.runner().try_run_next_job(0).await.unwrap(),
        Outcome::Ran {
            job_id: job.id,
            end: JobEnd::Succeeded
        }
    );
    assert_eq!(store.get_job(job.id).await.unwrap().unwrap().attempts, 1);
}

/// `POST /runs/{id}/calibrate` queues the run's calibration again: the old
/// result is gone at once (the unit's history without it), the same job
/// runs again with its attempts still counting, and the new result takes
/// its place; a second request while it waits is 409, and stations may not
/// ask.
#[tokio::test]
async fn a_run_calibrated_again_replaces_its_result() {
    let app = spawn_app(0).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 8, DataFormat::Csv, "RLG-RE");
    let up: Value = app.upload_run("RLG-RE", &run).await.json().await.unwrap();
    let run_id = up["run_id"].as_str().unwrap().to_string();
    app.runner.try_run_next_job(0).await.unwrap();
    let first = app.get_job(up["job_id"].as_str().unwrap()).await;
    assert_eq!(first["state"], "succeeded");
    let before = app.get_result(&run_id).await;
    let calibrate = |token: String| {
        let req = app
            .http
            .post(app.url(&format!("/runs/{run_id}/calibrate")))
            .bearer_auth(token);
        async move { req.send().await.unwrap() }
    };
    let station = app.create_token("station").await;
    assert_eq!(calibrate(station).await.status(), StatusCode::FORBIDDEN);
    let r = calibrate(app.admin.clone()).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let job: Value = r.json().await.unwrap();
    assert_eq!(job["id"], first["id"], "the run's one calibration job");
    assert_eq!(job["state"], "queued");
    let r = app.get(&app.admin, &format!("/runs/{run_id}/result")).await;
    assert_eq!(r.status(), StatusCode::CONFLICT, "the old result is gone");
    assert_eq!(app.history("RLG-RE", "").await["total"], 0);
    assert_eq!(
        calibrate(app.admin.clone()).await.status(),
        StatusCode::CONFLICT
    );
    app.runner.try_run_next_job(0).await.unwrap();
    let done = app.get_job(job["id"].as_str().unwrap()).await;
    assert_eq!(done["state"], "succeeded");
    assert!(done["attempts"].as_i64().unwrap() > first["attempts"].as_i64().unwrap());
    let after = app.get_result(&run_id).await;
    assert_eq!(
        after["parameters"], before["parameters"],
        "same data, same estimate"
    );
    assert_eq!(app.history("RLG-RE", "").await["total"], 1);
    app.stop().await;
}
