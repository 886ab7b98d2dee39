//! The discrepancy workflow as a server job: queue it for a calibrated
//! run, follow the job, read the report and its gap plot.

use crate::common;

use std::time::Duration;

use common::*;
use reqwest::StatusCode;
use serde_json::Value;
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::ErrorParameters;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn diagnose_job_names_accel_delay() {
    // Diagnosis on request only: the run below fails its model check, which
    // would otherwise queue a diagnose job by itself (tests/suite/api_model_check.rs).
    let app = spawn_app_with(1, |c| c.diagnose_inadequate = false).await;
    let dir = tempfile::tempdir().unwrap();
    let cfg = model_check_run(11, delayed_accelerometers());
    let run = simulate_run(dir.path(), &cfg, DataFormat::F64le, false, "RLG-D1", None);
    let (run_id, calib) = app
        .upload_and_calibrate("RLG-D1", &run, Duration::from_secs(300))
        .await;
    assert_eq!(calib["kind"], "calibrate");

    // Nothing asked for yet: 404.
    let r = app
        .get(&app.admin, &format!("/runs/{run_id}/diagnosis"))
        .await;
    assert_eq!(problem(r).await.0, StatusCode::NOT_FOUND);

    // Stations upload; they do not diagnose.
    let station = app.create_token("station").await;
    let r = app.post_diagnose(&station, &run_id).await;
    assert_eq!(problem(r).await.0, StatusCode::FORBIDDEN);

    // An unknown run: 404.
    let r = app
        .http
        .post(app.url(&format!("/runs/{}/diagnose", uuid::Uuid::new_v4())))
        .bearer_auth(&app.admin)
        .send()
        .await
        .unwrap();
    assert_eq!(problem(r).await.0, StatusCode::NOT_FOUND);

    let engineer = app.create_token("engineer").await;
    let r = app.post_diagnose(&engineer, &run_id).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let location = r.headers()["location"].to_str().unwrap().to_string();
    let job: Value = r.json().await.unwrap();
    let job_id = job["id"].as_str().unwrap().to_string();
    assert_eq!(location, format!("/api/v1/jobs/{job_id}"));
    assert_eq!(job["kind"], "diagnose");
    assert_eq!(job["run_id"], run_id.as_str());

    // Asked again while it is queued or running: the same job, not another.
    let r = app.post_diagnose(&engineer, &run_id).await;
    if r.status() == StatusCode::OK {
        let again: Value = r.json().await.unwrap();
        assert_eq!(again["id"], job_id.as_str());
        assert_eq!(again["kind"], "diagnose");
    } else {
        // A new job may be queued only once the first has finished.
        assert_eq!(r.status(), StatusCode::ACCEPTED);
        let first = app.get_job(&job_id).await;
        assert!(
            matches!(
                first["state"].as_str(),
                Some("succeeded" | "failed" | "dead_letter" | "cancelled")
            ),
            "a second diagnose job was queued beside {first}"
        );
    }

    let done = app.wait_job(&job_id, Duration::from_secs(600)).await;
    assert_eq!(done["state"], "succeeded", "{done}");
    assert_eq!(done["kind"], "diagnose");

    let r = app
        .get(&engineer, &format!("/runs/{run_id}/diagnosis"))
        .await;
    assert_eq!(r.status(), StatusCode::OK);
    let report: Value = r.json().await.unwrap();
    assert_eq!(report["named"][0], "accel_delay", "{}", report["verdict"]);
    let (before, after) = (
        report["gap_rms_before"].as_f64().unwrap(),
        report["gap_rms_after"].as_f64().unwrap(),
    );
    assert!(after < before, "gap RMS {before} -> {after}");

    let r = app
        .get(&engineer, &format!("/runs/{run_id}/diagnosis/gap.svg"))
        .await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.headers()["content-type"], "image/svg+xml");
    let svg = r.text().await.unwrap();
    assert!(svg.starts_with("<svg"), "{}", &svg[..svg.len().min(80)]);

    // The diagnosis wrote no calibration rows: the run's result is still
    // its calibration job's.
    let result = app.get_result(&run_id).await;
    assert!(result["parameters"].is_object());
    let run_view = app.get_run(&run_id).await;
    assert_eq!(run_view["job_id"], calib["id"]);

    adopt_the_delay(&app, &run_id, &station, &engineer).await;
    app.stop().await;
}

