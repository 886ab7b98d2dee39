//! A noise model held for a unit (`/units/{serial}/noise-model`): set
//! through the API, carried by each later calibration of the unit's runs
//! as its use says, shown on the unit's page, let go again; refusals name
//! the term or field at fault.

use crate::common;

use std::time::Duration;

use common::*;
use reqwest::StatusCode;
use serde_json::{json, Value};
use sinscal_core::calib::{EstimateOptions, NoiseDensity};
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::Effects;

const SERIAL: &str = "RLG-HN1";

async fn put_held(app: &TestApp, token: &str, serial: &str, body: Value) -> reqwest::Response {
    app.http
        .put(app.url(&format!("/units/{serial}/noise-model")))
        .bearer_auth(token)
        .json(&body)
        .send()
        .await
        .unwrap()
}

/// The walk the run carries and its white terms: what a long static
/// recording of the unit would have found.
fn characterisation() -> Value {
    json!({"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5,
           "gyro_rrw_deg_h_rt_h": 0.0003, "accel_rw_ug_rt_h": 3})
}

/// A unit whose bias walks (0.0003 deg/h/√h, 3 µg/√h) under dwells that
/// show only white noise (the screen's case, `api_model_check`). With its
/// characterisation held as given (API), the server's result is the
/// core's under that model, to the digits JSON keeps: source `given`, a
/// quiet check; the unit page shows it. Held as the reference (the page's
/// form), the run's own model is used and the result says the held one
/// was not tested (a white run is measured, not fitted). Let go (the
/// page's button), the unit's runs measure their own again.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_units_held_noise_model_is_carried_by_its_calibrations_as_its_use_says() {
    let app = spawn_app(1).await;
    let engineer = app.create_token("engineer").await;
    let r = put_held(
        &app,
        &engineer,
        SERIAL,
        json!({"noise": characterisation(), "used_as": "given"}),
    )
    .await;
    assert_eq!(r.status(), StatusCode::OK);
    let held: Value = r.json().await.unwrap();
    assert_eq!(held["used_as"], "given");
    assert_eq!(held["noise"]["accel_rw_ug_rt_h"], 3.0);
    let read = app.get_json(&format!("/units/{SERIAL}/noise-model")).await;
    assert_eq!(read, held);

    let mut cfg = model_check_run(2, Effects::none());
    cfg.noise.gyro_rrw_deg_h_rt_h = 0.0003;
    cfg.noise.accel_rw_ug_rt_h = 3.0;
    let dir = tempfile::tempdir().unwrap();
    let run = simulate_run(dir.path(), &cfg, DataFormat::F64le, false, SERIAL, None);
    let (run_id, _) = app
        .upload_and_calibrate(SERIAL, &run, Duration::from_secs(300))
        .await;
    let served = app.get_result(&run_id).await;
    assert_eq!(served["noise_model"]["source"], "given");
    assert_eq!(
        served["model_check"]["adequate"], true,
        "{}",
        served["model_check"]
    );
    let given: NoiseDensity = serde_json::from_value(characterisation()).unwrap();
    let direct = calibrate_directly_with(
        &run,
        &EstimateOptions {
            noise: Some(given),
            ..EstimateOptions::default()
        },
    );
    // The same numbers, to the last bits JSON's decimal text keeps.
    let same = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-300);
    for (name, p) in &direct.parameters {
        let s = &served["parameters"][name];
        let (value, sigma) = (s["value"].as_f64().unwrap(), s["sigma"].as_f64().unwrap());
        assert!(same(value, p.value), "{name}: {value} against {}", p.value);
        assert!(
            same(sigma, p.sigma),
            "{name}: σ {sigma} against {}",
            p.sigma
        );
    }
    let page = app.sign_in(&app.admin).await;
    let html = page
        .get(&format!("/units/{SERIAL}"))
        .await
        .text()
        .await
        .unwrap();
    assert!(
        html.contains("accelerometer RW 3.00 µg/√h") && html.contains("given to each calibration"),
        "the unit page shows the held model: {}",
        html.split("held-noise")
            .nth(1)
            .unwrap_or(&html)
            .chars()
            .take(400)
            .collect::<String>()
    );

    // The page's form holds it as the reference: refused first for text
    // that is not JSON, a term it does not know, and a missing CSRF token.
    let hold = format!("/units/{SERIAL}/noise-model");
    let terms = characterisation().to_string();
    let form = |noise: &'static str| [("noise", noise), ("used_as", "reference")];
    assert_eq!(page.post(&hold, &form("{ARW: 3}")).await.status(), 400);
    let r = page
        .post(
            &hold,
            &form(r#"{"gyro_arw_deg_rt_h": 3, "accel_vrw_ug_rt_hz": 5, "arw": 1}"#),
        )
        .await;
    assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY);
    assert!(r.text().await.unwrap().contains("noise.arw"));
    let forged = [("noise", terms.as_str()), ("used_as", "reference")];
    assert_eq!(page.post_exactly(&hold, &forged).await.status(), 403);
    let r = page.post(&hold, &forged).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let read = app.get_json(&hold).await;
    assert_eq!(
        (&read["used_as"], &read["noise"]),
        (&json!("reference"), &held["noise"])
    );
    let result = calibrate_again(&app, &run_id).await;
    assert_eq!(result["noise_model"]["source"], "measured");
    let warnings = result["warnings"].to_string();
    assert!(
        warnings.contains("held for the unit was not tested"),
        "{warnings}"
    );

    // Let go by the page's button; through the API there is then nothing
    // to delete.
    let r = page.post(&format!("{hold}/release"), &[]).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let r = app
        .http
        .delete(app.url(&hold))
        .bearer_auth(engineer.clone())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::NOT_FOUND);
    let r = app.get(&engineer, &hold).await;
    assert_eq!(r.status(), StatusCode::NOT_FOUND);
    let result = calibrate_again(&app, &run_id).await;
    assert_eq!(result["noise_model"]["source"], "measured");
    assert!(!result["warnings"].to_string().contains("held for the unit"));
    app.stop().await;
}

