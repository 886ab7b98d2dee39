//! `GET /runs/{id}/compensation`: the compensation file of a run's result,
//! as JSON or CSV, for engineers; 404 until the run has a result.

use crate::common;

use common::*;
use reqwest::StatusCode;
use serde_json::Value;
use sinscal_core::compensation::CompensationFile;
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::PARAMETERS;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_calibrated_run_serves_its_compensation_as_json_and_csv() {
    // No workers: the job waits until this test runs it.
    let app = spawn_app(0).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 11, DataFormat::F64le, "RLG-C1");
    let r = app.upload_run("RLG-C1", &run).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let run_id = r.json::<Value>().await.unwrap()["run_id"]
        .as_str()
        .unwrap()
        .to_string();
    let path = format!("/runs/{run_id}/compensation");

    // Before the result: nothing to deliver.
    let (status, body) = problem(app.get(&app.admin, &path).await).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert!(
        body["detail"].as_str().unwrap().contains("no result"),
        "{body}"
    );

    app.runner.try_run_next_job(0).await.unwrap();
    let result = app.get_result(&run_id).await;

    let r = app.get(&app.admin, &path).await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.headers()["content-type"], "application/json");
    let file = CompensationFile::from_json(&r.bytes().await.unwrap()).unwrap();
    assert_eq!(file.provenance.unit_serial.as_deref(), Some("RLG-C1"));
    assert_eq!(file.provenance.run_id.as_deref(), Some(run_id.as_str()));
    assert_eq!(file.provenance.model, result["model"].as_str().unwrap());
    // Judged without a product: accepted, and the file says so.
    assert_eq!(file.provenance.verdict.as_deref(), Some("accepted"));
    assert!(file.provenance.verdict_override.is_none());
    let (values, sigma) = (file.parameters(), file.sigma().unwrap());
    for (i, info) in PARAMETERS.iter().enumerate() {
        let p = &result["parameters"][info.name];
        let want = p["value"].as_f64().unwrap() * info.si_per_unit;
        let want_sigma = p["sigma"].as_f64().unwrap() * info.si_per_unit;
        assert!(
            (values.si[i] - want).abs() <= 1e-15 * want.abs(),
            "{}",
            info.name
        );
        assert!(
            (sigma[i] - want_sigma).abs() <= 1e-15 * want_sigma,
            "{}",
            info.name
        );
    }

    let r = app.get(&app.admin, &format!("{path}?format=csv")).await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.headers()["content-type"], "text/csv");
    let csv = r.text().await.unwrap();
    let rows: Vec<&str> = csv.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows[0], "name,symbol,value,unit,sigma");
    assert_eq!(rows.len(), 25);
    assert!(rows[1].starts_with("gyro_bias_x,b_g[0],") && rows[1].contains(",rad/s,"));
    assert!(csv.contains(&format!("# run_id: {run_id}")));

    let r = app.get(&app.admin, &format!("{path}?format=json")).await;
    assert_eq!(r.status(), StatusCode::OK);
    let (status, _) = problem(app.get(&app.admin, &format!("{path}?format=xml")).await).await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    app.stop().await;
}

#[tokio::test]
async fn compensation_needs_an_engineer_and_a_known_run() {
    let app = spawn_app(0).await;
    let unknown = format!("/runs/{}/compensation", uuid::Uuid::new_v4());
    let (status, _) = problem(app.get(&app.admin, &unknown).await).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    let (status, _) = problem(app.get(&app.admin, "/runs/not-a-uuid/compensation").await).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    let r = app.http.get(app.url(&unknown)).send().await.unwrap();
    assert_eq!(problem(r).await.0, StatusCode::UNAUTHORIZED);
    let station = app.create_token("station").await;
    let (status, _) = problem(app.get(&station, &unknown).await).await;
    assert_eq!(status, StatusCode::FORBIDDEN);
    let engineer = app.create_token("engineer").await;
    let (status, _) = problem(app.get(&engineer, &unknown).await).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    app.stop().await;
}

/// The compensation file of a run the acceptance did not accept (here: it
/// names a product with no product type, so it needs review) is held back
/// with 409 until an engineer gives a reason; the file then records the
/// verdict, the reason and who gave it. An accepted run's file records
/// its verdict and needs none.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_that_is_not_accepted_releases_its_compensation_only_on_a_reason() {
    let app = spawn_app(0).await;
    let dir = tempfile::tempdir().unwrap();
    let mut run = short_run(dir.path(), 12, DataFormat::F64le, "RLG-C2");
    let mut meta: Value = serde_json::from_slice(&run.metadata).unwrap();
    meta["product"] = Value::String("NO-SUCH-TYPE".into());
    run.metadata = serde_json::to_vec(&meta).unwrap();
    let r = app.upload_run("RLG-C2", &run).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let run_id = r.json::<Value>().await.unwrap()["run_id"]
        .as_str()
        .unwrap()
        .to_string();
    app.runner.try_run_next_job(0).await.unwrap();
    let path = format!("/runs/{run_id}/compensation");

    let (status, body) = problem(app.get(&app.admin, &path).await).await;
    assert_eq!(status, StatusCode::CONFLICT, "{body}");
    let detail = body["detail"].as_str().unwrap();
    assert!(
        detail.contains("needs review") && detail.contains("override="),
        "{detail}"
    );
    for bad in ["", "%20%20", "line%0Abreak", &"x".repeat(301)] {
        let r = app.get(&app.admin, &format!("{path}?override={bad}")).await;
        assert_eq!(
            problem(r).await.0,
            StatusCode::BAD_REQUEST,
            "override={bad:?}"
        );
    }

    let engineer = app.create_token("engineer").await;
    let reason = "line%20trial%20unit%2C%20not%20for%20delivery";
    let r = app
        .get(&engineer, &format!("{path}?override={reason}"))
        .await;
    assert_eq!(r.status(), StatusCode::OK);
    let file = CompensationFile::from_json(&r.bytes().await.unwrap()).unwrap();
    assert_eq!(file.provenance.verdict.as_deref(), Some("needs_review"));
    let o = file
        .provenance
        .verdict_override
        .expect("the override is recorded");
    assert_eq!(o.reason, "line trial unit, not for delivery");
    assert!(!o.by.is_empty());
    let csv = app
        .get(&engineer, &format!("{path}?format=csv&override={reason}"))
        .await
        .text()
        .await
        .unwrap();
    assert!(csv.contains("# verdict: needs_review"), "{csv}");
    assert!(csv.contains("# verdict_override_reason: line trial unit, not for delivery"));
    app.stop().await;
}