/// The diagnosis adopted: the run calibrated again with the delay as a
/// state, its current result within 3σ of the truth on every parameter,
/// the base model's result still readable as result 1.
async fn adopt_the_delay(app: &TestApp, run_id: &str, station: &str, engineer: &str) {
    let adopt = |token: &str| {
        app.http
            .post(app.url(&format!("/runs/{run_id}/diagnosis/adopt")))
            .bearer_auth(token.to_string())
            .send()
    };
    assert_eq!(
        problem(adopt(station).await.unwrap()).await.0,
        StatusCode::FORBIDDEN
    );
    let r = adopt(engineer).await.unwrap();
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let job: Value = r.json().await.unwrap();
    assert_eq!(job["kind"], "calibrate");
    let done = app
        .wait_job(job["id"].as_str().unwrap(), Duration::from_secs(600))
        .await;
    assert_eq!(done["state"], "succeeded", "{done}");

    let result = app.get_result(run_id).await;
    assert_eq!(result["model"], "base-24+accel_delay");
    let truth = ErrorParameters::paper().to_canonical();
    for (name, value) in &truth {
        let est = &result["parameters"][name];
        let (v, s) = (
            est["value"].as_f64().unwrap(),
            est["sigma"].as_f64().unwrap(),
        );
        assert!(
            (v - value).abs() <= 3.0 * s,
            "{name}: {v} ± {s} against the truth {value}"
        );
    }
    let delay = &result["effects"]["accel_delay"];
    assert!(
        (delay["value"].as_f64().unwrap() - 2.0).abs() <= 3.0 * delay["sigma"].as_f64().unwrap(),
        "accel_delay {delay}"
    );

    let versions: Value = app.get_json(&format!("/runs/{run_id}/results")).await;
    assert_eq!(versions.as_array().unwrap().len(), 2, "{versions}");
    assert_eq!(versions[0]["model"], "base-24");
    assert_eq!(versions[0]["current"], false);
    assert_eq!(versions[1]["model"], "base-24+accel_delay");
    assert_eq!(versions[1]["current"], true);
    let old: Value = app.get_json(&format!("/runs/{run_id}/results/1")).await;
    assert_eq!(old["model"], "base-24");
    let r = app
        .get(&app.admin, &format!("/runs/{run_id}/results/3"))
        .await;
    assert_eq!(problem(r).await.0, StatusCode::NOT_FOUND);

    // The same diagnosis again names nothing the current model lacks.
    let r = adopt(engineer).await.unwrap();
    assert_eq!(problem(r).await.0, StatusCode::CONFLICT);
}

#[tokio::test]
async fn diagnosis_of_a_run_never_diagnosed_is_409_while_queued() {
    // No workers: the job stays queued.
    let app = spawn_app(0).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 3, DataFormat::F64le, "RLG-D2");
    let r = app.upload_run("RLG-D2", &run).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let run_id = r.json::<Value>().await.unwrap()["run_id"]
        .as_str()
        .unwrap()
        .to_string();
    let r = app.post_diagnose(&app.admin, &run_id).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let r = app
        .get(&app.admin, &format!("/runs/{run_id}/diagnosis"))
        .await;
    assert_eq!(problem(r).await.0, StatusCode::CONFLICT);
    let r = app
        .get(&app.admin, &format!("/runs/{run_id}/diagnosis/gap.svg"))
        .await;
    assert_eq!(problem(r).await.0, StatusCode::CONFLICT);
    let r = app
        .get(
            &app.admin,
            &format!("/runs/{}/diagnosis", uuid::Uuid::new_v4()),
        )
        .await;
    assert_eq!(problem(r).await.0, StatusCode::NOT_FOUND);
    app.stop().await;
}

#[tokio::test]
async fn diagnose_on_a_full_queue_is_503() {
    // No workers and a queue of one: the upload's job fills it.
    let app = spawn_app_with(0, |c| c.max_queue = 1).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 4, DataFormat::F64le, "RLG-D3");
    let r = app.upload_run("RLG-D3", &run).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let run_id = r.json::<Value>().await.unwrap()["run_id"]
        .as_str()
        .unwrap()
        .to_string();
    let r = app.post_diagnose(&app.admin, &run_id).await;
    assert!(r.headers().contains_key("retry-after"));
    assert_eq!(problem(r).await.0, StatusCode::SERVICE_UNAVAILABLE);
    app.stop().await;
}
