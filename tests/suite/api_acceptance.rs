//! Acceptance through the server: admins manage product types, a run's
//! metadata `product` ties its unit to one, and every result gets a
//! verdict — accepted, rejected naming the limits, or needs review — that
//! the run, result, history and unit views carry and filter on, and that
//! follows the product type's current limits.

use crate::common;

use std::time::Duration;

use common::*;
use reqwest::StatusCode;
use serde_json::{json, Value};
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::Effects;
use sinscal_core::sim::SimConfig;

/// Uploads a simulated run naming `product`, waits for its calibration and
/// returns the run's view.
async fn calibrated_run(app: &TestApp, serial: &str, product: &str, cfg: &SimConfig) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let mut run = simulate_run(dir.path(), cfg, DataFormat::F64le, false, serial, None);
    let mut meta: Value = serde_json::from_slice(&run.metadata).unwrap();
    meta["product"] = json!(product);
    run.metadata = serde_json::to_vec(&meta).unwrap();
    let (run_id, _) = app
        .upload_and_calibrate(serial, &run, Duration::from_secs(300))
        .await;
    app.get_run(&run_id).await
}

async fn send(
    app: &TestApp,
    method: reqwest::Method,
    token: &str,
    path: &str,
    body: Option<Value>,
) -> reqwest::Response {
    let mut req = app.http.request(method, app.url(path)).bearer_auth(token);
    if let Some(b) = body {
        req = req.json(&b);
    }
    req.send().await.unwrap()
}

async fn create_type(app: &TestApp, body: Value) -> Value {
    let r = send(
        app,
        reqwest::Method::POST,
        &app.admin,
        "/product-types",
        Some(body),
    )
    .await;
    assert_eq!(r.status(), StatusCode::CREATED);
    assert!(r.headers().get("location").is_some());
    r.json().await.unwrap()
}

