//! `POST /api/v1/schemes/design`: engineers get the designer's answer as
//! JSON; stations are refused, and so is a malformed request, with a
//! problem naming what is wrong.

use crate::common;

use common::{problem, spawn_app_with};
use reqwest::StatusCode;
use serde_json::{json, Value};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_engineer_gets_a_scheme_that_meets_the_goal() {
    // The design's answer, not the server's time limit (its own test
    // below), is what this test reads: a loaded machine must not turn it
    // into a refusal.
    let app = spawn_app_with(0, |c| {
        c.design_time_limit = std::time::Duration::from_secs(600)
    })
    .await;
    let engineer = app.create_token("engineer").await;
    let station = app.create_token("station").await;
    let post = |token: &str, body: Value| {
        app.http
            .post(app.url("/schemes/design"))
            .bearer_auth(token)
            .json(&body)
            .send()
    };

    let r = post(&station, json!({})).await.unwrap();
    assert_eq!(problem(r).await.0, StatusCode::FORBIDDEN);

    let r = post(&engineer, json!({"target": "table2"})).await.unwrap();
    let (status, p) = problem(r).await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p["detail"].as_str().unwrap().contains("table2"), "{p}");

    let r = post(&engineer, json!({"target": {"gyro_bias_q": 1.0}}))
        .await
        .unwrap();
    let (status, p) = problem(r).await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p["detail"].as_str().unwrap().contains("gyro_bias_q"), "{p}");

    let r = post(&engineer, json!({"margin": 3, "colour": "red"}))
        .await
        .unwrap();
    let (status, p) = problem(r).await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p["detail"].as_str().unwrap().contains("colour"), "{p}");

    // An effect to detect needs its size's unit.
    let r = post(&engineer, json!({"detect": ["accel_delay=0.5"]}))
        .await
        .unwrap();
    let (status, p) = problem(r).await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    let detail = p["detail"].as_str().unwrap();
    assert!(detail.contains("detect") && detail.contains("ms"), "{p}");

    // A loose goal at tactical-grade noise and a search of up to 7 turns,
    // the fewest that reach every parameter: a quick design, since this
    // test runs on both databases and what it reads is the answer's form
    // and the request's limits (the search itself is
    // `tests/suite/design_search.rs`'s).
    let body = json!({"target": "table1", "tighten": 0.1, "arw_deg_rt_h": 0.001,
                      "vrw_ug_rt_hz": 10, "min_dwell_s": 60, "max_turns": 7});
    let r = post(&engineer, body).await.unwrap();
    assert_eq!(r.status(), StatusCode::OK);
    let d: Value = r.json().await.unwrap();
    let params = d["parameters"].as_object().unwrap();
    assert_eq!(params.len(), 24);
    for (name, p) in params {
        assert!(p["ratio"].as_f64().unwrap() <= 1.0, "{name}: {p}");
    }
    assert!(d["duration_s"].as_f64().unwrap() > 0.0);
    // The scheme is a SPEC §4 scheme the simulator accepts.
    let scheme: sinscal_core::sim::Scheme = serde_json::from_value(d["scheme"].clone()).unwrap();
    scheme.validate().unwrap();
    // The request's limits hold: at most 7 turns, no dwell under 60 s.
    let (dwells, turns) = scheme.counts();
    assert!(
        turns <= 7 && dwells == turns + 1,
        "{dwells} dwells, {turns} turns"
    );
    for step in &scheme.steps {
        if let sinscal_core::sim::scheme::Step::Dwell { dwell_s } = step {
            assert!(*dwell_s >= 60.0, "a dwell of {dwell_s} s");
        }
    }
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn designs_run_one_at_a_time_within_the_time_limit() {
    let app = spawn_app_with(0, |c| {
        c.design_time_limit = std::time::Duration::from_secs(5)
    })
    .await;
    let engineer = app.create_token("engineer").await;
    // Table 1 at navigation-grade noise scores thousands of schemes; two
    // at once: one runs into the limit, the other finds the slot taken (the
    // limit leaves the second request seconds to arrive while the first runs).
    let send = || {
        app.http
            .post(app.url("/schemes/design"))
            .bearer_auth(&engineer)
            .json(&json!({"target": "table1"}))
            .send()
    };
    let (a, b) = tokio::join!(send(), send());
    let (mut answers, mut busy) = (Vec::new(), 0);
    for r in [a.unwrap(), b.unwrap()] {
        let retry = r.headers().get("retry-after").is_some();
        let (status, p) = problem(r).await;
        let detail = p["detail"].as_str().unwrap_or_default();
        if status == StatusCode::SERVICE_UNAVAILABLE && detail.contains("is running") {
            assert!(retry, "{p}");
            busy += 1;
        } else {
            answers.push((status, p));
        }
    }
    assert_eq!(busy, 1, "{answers:?}");
    // Out of time is the server's limit, not a bad request: 503, naming
    // the limit and the job route that has a longer one.
    let (status, p) = &answers[0];
    assert_eq!(*status, StatusCode::SERVICE_UNAVAILABLE);
    let detail = p["detail"].as_str().unwrap();
    assert!(
        detail.contains("(5 s)") && detail.contains("/api/v1/designs"),
        "{p}"
    );
    app.stop().await;
}
