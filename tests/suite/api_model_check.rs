//! The model check through the server: a run the 24-parameter model does
//! not explain is stored with its check, marked for review in the run and
//! history views, and gets a diagnose job by itself; a clean run is clear
//! and gets none.

use crate::common;

use std::time::Duration;

use common::*;
use reqwest::StatusCode;
use serde_json::Value;
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::Effects;
use sinscal_core::sim::SimConfig;

async fn upload_and_calibrate(app: &TestApp, serial: &str, cfg: &SimConfig) -> String {
    let dir = tempfile::tempdir().unwrap();
    let run = simulate_run(dir.path(), cfg, DataFormat::F64le, false, serial, None);
    app.upload_and_calibrate(serial, &run, Duration::from_secs(300))
        .await
        .0
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_inadequate_run_is_marked_and_diagnosed_by_itself() {
    let app = spawn_app(1).await;
    let run_id = upload_and_calibrate(
        &app,
        "RLG-MC1",
        &model_check_run(11, delayed_accelerometers()),
    )
    .await;

    let result = app.get_result(&run_id).await;
    let check = &result["model_check"];
    assert_eq!(check["adequate"], false, "{check}");
    assert!(check["statistic"].as_f64().unwrap() > check["threshold"].as_f64().unwrap());
    assert!(!check["findings"].as_array().unwrap().is_empty());

    let run = app.get_run(&run_id).await;
    assert_eq!(run["review"], "needs_review", "{run}");
    assert_eq!(run["model_check"]["adequate"], false);
    let summary = run["model_check"]["summary"].as_str().unwrap();
    assert!(summary.contains("run `sinscal diagnose`"), "{summary}");

    let history = app.history("RLG-MC1", "").await;
    assert_eq!(history["items"][0]["review"], "needs_review", "{history}");
    assert_eq!(history["items"][0]["model_check"]["adequate"], false);

    // A diagnose job was queued when the result was stored: asking again
    // returns it (or, once it has finished, its report exists).
    let r = app.post_diagnose(&app.admin, &run_id).await;
    let (status, job): (StatusCode, Value) = (r.status(), r.json().await.unwrap());
    let job_id = job["id"].as_str().unwrap().to_string();
    assert_eq!(job["kind"], "diagnose");
    if status == StatusCode::ACCEPTED {
        // The automatic job finished before we asked: its report is there.
        let r = app
            .get(&app.admin, &format!("/runs/{run_id}/diagnosis"))
            .await;
        assert!(
            matches!(r.status(), StatusCode::OK | StatusCode::CONFLICT),
            "no automatic diagnosis: {}",
            r.status()
        );
    } else {
        assert_eq!(status, StatusCode::OK, "{job}");
    }
    let done = app.wait_job(&job_id, Duration::from_secs(600)).await;
    assert_eq!(done["state"], "succeeded", "{done}");
    let r = app
        .get(&app.admin, &format!("/runs/{run_id}/diagnosis"))
        .await;
    let report: Value = r.json().await.unwrap();
    assert_eq!(report["named"][0], "accel_delay", "{}", report["verdict"]);
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_clean_run_is_clear_and_the_option_can_turn_diagnosis_off() {
    let app = spawn_app_with(1, |c| c.diagnose_inadequate = false).await;
    let clean = upload_and_calibrate(&app, "RLG-MC2", &model_check_run(12, Effects::none())).await;
    let run = app.get_run(&clean).await;
    assert_eq!(run["review"], "clear", "{run}");
    assert_eq!(run["model_check"]["adequate"], true);
    assert_eq!(
        app.get_result(&clean).await["model_check"]["adequate"],
        true
    );

    // Inadequate, but with automatic diagnosis off: marked, not queued.
    let bad = upload_and_calibrate(
        &app,
        "RLG-MC2",
        &model_check_run(13, delayed_accelerometers()),
    )
    .await;
    assert_eq!(app.get_run(&bad).await["review"], "needs_review");
    let r = app.post_diagnose(&app.admin, &bad).await;
    let (status, job): (StatusCode, Value) = (r.status(), r.json().await.unwrap());
    assert_eq!(
        status,
        StatusCode::ACCEPTED,
        "a diagnose job was already queued: {job}"
    );
    let history = app.history("RLG-MC2", "").await;
    let reviews: Vec<&str> = history["items"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["review"].as_str().unwrap())
        .collect();
    assert_eq!(reviews, ["clear", "needs_review"], "{history}");
    app.stop().await;
}

/// A unit whose bias walks (0.0003 deg/h/√h, 3 µg/√h) but whose dwells
/// show white noise: its check fails and its result proposes the wander,
/// on the run page too. The engineer's button calibrates again with the
/// wander fitted: the new result's noise model is fitted, its check quiet,
/// the proposal gone. Through the API, `{"fit_unseen_wander": false}`
/// turns it off again; bodies that are not that object are refused naming
/// why.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_calibrated_again_fits_the_wander_its_result_proposed() {
    let app = spawn_app_with(1, |c| c.diagnose_inadequate = false).await;
    let mut cfg = model_check_run(2, Effects::none());
    cfg.scheme = sinscal_core::sim::Scheme::builtin("ten-position-9+9", 200.0).unwrap();
    cfg.noise.gyro_rrw_deg_h_rt_h = 0.0003;
    cfg.noise.accel_rw_ug_rt_h = 3.0;
    let run_id = upload_and_calibrate(&app, "RLG-MC3", &cfg).await;
    let white = |r: &Value| {
        assert_eq!(r["model_check"]["adequate"], false, "{}", r["model_check"]);
        assert_eq!(r["noise_model"]["source"], "measured");
        assert_eq!(r["noise_model"]["unseen_wander"]["fitted"], false);
    };
    white(&app.get_result(&run_id).await);
    let page = app.sign_in(&app.admin).await;
    let proposal = format!("/runs/{run_id}/fit-wander");
    let html = run_page(&page, &run_id).await;
    assert!(html.contains("unseen-wander") && html.contains(&proposal));

    let r = page.post(&proposal, &[]).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let job = app.get_run(&run_id).await["job_id"].clone();
    wait_succeeded(&app, &job).await;
    let result = app.get_result(&run_id).await;
    assert_eq!(result["noise_model"]["source"], "fitted");
    assert_eq!(result["noise_model"]["unseen_wander"]["fitted"], true);
    assert_eq!(
        result["model_check"]["adequate"], true,
        "{}",
        result["model_check"]
    );
    assert_eq!(app.get_run(&run_id).await["review"], "clear");
    let html = run_page(&page, &run_id).await;
    assert!(
        !html.contains(&proposal),
        "the proposal is gone once fitted"
    );

    let calibrate = |body: &'static str, content_type: &'static str| {
        let req = app
            .http
            .post(app.url(&format!("/runs/{run_id}/calibrate")))
            .bearer_auth(app.admin.clone())
            .header("content-type", content_type)
            .body(body);
        async move { req.send().await.unwrap() }
    };
    for (body, content_type, status, says) in [
        (
            r#"{"fit_unseen_wander": "yes"}"#,
            "application/json",
            422,
            "fit_unseen_wander",
        ),
        (
            r#"{"fit_wander": true}"#,
            "application/json",
            422,
            "fit_wander",
        ),
        ("[true]", "application/json", 422, "JSON object"),
        (
            "fit_unseen_wander=true",
            "text/plain",
            400,
            "application/json",
        ),
    ] {
        let r = calibrate(body, content_type).await;
        let got = r.status().as_u16();
        let problem: Value = r.json().await.unwrap();
        assert_eq!(got, status, "{body}: {problem}");
        assert!(
            problem["detail"].as_str().unwrap_or("").contains(says),
            "{body}: {problem}"
        );
    }
    let r = calibrate(r#"{"fit_unseen_wander": false}"#, "application/json").await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let job: Value = r.json().await.unwrap();
    wait_succeeded(&app, &job["id"]).await;
    white(&app.get_result(&run_id).await);
    app.stop().await;
}

/// Waits for a job by id (a JSON string) and asserts it succeeded.
async fn wait_succeeded(app: &TestApp, job: &Value) {
    let done = app
        .wait_job(job.as_str().unwrap(), Duration::from_secs(300))
        .await;
    assert_eq!(done["state"], "succeeded", "{done}");
}

/// The run's page as the session sees it.
async fn run_page(page: &pages::PageSession, run_id: &str) -> String {
    page.get(&format!("/runs/{run_id}"))
        .await
        .text()
        .await
        .unwrap()
}