/// Serials of the units a units query returns.
async fn unit_serials(app: &TestApp, query: &str) -> Vec<String> {
    let page = app.get_json(&format!("/units{query}")).await;
    page["items"]
        .as_array()
        .unwrap()
        .iter()
        .map(|u| u["serial"].as_str().unwrap().to_string())
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn verdicts_follow_limits_checks_and_filters() {
    let app = spawn_app_with(1, |c| c.diagnose_inadequate = false).await;
    // Loose bounds: a navigation-grade unit is well inside them.
    let loose = json!({
        "name": "SINS-A",
        "description": "loose",
        "limits": {
            "gyro_bias_x": {"max_abs_value": 10.0, "max_sigma": 1.0},
            "accel_bias_z": {"max_abs_value": 10000.0, "max_repeatability": 1000.0},
        }
    });
    let created = create_type(&app, loose).await;
    assert_eq!(created["revision"], 1);
    assert_eq!(created["limits"]["gyro_bias_x"]["max_sigma"], 1.0);
    // A σ bound no run can meet.
    create_type(
        &app,
        json!({"name": "SINS-T", "limits": {"gyro_scale_y": {"max_sigma": 1e-9}}}),
    )
    .await;

    // Within the limits. One run cannot judge the repeatability bound, a
    // second can.
    let first = calibrated_run(
        &app,
        "ACC-1",
        "SINS-A",
        &model_check_run(21, Effects::none()),
    )
    .await;
    assert_eq!(first["verdict"]["status"], "needs_review", "{first}");
    assert_eq!(
        first["verdict"]["reasons"],
        json!([{"reason": "too_few_runs", "runs": 1, "needed": 2}])
    );
    let good = calibrated_run(
        &app,
        "ACC-1",
        "SINS-A",
        &model_check_run(22, Effects::none()),
    )
    .await;
    let verdict = &good["verdict"];
    assert_eq!(verdict["status"], "accepted", "{good}");
    assert_eq!(verdict["failed"], json!([]));
    assert_eq!(verdict["reasons"], json!([]));
    assert_eq!(verdict["product"], "SINS-A");
    assert_eq!(verdict["product_revision"], 1);
    let good_id = good["id"].as_str().unwrap();
    assert_eq!(
        app.get_result(good_id).await["verdict"]["status"],
        "accepted"
    );

    // A tight limit: rejected, naming the parameter and the bound.
    let tight = calibrated_run(
        &app,
        "REJ-1",
        "SINS-T",
        &model_check_run(23, Effects::none()),
    )
    .await;
    let verdict = &tight["verdict"];
    assert_eq!(verdict["status"], "rejected", "{tight}");
    let failed = &verdict["failed"][0];
    assert_eq!(failed["parameter"], "gyro_scale_y");
    assert_eq!(failed["limit"], "max_sigma");
    assert_eq!(failed["max"], 1e-9);
    assert_eq!(failed["unit"], "ppm");
    assert!(failed["actual"].as_f64().unwrap() > 1e-9);

    // The model check fails: needs review, whatever the limits.
    let odd = calibrated_run(
        &app,
        "REV-1",
        "SINS-A",
        &model_check_run(24, delayed_accelerometers()),
    )
    .await;
    assert_eq!(odd["review"], "needs_review");
    assert_eq!(odd["verdict"]["status"], "needs_review", "{odd}");
    let reasons: Vec<&str> = odd["verdict"]["reasons"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["reason"].as_str().unwrap())
        .collect();
    assert!(reasons.contains(&"model_inadequate"), "{reasons:?}");
    // Its page says so in words, and a value within its limits is not
    // shown as passing.
    let page = app.sign_in(&app.admin).await;
    let html = page
        .get(&format!("/runs/{}", odd["id"].as_str().unwrap()))
        .await
        .text()
        .await
        .unwrap();
    assert!(html.contains("the model check found a misfit"), "{html}");
    assert!(html.contains(">unverified<") && !html.contains(">pass<"));

    // Filters.
    assert_eq!(unit_serials(&app, "?verdict=accepted").await, ["ACC-1"]);
    assert_eq!(unit_serials(&app, "?verdict=rejected").await, ["REJ-1"]);
    assert_eq!(unit_serials(&app, "?verdict=needs_review").await, ["REV-1"]);
    assert_eq!(unit_serials(&app, "?product=SINS-T").await, ["REJ-1"]);
    assert_eq!(
        unit_serials(&app, "?product=SINS-A&verdict=needs_review").await,
        ["REV-1"]
    );
    assert!(unit_serials(&app, "?product=NONE").await.is_empty());
    let unit = app.unit("ACC-1").await;
    assert_eq!(unit["product"], "SINS-A");
    assert_eq!(unit["verdict"]["status"], "accepted");
    assert_eq!(unit["verdict"]["run_id"], good_id);
    let history = app.history("ACC-1", "?verdict=accepted").await;
    assert_eq!(history["total"], 1, "{history}");
    assert_eq!(history["items"][0]["run_id"], good_id);
    assert_eq!(history["items"][0]["verdict"]["status"], "accepted");
    let history = app.history("ACC-1", "?verdict=needs_review").await;
    assert_eq!(history["total"], 1);
    assert_eq!(history["items"][0]["run_id"], first["id"]);
    let r = app.get(&app.admin, "/units?verdict=great").await;
    assert_eq!(problem(r).await.0, StatusCode::BAD_REQUEST);

    // The API's repeatability judges against the product's limit, as the
    // verdict and the unit's page do.
    let spread = |serial: &'static str| {
        let app = &app;
        async move {
            let r = app
                .get_json(&format!("/units/{serial}/repeatability"))
                .await;
            r["parameters"]
                .as_array()
                .unwrap()
                .iter()
                .find(|p| p["name"] == "accel_bias_z")
                .unwrap()
                .clone()
        }
    };
    let z = spread("ACC-1").await;
    assert_eq!(z["tolerance"], 1000.0, "{z}");
    assert_eq!(z["tolerance_source"], "product");
    assert_eq!(z["flagged"], false);
    let r = send(
        &app,
        reqwest::Method::PUT,
        &app.admin,
        "/product-types/SINS-A",
        Some(json!({"limits": {"accel_bias_z": {"max_repeatability": 1e-9}}})),
    )
    .await;
    assert_eq!(r.status(), StatusCode::OK);
    let z = spread("ACC-1").await;
    assert_eq!(z["tolerance"], 1e-9, "{z}");
    assert_eq!(z["flagged"], true);

    // Limits change: the verdict follows them, with the new revision.
    let r = send(
        &app,
        reqwest::Method::PUT,
        &app.admin,
        "/product-types/SINS-A",
        Some(json!({"limits": {"gyro_bias_x": {"max_sigma": 1e-9}}})),
    )
    .await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.json::<Value>().await.unwrap()["revision"], 3);
    let now = app.get_run(good_id).await;
    assert_eq!(now["verdict"]["status"], "rejected", "{now}");
    assert_eq!(now["verdict"]["product_revision"], 3);
    assert_eq!(now["verdict"]["failed"][0]["parameter"], "gyro_bias_x");
    let rejected = unit_serials(&app, "?verdict=rejected").await;
    assert_eq!(rejected, ["ACC-1", "REJ-1"]);

    // Deleted: runs naming it need review (unknown product).
    let r = send(
        &app,
        reqwest::Method::DELETE,
        &app.admin,
        "/product-types/SINS-T",
        None,
    )
    .await;
    assert_eq!(r.status(), StatusCode::NO_CONTENT);
    let now = app.get_run(tight["id"].as_str().unwrap()).await;
    assert_eq!(
        now["verdict"]["reasons"],
        json!([{"reason": "unknown_product", "product": "SINS-T"}])
    );
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn product_types_are_admin_managed_and_validated() {
    let app = spawn_app(1).await;
    let station = app.create_token("station").await;
    let engineer = app.create_token("engineer").await;
    let body = json!({"name": "SINS-B", "limits": {"gyro_bias_x": {"max_abs_value": 0.5}}});
    for token in [&station, &engineer] {
        let r = send(
            &app,
            reqwest::Method::POST,
            token,
            "/product-types",
            Some(body.clone()),
        )
        .await;
        assert_eq!(problem(r).await.0, StatusCode::FORBIDDEN);
    }
    create_type(&app, body.clone()).await;
    let r = send(
        &app,
        reqwest::Method::POST,
        &app.admin,
        "/product-types",
        Some(body),
    )
    .await;
    assert_eq!(problem(r).await.0, StatusCode::CONFLICT);

    // Engineers read; stations do not; nobody but an admin writes.
    let r = app.get(&engineer, "/product-types").await;
    assert_eq!(r.status(), StatusCode::OK);
    let list: Value = r.json().await.unwrap();
    assert_eq!(list[0]["name"], "SINS-B");
    let r = app.get(&engineer, "/product-types/SINS-B").await;
    assert_eq!(r.status(), StatusCode::OK);
    let r = app.get(&station, "/product-types").await;
    assert_eq!(problem(r).await.0, StatusCode::FORBIDDEN);
    let put = json!({"limits": {}});
    let r = send(
        &app,
        reqwest::Method::PUT,
        &engineer,
        "/product-types/SINS-B",
        Some(put.clone()),
    )
    .await;
    assert_eq!(problem(r).await.0, StatusCode::FORBIDDEN);
    let r = send(
        &app,
        reqwest::Method::DELETE,
        &engineer,
        "/product-types/SINS-B",
        None,
    )
    .await;
    assert_eq!(problem(r).await.0, StatusCode::FORBIDDEN);
    let r = send(
        &app,
        reqwest::Method::PUT,
        &app.admin,
        "/product-types/NOPE",
        Some(put),
    )
    .await;
    assert_eq!(problem(r).await.0, StatusCode::NOT_FOUND);
    let r = app.get(&app.admin, "/product-types/NOPE").await;
    assert_eq!(problem(r).await.0, StatusCode::NOT_FOUND);

    // Bad limits and names: 422 naming the field.
    for (limits, field) in [
        (
            json!({"gyro_bias_x": {"max_sigma": -1.0}}),
            "limits.gyro_bias_x.max_sigma",
        ),
        (
            json!({"gyro_bias_q": {"max_sigma": 1.0}}),
            "limits.gyro_bias_q",
        ),
        (
            json!({"gyro_bias_x": {"max_value": 1.0}}),
            "limits.gyro_bias_x.max_value",
        ),
        (
            json!({"gyro_bias_x": {"max_abs_value": "big"}}),
            "limits.gyro_bias_x.max_abs_value",
        ),
        (json!([]), "limits"),
    ] {
        let body = json!({"name": "SINS-C", "limits": limits});
        let r = send(
            &app,
            reqwest::Method::POST,
            &app.admin,
            "/product-types",
            Some(body),
        )
        .await;
        let (status, p) = problem(r).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{p}");
        assert_eq!(p["field"], field, "{p}");
        assert!(p["detail"].as_str().unwrap().starts_with(field), "{p}");
    }
    let body = json!({"name": "bad/name", "limits": {}});
    let r = send(
        &app,
        reqwest::Method::POST,
        &app.admin,
        "/product-types",
        Some(body),
    )
    .await;
    let (status, p) = problem(r).await;
    assert_eq!(
        (status, &p["field"]),
        (StatusCode::UNPROCESSABLE_ENTITY, &json!("name"))
    );
    let body = json!({"name": "SINS-D", "limits": {}, "colour": "red"});
    let r = send(
        &app,
        reqwest::Method::POST,
        &app.admin,
        "/product-types",
        Some(body),
    )
    .await;
    assert_eq!(problem(r).await.0, StatusCode::UNPROCESSABLE_ENTITY);

    // A run's metadata must name a product as a product type is named.
    let mut meta: Value = serde_json::from_slice(&metadata("BAD-1", "csv")).unwrap();
    meta["product"] = json!("no such/name");
    let r = app
        .upload_multipart(
            &app.admin,
            "BAD-1",
            &serde_json::to_vec(&meta).unwrap(),
            b"t,dthx,dthy,dthz,dvx,dvy,dvz\n".to_vec(),
        )
        .await;
    let (status, p) = problem(r).await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p["detail"].as_str().unwrap().contains("product"), "{p}");

    let r = send(
        &app,
        reqwest::Method::DELETE,
        &app.admin,
        "/product-types/SINS-B",
        None,
    )
    .await;
    assert_eq!(r.status(), StatusCode::NO_CONTENT);
    let r = send(
        &app,
        reqwest::Method::DELETE,
        &app.admin,
        "/product-types/SINS-B",
        None,
    )
    .await;
    assert_eq!(problem(r).await.0, StatusCode::NOT_FOUND);
    app.stop().await;
}

/// A run whose metadata declares a scheme it did not finish (ten positions
/// recorded, `ten-position-9+9`'s nineteen declared) needs review, saying
/// how far it got; the same run declaring what it did is accepted.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_short_of_its_declared_scheme_needs_review() {
    let app = spawn_app(1).await;
    for (serial, declared, reasons) in [
        (
            "SHORT-1",
            "ten-position-9+9",
            json!([{"reason": "short_of_scheme", "dwells": 10, "declared": 19}]),
        ),
        ("SHORT-2", "ten-position", json!([])),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let mut run = short_run(dir.path(), 5, DataFormat::F64le, serial);
        let mut meta: Value = serde_json::from_slice(&run.metadata).unwrap();
        meta["scheme"] = json!(declared);
        run.metadata = serde_json::to_vec(&meta).unwrap();
        let (run_id, job) = app
            .upload_and_calibrate(serial, &run, Duration::from_secs(300))
            .await;
        assert_eq!(job["state"], "succeeded", "{job}");
        let view = app.get_run(&run_id).await;
        assert_eq!(view["verdict"]["reasons"], reasons, "{view}");
    }
    app.stop().await;
}
