//! `POST /api/v1/designs` and `GET /api/v1/designs/{id}`: a scheme design
//! as a durable job. It is queued (202) with the request checked first,
//! run by a worker with its progress written as it goes, and read back
//! with its design; running out of the job's time limit fails it with the
//! reason in words, never a 422. Stations are refused.

use std::time::Duration;

use crate::common;

use common::{problem, spawn_app_with, TestApp};
use reqwest::StatusCode;
use serde_json::{json, Value};
use sinscal_server::jobs::{JobEnd, Outcome};

/// A quick design (a loose goal at tactical-grade noise, up to 7 turns:
/// `api_design`'s), so that the job's life, not the search, is timed.
fn quick() -> Value {
    json!({"target": "table1", "tighten": 0.1, "arw_deg_rt_h": 0.001,
           "vrw_ug_rt_hz": 10, "min_dwell_s": 60, "max_turns": 7})
}

async fn post(app: &TestApp, token: &str, body: &Value) -> reqwest::Response {
    app.http
        .post(app.url("/designs"))
        .bearer_auth(token)
        .json(body)
        .send()
        .await
        .unwrap()
}

async fn read(app: &TestApp, token: &str, id: &str) -> Value {
    let r = app.get(token, &format!("/designs/{id}")).await;
    assert_eq!(r.status(), StatusCode::OK);
    r.json().await.unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_design_is_queued_run_and_read_back() {
    let app = spawn_app_with(0, |_| {}).await;
    let engineer = app.create_token("engineer").await;
    let r = post(&app, &engineer, &quick()).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let id = {
        let location = r.headers()["location"].to_str().unwrap().to_string();
        let job: Value = r.json().await.unwrap();
        assert_eq!(
            location,
            format!("/api/v1/designs/{}", job["id"].as_str().unwrap())
        );
        assert_eq!(
            (job["kind"].as_str(), job["state"].as_str()),
            (Some("design"), Some("queued"))
        );
        assert!(
            job.get("run_id").is_none() && job.get("design").is_none(),
            "{job}"
        );
        // As asked (numbers read back as numbers, 10 as 10.0).
        let asked = &job["request"];
        assert_eq!(
            (asked["target"].as_str(), asked["max_turns"].as_u64()),
            (Some("table1"), Some(7))
        );
        assert_eq!(asked["vrw_ug_rt_hz"].as_f64(), Some(10.0));
        job["id"].as_str().unwrap().to_string()
    };

    let ran = app.runner.try_run_next_job(0).await.unwrap();
    assert!(
        matches!(
            ran,
            Outcome::Ran {
                end: JobEnd::Succeeded,
                ..
            }
        ),
        "{ran:?}"
    );
    let done = read(&app, &engineer, &id).await;
    assert_eq!(done["state"], "succeeded");
    assert_eq!(done["progress_percent"], 100.0);
    let params = done["design"]["parameters"].as_object().unwrap();
    assert_eq!(params.len(), 24);
    for (name, p) in params {
        assert!(p["ratio"].as_f64().unwrap() <= 1.0, "{name}: {p}");
    }
    // The same answer the synchronous route gives for the same body.
    let r = app
        .http
        .post(app.url("/schemes/design"))
        .bearer_auth(&engineer)
        .json(&quick())
        .send()
        .await
        .unwrap();
    let answered: Value = r.json().await.unwrap();
    assert_eq!(done["design"]["scheme"], answered["scheme"]);
    // The job reads as a job too, with no run.
    let job = app.get_job(&id).await;
    assert_eq!(
        (job["kind"].as_str(), job.get("run_id")),
        (Some("design"), None)
    );
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stations_are_refused_and_a_bad_request_names_its_field() {
    let app = spawn_app_with(0, |_| {}).await;
    let engineer = app.create_token("engineer").await;
    let station = app.create_token("station").await;
    let (status, _) = problem(post(&app, &station, &quick()).await).await;
    assert_eq!(status, StatusCode::FORBIDDEN);

    // Malformed: a number as text, an unknown field, an array where the
    // object goes (serde would read it field by field as all defaults); out
    // of range: checked before anything is queued.
    for (body, field) in [
        (json!([null, null]), "JSON object"),
        (json!({"margin": "three"}), "margin"),
        (json!({"colour": "red"}), "colour"),
        (json!({"margin": 0.1}), "margin"),
        (json!({"target": "table2"}), "table2"),
    ] {
        let (status, p) = problem(post(&app, &engineer, &body).await).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{body}: {p}");
        assert!(p["detail"].as_str().unwrap().contains(field), "{body}: {p}");
    }
    assert_eq!(app.store.queue_depth().await.unwrap(), 0);

    let r = post(&app, &engineer, &quick()).await;
    let id = r.json::<Value>().await.unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let (status, _) = problem(app.get(&station, &format!("/designs/{id}")).await).await;
    assert_eq!(status, StatusCode::FORBIDDEN);
    // A station cannot see it as a job either.
    let (status, _) = problem(app.get(&station, &format!("/jobs/{id}")).await).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    let missing = format!("/designs/{}", uuid::Uuid::new_v4());
    let (status, _) = problem(app.get(&engineer, &missing).await).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    app.stop().await;
}

/// Table 1 at navigation-grade noise scores thousands of schemes: with a
/// 3 s limit the job's stage counts them while it runs, and then the job
/// fails, saying it ran out of time; the synchronous route says the same
/// as 503, pointing to the job route.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_design_out_of_time_fails_in_words_with_its_progress_seen() {
    let app = spawn_app_with(0, |c| {
        c.design_job_time_limit = Duration::from_secs(3);
        c.design_time_limit = Duration::from_secs(1);
    })
    .await;
    let engineer = app.create_token("engineer").await;
    let r = post(&app, &engineer, &json!({"target": "table1", "margin": 3})).await;
    let id = r.json::<Value>().await.unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let runner = app.runner.clone();
    let step = tokio::spawn(async move { runner.try_run_next_job(0).await });
    let mut stages = Vec::new();
    while !step.is_finished() {
        let now = read(&app, &engineer, &id).await;
        if let Some(s) = now["stage"].as_str() {
            stages.push(s.to_string());
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    let ran = step.await.unwrap().unwrap();
    assert!(
        matches!(
            ran,
            Outcome::Ran {
                end: JobEnd::Failed,
                ..
            }
        ),
        "{ran:?}"
    );
    assert!(
        stages.iter().any(|s| s.contains("schemes scored")),
        "{stages:?}"
    );
    let failed = read(&app, &engineer, &id).await;
    assert_eq!(failed["state"], "failed");
    let error = failed["error"].as_str().unwrap();
    assert!(error.contains("time limit of 3 s"), "{error}");
    assert!(failed.get("design").is_none());

    let r = app
        .http
        .post(app.url("/schemes/design"))
        .bearer_auth(&engineer)
        .json(&json!({"target": "table1"}))
        .send()
        .await
        .unwrap();
    let (status, p) = problem(r).await;
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE);
    let detail = p["detail"].as_str().unwrap();
    assert!(
        detail.contains("(1 s)") && detail.contains("/api/v1/designs"),
        "{p}"
    );
    app.stop().await;
}
