//! Calibration certificates through the server: a draft until an engineer
//! approves an accepted result, then a number and issue date that stay
//! the same on every view; refused (409) for a result that is not
//! accepted; a PDF of one A4 page whose text (pdftotext) has the number,
//! the unit, the 24 parameters with σ and the approver; and a run
//! calibrated again needs a new approval while the old certificate stays
//! on file. Needs poppler-utils (`pdftotext`, `pdftoppm`; scripts/test
//! installs them): the test fails without them.

use crate::common;

use std::process::Command;
use std::time::Duration;

use common::*;
use reqwest::StatusCode;
use serde_json::{json, Value};
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::{Effects, PARAMETERS};

const CALIBRATION: Duration = Duration::from_secs(300);

async fn post(app: &TestApp, token: &str, path: &str) -> reqwest::Response {
    app.http
        .post(app.url(path))
        .bearer_auth(token)
        .send()
        .await
        .unwrap()
}

/// Uploads a short clean run of `serial` naming `product`; its run id.
async fn calibrated(app: &TestApp, serial: &str, product: &str, seed: u64) -> String {
    let dir = tempfile::tempdir().unwrap();
    let cfg = model_check_run(seed, Effects::none());
    let mut run = simulate_run(dir.path(), &cfg, DataFormat::F64le, false, serial, None);
    let mut meta: Value = serde_json::from_slice(&run.metadata).unwrap();
    meta["product"] = json!(product);
    meta["station"] = json!("bench-3");
    run.metadata = serde_json::to_vec(&meta).unwrap();
    app.upload_and_calibrate(serial, &run, CALIBRATION).await.0
}

/// The text of a PDF, by pdftotext (the layout kept, so a table row is a
/// line).
fn pdf_text(pdf: &[u8]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.pdf");
    std::fs::write(&path, pdf).unwrap();
    let out = Command::new("pdftotext")
        .arg("-layout")
        .arg(&path)
        .arg("-")
        .output()
        .expect("pdftotext (poppler-utils; scripts/test installs it)");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// How many pages pdftoppm renders of a PDF.
fn rendered_pages(pdf: &[u8]) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.pdf");
    std::fs::write(&path, pdf).unwrap();
    let out = Command::new("pdftoppm")
        .args(["-png", "-r", "30"])
        .arg(&path)
        .arg(dir.path().join("page"))
        .output()
        .expect("pdftoppm (poppler-utils; scripts/test installs it)");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::read_dir(dir.path())
        .unwrap()
        .filter(|e| {
            let name = e.as_ref().unwrap().file_name();
            let name = name.to_string_lossy();
            name.starts_with("page") && name.ends_with(".png")
        })
        .count()
}