/// Bodies the model cannot be, and callers who may not set it: each
/// refused saying what, and nothing held.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_held_noise_model_that_is_not_one_is_refused_naming_its_fault() {
    let app = spawn_app(0).await;
    let white = json!({"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5});
    let mut misspelt = white.clone();
    misspelt["gyro_bias_instabilty_deg_h"] = json!(0.001);
    let mut negative = white.clone();
    negative["accel_rw_ug_rt_h"] = json!(-1);
    for (body, says) in [
        (
            json!({"noise": misspelt, "used_as": "given"}),
            "noise.gyro_bias_instabilty_deg_h",
        ),
        (
            json!({"noise": negative, "used_as": "given"}),
            "noise.accel_rw_ug_rt_h",
        ),
        (
            json!({"noise": {"gyro_arw_deg_rt_h": 0.0003}, "used_as": "given"}),
            "noise.accel_vrw_ug_rt_hz",
        ),
        (
            json!({"noise": white.clone(), "used_as": "both"}),
            "used_as",
        ),
        (json!({"noise": white.clone()}), "used_as"),
        (
            json!({"noise": white.clone(), "used_as": "given", "note": 1}),
            "note",
        ),
    ] {
        let (status, problem) =
            problem(put_held(&app, &app.admin, SERIAL, body.clone()).await).await;
        assert_eq!(
            status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{body}: {problem}"
        );
        let text = problem.to_string();
        assert!(text.contains(says), "{body}: {problem}");
    }
    let station = app.create_token("station").await;
    let ok = json!({"noise": white, "used_as": "given"});
    let r = put_held(&app, &station, SERIAL, ok.clone()).await;
    assert_eq!(r.status(), StatusCode::FORBIDDEN);
    let r = put_held(&app, &app.admin, "bad serial/..", ok).await;
    assert!(r.status().is_client_error(), "{}", r.status());
    let r = app
        .get(&app.admin, &format!("/units/{SERIAL}/noise-model"))
        .await;
    assert_eq!(r.status(), StatusCode::NOT_FOUND, "nothing was held");
    app.stop().await;
}

/// The run calibrated again (as an engineer asks), its new result.
async fn calibrate_again(app: &TestApp, run_id: &str) -> Value {
    let r = app
        .http
        .post(app.url(&format!("/runs/{run_id}/calibrate")))
        .bearer_auth(app.admin.clone())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let job: Value = r.json().await.unwrap();
    let job = app
        .wait_job(job["id"].as_str().unwrap(), Duration::from_secs(300))
        .await;
    assert_eq!(job["state"], "succeeded", "{job}");
    app.get_result(run_id).await
}
