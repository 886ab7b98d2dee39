//! The steps the Chromium walks share: signing in, visiting a page with
//! its screenshot (no console error allowed), product types, uploads for
//! a product, running the
//! queued jobs by hand, and counting a page's printed sheets.

use std::time::Duration;

use crate::common::browser::{screenshot_path, Browser};
use crate::common::{SimRun, TestApp};
use reqwest::StatusCode;
use serde_json::json;

pub(crate) const LOAD: Duration = Duration::from_secs(10);
pub(crate) const CALIBRATION: Duration = Duration::from_secs(240);

/// Writes `run`'s metadata next to its data, with `product` named, for the
/// upload form's file inputs.
pub(crate) fn with_product(run: &SimRun, product: &str) -> (std::path::PathBuf, Vec<u8>) {
    let mut meta: serde_json::Value = serde_json::from_slice(&run.metadata).unwrap();
    meta["product"] = json!(product);
    let bytes = serde_json::to_vec(&meta).unwrap();
    let path = run.data.with_file_name("run-with-product.json");
    std::fs::write(&path, &bytes).unwrap();
    (path, bytes)
}

/// Uploads `run` of unit `serial` through the API as the admin, with
/// `product` named in its metadata; the upload's answer (`run_id`,
/// `job_id`).
pub(crate) async fn upload_for_product(
    app: &TestApp,
    serial: &str,
    run: &SimRun,
    product: &str,
) -> serde_json::Value {
    let (_, meta) = with_product(run, product);
    let r = app
        .upload_multipart(&app.admin, serial, &meta, std::fs::read(&run.data).unwrap())
        .await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    r.json().await.unwrap()
}

/// The walks' product type NAV-1: loose limits the paper's unit passes.
pub(crate) async fn nav1_product(app: &TestApp) {
    product_type(
        app,
        "NAV-1",
        json!({"gyro_bias_x": {"max_abs_value": 1.0, "max_sigma": 0.1}}),
    )
    .await;
}

pub(crate) async fn product_type(app: &TestApp, name: &str, limits: serde_json::Value) {
    let r = app
        .http
        .post(app.url("/product-types"))
        .bearer_auth(&app.admin)
        .json(&json!({"name": name, "limits": limits}))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::CREATED);
}

/// Opens `path`, checks the page logged no console error, and saves a
/// full-page screenshot as `name`.
pub(crate) async fn visit(b: &Browser, origin: &str, path: &str, name: &str) {
    b.goto(&format!("{origin}{path}")).await;
    b.wait_for("main", LOAD).await;
    shoot(b, name).await;
}

pub(crate) async fn shoot(b: &Browser, name: &str) {
    let errors = b.console_errors().await;
    assert!(errors.is_empty(), "{name}: console errors {errors:?}");
    b.full_page_screenshot(screenshot_path(&format!("workbench-{name}.png")))
        .await;
}

/// How many pages the current page prints on (Chromium's print to PDF,
/// with the page's own `@page` size; pdfinfo counts them).
pub(crate) async fn printed_pages(b: &Browser) -> usize {
    use base64::Engine;
    let printed = b
        .cdp("Page.printToPDF", json!({"preferCSSPageSize": true}))
        .await;
    let pdf = base64::engine::general_purpose::STANDARD
        .decode(printed["data"].as_str().expect("printToPDF's data"))
        .unwrap();
    let path = screenshot_path("workbench-certificate-print.pdf");
    std::fs::write(&path, pdf).unwrap();
    let info = std::process::Command::new("pdfinfo")
        .arg(&path)
        .output()
        .expect("pdfinfo (poppler-utils; scripts/test installs it)");
    let info = String::from_utf8_lossy(&info.stdout).into_owned();
    info.lines()
        .find_map(|l| l.strip_prefix("Pages:"))
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("pdfinfo: {info}"))
}

pub(crate) async fn sign_in(b: &Browser, origin: &str, token: &str) {
    b.goto(&format!("{origin}/")).await;
    b.wait_for("input#token", LOAD).await.send_keys(token).await;
    b.find("form[action='/signin'] button").await.click().await;
    b.wait_for("nav.top", LOAD).await;
}

/// Runs every queued job, one after the other (the server has no worker
/// of its own here, so that a page can be seen before its job runs).
pub(crate) async fn run_queued_jobs(app: &TestApp) {
    while !matches!(
        app.runner.try_run_next_job(0).await.unwrap(),
        sinscal_server::jobs::Outcome::Empty
    ) {}
}
