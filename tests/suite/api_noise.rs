//! `GET /runs/{id}/noise`: the noise analysis of a stored run, served to
//! engineers. Apart from `noise_analysis` (the analysis itself, pure
//! computation), so that the PostgreSQL pass of `scripts/test`, which
//! reruns every module that starts a server, reruns only this.

use crate::common;
use crate::noise_analysis::within;

use std::time::Duration;

use common::*;
use reqwest::StatusCode;
use serde_json::Value;
use sinscal_core::io::data::DataFormat;

/// The endpoint on an uploaded simulated run: the engineer reads the
/// analysis, ARW and VRW within 10 %; an unknown run is 404, no token 401,
/// a station token 403.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_api_serves_the_noise_of_a_stored_run() {
    let app = spawn_app(1).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 5, DataFormat::F64le, "RLG-N1");
    let (run_id, _) = app
        .upload_and_calibrate("RLG-N1", &run, Duration::from_secs(120))
        .await;

    let engineer = app.create_token("engineer").await;
    let r = app.get(&engineer, &format!("/runs/{run_id}/noise")).await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.headers()["content-type"], "application/json");
    let report: Value = r.json().await.unwrap();
    assert_eq!(
        report["computed_over"]["stretches"]
            .as_array()
            .unwrap()
            .len(),
        10
    );
    for axis in ["x", "y", "z"] {
        within(
            &format!("served gyro {axis} ARW"),
            report["gyro"][axis]["arw_deg_rt_h"]["value"]
                .as_f64()
                .unwrap(),
            0.0003,
            0.10,
        );
        within(
            &format!("served accel {axis} VRW"),
            report["accel"][axis]["vrw_ug_rt_hz"]["value"]
                .as_f64()
                .unwrap(),
            5.0,
            0.10,
        );
    }

    let unknown = format!("/runs/{}/noise", uuid::Uuid::new_v4());
    let (status, body) = problem(app.get(&engineer, &unknown).await).await;
    assert_eq!(status, StatusCode::NOT_FOUND, "{body}");
    let r = app
        .http
        .get(app.url(&format!("/runs/{run_id}/noise")))
        .send()
        .await
        .unwrap();
    assert_eq!(problem(r).await.0, StatusCode::UNAUTHORIZED);
    let station = app.create_token("station").await;
    let r = app.get(&station, &format!("/runs/{run_id}/noise")).await;
    assert_eq!(problem(r).await.0, StatusCode::FORBIDDEN);
    app.stop().await;
}
