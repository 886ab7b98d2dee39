//! The workbench in a real headless Chromium, from sign-in to a rejected
//! unit: a run uploaded through the form and followed live to its result,
//! the run page's 24 rows and convergence plots, a unit's trends and
//! repeatability after three runs, a soaked unit's thermal model, the
//! noise, certificate and admin pages, and a station kept out of admin
//! (the diagnosis page is walked in `loop_in_chromium`). No page logs a
//! console error. Screenshots of every page go to `target/screenshots/`.

use crate::common::browser::{screenshot_path, Browser};
use crate::common::{short_run, spawn_app, SimRun};
use crate::steps::{
    nav1_product, printed_pages, product_type, run_queued_jobs, shoot, sign_in, upload_for_product,
    visit, with_product, CALIBRATION, LOAD,
};
use reqwest::StatusCode;
use serde_json::json;
use sinscal_core::io::data::DataFormat;

#[tokio::test]
async fn the_workbench_in_chromium() {
    let app = spawn_app(0).await;
    let origin = app.origin();
    nav1_product(&app).await;
    // Tight enough that the paper's 0.05 deg/h bias fails it.
    product_type(
        &app,
        "NAV-TIGHT",
        json!({"gyro_bias_x": {"max_abs_value": 0.001}}),
    )
    .await;
    let dir = tempfile::tempdir().unwrap();
    let runs: Vec<SimRun> = (0..3)
        .map(|k| {
            let d = dir.path().join(format!("a{k}"));
            std::fs::create_dir_all(&d).unwrap();
            short_run(&d, 11 + k, DataFormat::Csv, "RLG-A")
        })
        .collect();

    let b = Browser::start().await;
    // Without a session the root is the sign-in page.
    visit(&b, &origin, "/", "signin").await;
    sign_in(&b, &origin, &app.admin).await;
    let session = b.cookie("sinscal_session").await.expect("a session cookie");
    assert!(session.http_only);
    assert_eq!(session.same_site.as_deref(), Some("Strict"));

    // Upload through the form and watch the job finish on the run page:
    // the live block reloads the page when the calibration settles.
    let (meta_path, _) = with_product(&runs[0], "NAV-1");
    visit(&b, &origin, "/upload", "upload").await;
    b.find("input#metadata").await.upload(&meta_path).await;
    b.find("input#data").await.upload(&runs[0].data).await;
    b.find("form#upload button").await.click().await;
    let progress = b.wait_for("section#progress", LOAD).await;
    assert!(b.current_url().await.contains("/runs/"));
    // Nothing has run yet: the page shows the job queued and asks for its
    // progress every two seconds; it reloads by itself once the job is done.
    assert_eq!(
        progress.attr("hx-trigger").await.as_deref(),
        Some("every 2s")
    );
    assert!(b.find("td.job-state").await.text().await.contains("queued"));
    assert!(b.find_all("table#parameters").await.is_empty());
    let runner = app.runner.clone();
    let job = tokio::spawn(async move { runner.try_run_next_job(0).await.unwrap() });
    let run_id = b
        .current_url()
        .await
        .rsplit('/')
        .next()
        .unwrap()
        .to_string();
    b.wait_for("table#parameters", CALIBRATION).await;
    job.await.unwrap();
    assert!(b
        .find("section#progress")
        .await
        .attr("hx-trigger")
        .await
        .is_none());
    assert_eq!(b.find_all("table#parameters tbody tr").await.len(), 24);
    // Per family, the estimate and its σ on a log axis.
    assert_eq!(
        b.find_all("#convergence figure.estimate svg").await.len(),
        7
    );
    assert_eq!(b.find_all("#convergence figure.sigma svg").await.len(), 7);
    assert!(b.find("#verdict").await.text().await.contains("accepted"));
    shoot(&b, "run").await;

    // Two more runs of the unit (through the API), then its page.
    for run in &runs[1..] {
        let up = upload_for_product(&app, "RLG-A", run, "NAV-1").await;
        run_queued_jobs(&app).await;
        let job = app.get_job(up["job_id"].as_str().unwrap()).await;
        assert_eq!(job["state"], "succeeded");
    }
    visit(&b, &origin, "/units/RLG-A", "unit").await;
    assert_eq!(b.find_all("#trends svg").await.len(), 24);
    assert_eq!(b.find_all("table#repeatability tbody tr").await.len(), 24);
    // Three run columns, then mean, std, range, largest change, limit.
    let header = b.find_all("table#repeatability thead th").await.len();
    assert_eq!(header, 2 + 3 + 6);
    assert_eq!(b.find_all("table#history tbody tr").await.len(), 3);
    // Compare the first and last run.
    let radios_a = b.find_all("input[name='a']").await;
    let radios_b = b.find_all("input[name='b']").await;
    radios_a[0].click().await;
    radios_b[2].click().await;
    b.find("button#compare-runs").await.click().await;
    b.wait_for("table.compare", LOAD).await;
    assert_eq!(b.find_all("table.compare tbody tr").await.len(), 24);
    shoot(&b, "unit-compare").await;

    // The units page, filtered.
    visit(&b, &origin, "/?verdict=accepted", "units").await;
    assert!(b.find("table#units").await.text().await.contains("RLG-A"));

    // The run's other pages.
    visit(
        &b,
        &origin,
        &format!("/runs/{run_id}/certificate"),
        "certificate",
    )
    .await;
    let facts = b.find("#certificate-facts").await.text().await;
    assert!(facts.contains("RLG-A") && facts.contains("NAV-1") && facts.contains("sinscal "));
    // A draft until approved; the button issues its number.
    assert!(b
        .find("#certificate-number")
        .await
        .text()
        .await
        .contains("DRAFT"));
    assert_eq!(
        b.find_all("#certificate-parameters tbody tr").await.len(),
        24
    );
    b.find("form#approve button").await.click().await;
    b.wait_for("#approved-by", LOAD).await;
    let number = b.find("#certificate-number").await.text().await;
    assert!(number.contains("SC-000001"), "{number}");
    shoot(&b, "certificate-approved").await;
    assert_eq!(
        printed_pages(&b).await,
        1,
        "the certificate prints on one A4 page"
    );
    visit(&b, &origin, &format!("/runs/{run_id}/noise"), "noise").await;
    // One chart per sensor axis.
    assert_eq!(
        b.find_all("#gyro-allan svg, #accel-allan svg").await.len(),
        6
    );
    assert_eq!(b.find_all("table#gyro-noise tr").await.len(), 4);

    // A rejected unit shows what failed.
    let rdir = dir.path().join("b");
    std::fs::create_dir_all(&rdir).unwrap();
    let rejected = short_run(&rdir, 21, DataFormat::Csv, "RLG-B");
    upload_for_product(&app, "RLG-B", &rejected, "NAV-TIGHT").await;
    run_queued_jobs(&app).await;
    visit(&b, &origin, "/?verdict=rejected", "units-rejected").await;
    assert!(b.find("table#units").await.text().await.contains("RLG-B"));
    b.find("table#units a[href^='/runs/']").await.click().await;
    b.wait_for("#verdict", LOAD).await;
    let verdict = b.find("#verdict").await.text().await;
    assert!(
        verdict.contains("rejected") && verdict.contains("gyro_bias_x"),
        "{verdict}"
    );
    assert!(!b.find_all("table#parameters tr.fail").await.is_empty());
    shoot(&b, "run-rejected").await;

    // A unit soaked at three temperatures shows its thermal model.
    for (k, t) in [-20.0, 25.0, 65.0].into_iter().enumerate() {
        let d = dir.path().join(format!("t{k}"));
        std::fs::create_dir_all(&d).unwrap();
        let mut cfg = crate::common::sim_config(
            31 + k as u64,
            crate::thermal_support::parameters_at(t),
            "ten-position",
            30.0,
        );
        cfg.sample_rate_hz = 50.0;
        let run = crate::common::simulate_run(&d, &cfg, DataFormat::F64le, false, "RLG-T", None);
        let mut meta: serde_json::Value = serde_json::from_slice(&run.metadata).unwrap();
        meta["temperature_c"] = json!(t);
        let r = app
            .upload_multipart(
                &app.admin,
                "RLG-T",
                &serde_json::to_vec(&meta).unwrap(),
                std::fs::read(&run.data).unwrap(),
            )
            .await;
        assert_eq!(r.status(), StatusCode::ACCEPTED);
    }
    run_queued_jobs(&app).await;
    visit(&b, &origin, "/units/RLG-T", "unit-thermal").await;
    assert_eq!(b.find_all("table#thermal tbody tr").await.len(), 24);
    assert_eq!(b.find_all("#thermal-charts svg").await.len(), 24);
    assert!(b
        .find("#thermal-check")
        .await
        .text()
        .await
        .contains("adequate"));

    // Admin: issue a station token through the form.
    visit(&b, &origin, "/admin", "admin").await;
    b.find("input#label")
        .await
        .send_keys("line A station 1")
        .await;
    b.find("select#role").await.select_by_value("station").await;
    b.find("form#new-token button").await.click().await;
    let station = b.wait_for("#issued-token", LOAD).await.text().await;
    assert!(station.starts_with("sinscal_"));
    shoot(&b, "admin-token-issued").await;

    // Sign out, sign in as the station: upload yes, admin and units no.
    b.find("nav.top form button").await.click().await;
    b.wait_for("input#token", LOAD).await;
    sign_in(&b, &origin, &station).await;
    assert!(b.current_url().await.ends_with("/upload"));
    // A data file cut off mid-line through the form: the page names the
    // data file and the line, and offers the form again.
    let data = std::fs::read(&runs[0].data).unwrap();
    let broken = dir.path().join("broken.csv");
    let mut cut = data[..data.len() / 2].to_vec();
    cut.extend_from_slice(b"\n1.0,not-a-number\n");
    std::fs::write(&broken, cut).unwrap();
    b.find("input#metadata").await.upload(&meta_path).await;
    b.find("input#data").await.upload(&broken).await;
    b.find("form#upload button").await.click().await;
    let refusal = b.wait_for("#refusal", LOAD).await.text().await;
    assert!(refusal.contains("The data file was refused"), "{refusal}");
    assert!(refusal.contains("line"), "{refusal}");
    assert_eq!(b.find_all("form#upload").await.len(), 1);
    // The refusal itself is the one console entry (the document's 422).
    let errors = b.console_errors().await;
    assert!(errors.iter().all(|e| e.contains("422")), "{errors:?}");
    b.full_page_screenshot(screenshot_path("workbench-upload-refused.png"))
        .await;
    assert!(b.find_all("nav.top a[href='/admin']").await.is_empty());
    b.goto(&format!("{origin}/admin")).await;
    assert!(b.wait_for("h1", LOAD).await.text().await.contains("403"));
    // The refusal itself is the one console entry (the document's 403).
    let errors = b.console_errors().await;
    assert!(errors.iter().all(|e| e.contains("403")), "{errors:?}");
    b.full_page_screenshot(screenshot_path("workbench-station-admin-refused.png"))
        .await;
    b.goto(&format!("{origin}/units/RLG-A")).await;
    assert!(b.wait_for("h1", LOAD).await.text().await.contains("403"));
    let _ = b.console_errors().await;
    b.quit().await;
    app.stop().await;
}
