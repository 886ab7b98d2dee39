//! The discrepancy loop closed in a real headless Chromium, as an engineer
//! walks it: a unit whose accelerometers lag by 2 ms fails its model check
//! (its limited parameter "unverified", not "pass"), the run page's button
//! diagnoses it, the diagnosis names the delay, "Recalibrate with it"
//! calibrates the run again with the delay as a state, and the run's
//! current result is then within 3σ of the truth on every parameter, its
//! certificate and compensation file from the adopted model, the base
//! model's result still listed. Screenshots go to `target/screenshots/`.

use crate::common::browser::Browser;
use crate::common::{
    delayed_accelerometers, model_check_run, simulate_run, spawn_app_with, TestApp,
};
use crate::steps::{nav1_product, shoot, sign_in, upload_for_product, visit, CALIBRATION, LOAD};
use serde_json::Value;
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::ErrorParameters;

/// The delayed unit's run: the 9+9 scheme with 120 s dwells at 20 Hz,
/// long enough for a 2 ms accelerometer delay to stand out (as in
/// tests/suite/api_diagnose.rs), uploaded under product NAV-1.
async fn upload_delayed_unit(app: &TestApp, dir: &std::path::Path) -> String {
    let cfg = model_check_run(11, delayed_accelerometers());
    let run = simulate_run(dir, &cfg, DataFormat::F64le, false, "RLG-D1", None);
    let up = upload_for_product(app, "RLG-D1", &run, "NAV-1").await;
    up["run_id"].as_str().unwrap().to_string()
}

/// Runs the next queued job while the page waits for `css` to contain
/// `needle` (the page's own live block reloads it when the job settles).
async fn run_next_job_watching(app: &TestApp, b: &Browser, css: &str, needle: &str) {
    let runner = app.runner.clone();
    let job = tokio::spawn(async move { runner.try_run_next_job(0).await.unwrap() });
    b.wait_for_text(css, needle, CALIBRATION).await;
    job.await.unwrap();
}

/// A number as the pages print it (a minus sign may be U+2212).
fn number(cell: &str) -> f64 {
    let plain = cell.trim().replace('\u{2212}', "-");
    plain
        .parse()
        .unwrap_or_else(|e| panic!("{cell:?} is not a number: {e}"))
}

/// The run page's 24 rows as (name, value, σ, check).
async fn parameter_rows(b: &Browser) -> Vec<(String, f64, f64, String)> {
    let mut rows = Vec::new();
    for tr in b.find_all("table#parameters tbody tr").await {
        let cells = tr.find_all("td").await;
        let mut text = Vec::new();
        for c in &cells {
            text.push(c.text().await);
        }
        rows.push((
            text[0].clone(),
            number(&text[1]),
            number(&text[2]),
            text[6].clone(),
        ));
    }
    rows
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_diagnosed_delay_is_adopted_from_the_pages() {
    // Diagnosis on the engineer's click, not queued by the failed check.
    let app = spawn_app_with(0, |c| c.diagnose_inadequate = false).await;
    let origin = app.origin();
    nav1_product(&app).await;
    let dir = tempfile::tempdir().unwrap();
    let run_id = upload_delayed_unit(&app, dir.path()).await;
    let b = Browser::start().await;
    sign_in(&b, &origin, &app.admin).await;
    let run_page = format!("/runs/{run_id}");

    // The base model cannot explain the delay: the check fails, and the
    // one limited parameter is unverified, not passed.
    b.goto(&format!("{origin}{run_page}")).await;
    run_next_job_watching(&app, &b, "#verdict", "needs review").await;
    b.wait_for("table#parameters", LOAD).await;
    assert!(b
        .find("#model-check")
        .await
        .text()
        .await
        .contains("inadequate"));
    let rows = parameter_rows(&b).await;
    assert_eq!(rows.len(), 24);
    let checks: Vec<&str> = rows.iter().map(|r| r.3.as_str()).collect();
    assert!(!checks.contains(&"pass"), "{checks:?}");
    assert!(checks.contains(&"unverified"), "{checks:?}");
    shoot(&b, "loop-inadequate").await;

    // Diagnose from the run page's button and read what it names.
    b.find(&format!("form[action='/runs/{run_id}/diagnose'] button"))
        .await
        .click()
        .await;
    b.wait_for_text("section#progress", "diagnosis", LOAD).await;
    run_next_job_watching(
        &app,
        &b,
        &format!("a[href='/runs/{run_id}/diagnosis']"),
        "succeeded",
    )
    .await;
    visit(
        &b,
        &origin,
        &format!("{run_page}/diagnosis"),
        "loop-diagnosis",
    )
    .await;
    assert!(b
        .find("table#named")
        .await
        .text()
        .await
        .contains("accel_delay"));
    assert!(!b.find_all("#gap-plot svg").await.is_empty());

    // "Recalibrate with it": the run calibrated again with the delay.
    b.find("#adopt button").await.click().await;
    b.wait_for("section#progress", LOAD).await;
    assert!(b.current_url().await.ends_with(&run_page));
    run_next_job_watching(&app, &b, "#run-model", "accel_delay").await;
    b.wait_for("table#parameters", LOAD).await;
    assert!(b.find("#verdict").await.text().await.contains("accepted"));
    let truth = ErrorParameters::paper().to_canonical();
    let rows = parameter_rows(&b).await;
    assert_eq!(rows.len(), 24);
    for (name, value, sigma, _) in &rows {
        let t = truth[name];
        assert!(
            (value - t).abs() <= 3.0 * sigma,
            "{name}: {value} ± {sigma} against the truth {t}"
        );
    }
    assert!(b
        .find("table#effects")
        .await
        .text()
        .await
        .contains("accel_delay"));
    let earlier = b.find("#earlier-results").await.text().await;
    assert!(earlier.contains("base-24"), "{earlier}");
    shoot(&b, "loop-adopted").await;

    // The certificate and the compensation file carry the adopted model.
    visit(
        &b,
        &origin,
        &format!("{run_page}/certificate"),
        "loop-certificate",
    )
    .await;
    let facts = b.find("#certificate-facts").await.text().await;
    assert!(facts.contains("base-24+accel_delay"), "{facts}");
    let file: Value = app.get_json(&format!("/runs/{run_id}/compensation")).await;
    assert_eq!(file["provenance"]["model"], "base-24+accel_delay", "{file}");
    assert_eq!(file["provenance"]["verdict"], "accepted");
    b.quit().await;
    app.stop().await;
}