async fn pdf(app: &TestApp, token: &str, run: &str) -> Vec<u8> {
    let r = app
        .get(token, &format!("/runs/{run}/certificate.pdf"))
        .await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.headers()["content-type"], "application/pdf");
    r.bytes().await.unwrap().to_vec()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_certificate_is_approved_once_numbered_and_printed_on_one_page() {
    let app = spawn_app_with(1, |c| c.diagnose_inadequate = false).await;
    let r = app
        .http
        .post(app.url("/product-types"))
        .bearer_auth(&app.admin)
        .json(&json!({"name": "CERT-A", "limits": {
            "gyro_bias_x": {"max_abs_value": 10.0, "max_sigma": 1.0, "max_repeatability": 1.0},
            "accel_bias_z": {"max_abs_value": 10000.0, "max_repeatability": 1000.0}
        }}))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::CREATED);
    let engineer = app.create_token("engineer").await;
    let station = app.create_token("station").await;

    // One run cannot judge repeatability: needs review, not approvable.
    let first = calibrated(&app, "CERT-1", "CERT-A", 41).await;
    let r = post(
        &app,
        &engineer,
        &format!("/runs/{first}/certificate/approve"),
    )
    .await;
    assert_eq!(r.status(), StatusCode::CONFLICT);
    assert_eq!(r.headers()["content-type"], "application/problem+json");
    let problem: Value = r.json().await.unwrap();
    assert!(
        problem["detail"].as_str().unwrap().contains("needs_review"),
        "{problem}"
    );

    // The second is accepted: a draft until approved.
    let run = calibrated(&app, "CERT-1", "CERT-A", 42).await;
    let path = format!("/runs/{run}/certificate");
    let draft: Value = app.get(&engineer, &path).await.json().await.unwrap();
    assert_eq!(draft["status"], "draft", "{draft}");
    assert_eq!(draft["verdict"], "accepted");
    assert_eq!(draft["number"], Value::Null);
    assert_eq!(draft["approvable"], true);
    let text = pdf_text(&pdf(&app, &engineer, &run).await);
    assert!(text.contains("DRAFT"), "{text}");

    // Stations neither read nor approve certificates.
    for r in [
        app.get(&station, &path).await,
        app.get(&station, &format!("{path}.pdf")).await,
        post(&app, &station, &format!("{path}/approve")).await,
    ] {
        assert_eq!(r.status(), StatusCode::FORBIDDEN);
    }

    let r = post(&app, &engineer, &format!("{path}/approve")).await;
    assert_eq!(r.status(), StatusCode::CREATED);
    let issued: Value = r.json().await.unwrap();
    let number = issued["number"].as_str().unwrap().to_string();
    assert!(number.starts_with("SC-") && number.len() == 9, "{issued}");
    assert_eq!(issued["status"], "approved");
    assert_eq!(issued["approved_by"], "test");
    assert_eq!(issued["approver_role"], "engineer");
    assert_eq!(issued["approvable"], false);
    // Approving again, and viewing again, change nothing.
    let again = post(&app, &app.admin, &format!("{path}/approve")).await;
    assert_eq!(again.status(), StatusCode::OK);
    let again: Value = again.json().await.unwrap();
    for view in [again, app.get_json(&path).await, app.get_json(&path).await] {
        for field in ["number", "issued_at", "approved_by", "approved_at"] {
            assert_eq!(view[field], issued[field], "{field}");
        }
    }

    // The PDF: one page, with the number, the unit, every parameter with
    // its σ, and the approver.
    let bytes = pdf(&app, &engineer, &run).await;
    assert!(bytes.starts_with(b"%PDF-"));
    // Kept beside the workbench's screenshots, to be looked at.
    std::fs::write(
        common::browser::screenshot_path("certificate-approved.pdf"),
        &bytes,
    )
    .unwrap();
    assert_eq!(rendered_pages(&bytes), 1);
    let text = pdf_text(&bytes);
    for needle in [
        number.as_str(),
        "CERT-1",
        "CERT-A",
        "bench-3",
        "test (engineer)",
        "1σ",
    ] {
        assert!(text.contains(needle), "{needle:?} not in\n{text}");
    }
    assert!(!text.contains("DRAFT"), "{text}");
    let result = app.get_result(&run).await;
    for p in PARAMETERS.iter() {
        let line = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(p.name))
            .unwrap_or_else(|| panic!("no line for {} in\n{text}", p.name));
        let sigma = result["parameters"][p.name]["sigma"].as_f64().unwrap();
        let cells: Vec<&str> = line.split_whitespace().collect();
        let printed: f64 = cells[2].parse().unwrap();
        assert!(
            (printed - sigma).abs() <= 0.01 * sigma.abs(),
            "{}: σ {sigma} printed {printed}",
            p.name
        );
    }

    // Calibrated again: the new result is a draft, the old certificate
    // stays on file.
    let r = post(&app, &engineer, &format!("/runs/{run}/calibrate")).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let job: Value = r.json().await.unwrap();
    let job = app.wait_job(job["id"].as_str().unwrap(), CALIBRATION).await;
    assert_eq!(job["state"], "succeeded");
    let redrafted = app.get_json(&path).await;
    assert_eq!(redrafted["status"], "draft", "{redrafted}");
    assert_eq!(redrafted["result_seq"], 2);
    assert_eq!(issued["result_seq"], 1);
    assert_eq!(redrafted["superseded"][0]["number"], number.as_str());
    let r = post(&app, &engineer, &format!("{path}/approve")).await;
    assert_eq!(r.status(), StatusCode::CREATED);
    let renewed: Value = r.json().await.unwrap();
    assert_ne!(renewed["number"], issued["number"]);
    app.stop().await;
}
