//! A product type carries its line's error model: written through the API
//! (a model the server cannot read is refused with a 422 naming the field),
//! read back, and carried by the next calibration job of every run naming
//! the product; a unit's history and repeatability say which model each
//! run's result was made with.

use crate::common;

use std::time::Duration;

use common::*;
use reqwest::{Method, StatusCode};
use serde_json::{json, Value};
use sinscal_core::io::data::DataFormat;

const CALIBRATION: Duration = Duration::from_secs(600);

/// An admin's request to the API with a JSON body.
async fn admin_sends(app: &TestApp, method: Method, path: &str, body: Value) -> reqwest::Response {
    app.http
        .request(method, app.url(path))
        .bearer_auth(&app.admin)
        .json(&body)
        .send()
        .await
        .unwrap()
}

/// The model of the unit's history entries and of the runs its
/// repeatability covers, each in time order.
async fn models_shown(app: &TestApp, serial: &str) -> (Vec<Value>, Vec<Value>) {
    let history = app.history(serial, "").await;
    let repeatability = app.repeatability(serial, "").await;
    let models = |rows: &Value| -> Vec<Value> {
        rows.as_array()
            .unwrap()
            .iter()
            .map(|r| r["model"].clone())
            .collect()
    };
    (
        models(&history["items"]),
        models(&repeatability["run_models"]),
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_product_types_model_is_carried_by_the_next_calibration_of_its_runs() {
    let app = spawn_app_with(1, |c| c.diagnose_inadequate = false).await;

    // Not a model: refused naming the field, nothing created.
    for (model, says) in [
        (
            "base+accel_dleay",
            "\"accel_dleay\" is not a SPEC §3 effect",
        ),
        ("accel_delay", "must start with the base model"),
        ("base + accel_delay", "white space"),
    ] {
        let body = json!({"name": "SINS-D", "limits": {}, "model": model});
        let r = admin_sends(&app, Method::POST, "/product-types", body).await;
        let (status, p) = problem(r).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{model}: {p}");
        assert_eq!(p["field"], "model", "{p}");
        assert!(p["detail"].as_str().unwrap().contains(says), "{p}");
    }
    let r = app.get(&app.admin, "/product-types/SINS-D").await;
    assert_eq!(r.status(), StatusCode::NOT_FOUND);

    // The line's model, read back in its one spelling.
    let body = json!({"name": "SINS-D", "limits": {}, "model": "base+accel_delay"});
    let r = admin_sends(&app, Method::POST, "/product-types", body).await;
    assert_eq!(r.status(), StatusCode::CREATED);
    let created: Value = r.json().await.unwrap();
    assert_eq!(created["model"], "base-24+accel_delay", "{created}");
    let read = app.get_json("/product-types/SINS-D").await;
    assert_eq!(read["model"], "base-24+accel_delay");

    // A unit of the line whose accelerometers lag 2 ms: its calibration
    // carries the line's model and finds the delay.
    let dir = tempfile::tempdir().unwrap();
    let cfg = model_check_run(31, delayed_accelerometers());
    let mut run = simulate_run(dir.path(), &cfg, DataFormat::F64le, false, "DLY-1", None);
    let mut meta: Value = serde_json::from_slice(&run.metadata).unwrap();
    meta["product"] = json!("SINS-D");
    run.metadata = serde_json::to_vec(&meta).unwrap();
    let (run_id, _) = app.upload_and_calibrate("DLY-1", &run, CALIBRATION).await;
    let result = app.get_result(&run_id).await;
    assert_eq!(result["model"], "base-24+accel_delay");
    let delay = &result["effects"]["accel_delay"];
    assert!(
        (delay["value"].as_f64().unwrap() - 2.0).abs() <= 3.0 * delay["sigma"].as_f64().unwrap(),
        "accel_delay {delay}"
    );
    let line_model = json!("base-24+accel_delay");
    assert_eq!(
        models_shown(&app, "DLY-1").await,
        (vec![line_model.clone()], vec![line_model.clone()])
    );
    let repeatability = app.repeatability("DLY-1", "").await;
    assert_eq!(repeatability["run_models"][0]["run_id"], run_id.as_str());

    // The line back on the server's model (a replacement without one):
    // the run's next calibration carries the server's base model, and the
    // views follow its current result.
    let r = admin_sends(
        &app,
        Method::PUT,
        "/product-types/SINS-D",
        json!({"limits": {}}),
    )
    .await;
    assert_eq!(r.status(), StatusCode::OK);
    let replaced: Value = r.json().await.unwrap();
    assert_eq!(replaced["model"], Value::Null, "{replaced}");
    assert_eq!(replaced["revision"], 2);
    let r = app
        .http
        .post(app.url(&format!("/runs/{run_id}/calibrate")))
        .bearer_auth(&app.admin)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let job: Value = r.json().await.unwrap();
    let done = app.wait_job(job["id"].as_str().unwrap(), CALIBRATION).await;
    assert_eq!(done["state"], "succeeded", "{done}");
    assert_eq!(app.get_result(&run_id).await["model"], "base-24");
    let base = json!("base-24");
    assert_eq!(
        models_shown(&app, "DLY-1").await,
        (vec![base.clone()], vec![base])
    );
    let versions = app.get_json(&format!("/runs/{run_id}/results")).await;
    assert_eq!(versions[0]["model"], line_model, "{versions}");
    assert_eq!(versions[1]["model"], "base-24", "{versions}");
    app.stop().await;
}
