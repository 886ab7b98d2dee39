//! The design page over HTTP, as a browser without JavaScript uses it: the
//! form pre-filled with the docs' example, a post that queues a design
//! job and goes to its page, the page while the job waits (polling) and
//! once it is done (the scheme, the predicted accuracies, the scheme's
//! JSON to download), and a field that does not parse refused by name.

use crate::common::pages::location;
use crate::common::spawn_app;
use reqwest::StatusCode;
use sinscal_core::sim::Scheme;

/// A quick design (see `design_in_chromium`): the form's fields as sent.
const QUICK: &[(&str, &str)] = &[
    ("target", "table1"),
    ("tighten", "0.1"),
    ("margin", "3"),
    ("arw_deg_rt_h", "0.001"),
    ("vrw_ug_rt_hz", "10"),
    ("rate_dps", "10"),
    ("accel_dps2", "20"),
    ("min_dwell_s", "60"),
    ("max_dwell_s", "3600"),
    ("max_turns", "7"),
    ("axes", "body"),
    ("max_duration_s", ""),
    ("detect", ""),
];

#[tokio::test]
async fn the_design_form_queues_a_job_whose_page_shows_the_scheme() {
    let app = spawn_app(0).await;
    let engineer = app.create_token("engineer").await;
    let s = app.sign_in(&engineer).await;
    let form = s.get("/design").await.text().await.unwrap();
    assert!(form.contains("name=\"margin\""), "{form}");
    assert!(form.contains("value=\"3\""), "{form}");
    assert!(form.contains("option value=\"table1\" selected"), "{form}");
    assert!(
        form.contains("href=\"/design\""),
        "the navigation links the page"
    );

    // A field that does not parse is refused by name; nothing is queued.
    let mut bad = QUICK.to_vec();
    bad[2] = ("margin", "three");
    let r = s.post("/design", &bad).await;
    assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY);
    assert!(r.text().await.unwrap().contains("margin"));
    assert_eq!(app.store.queue_depth().await.unwrap(), 0);

    let r = s.post("/design", QUICK).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let page = location(&r).unwrap().to_string();
    assert!(page.starts_with("/designs/"), "{page}");
    let waiting = s.get(&page).await.text().await.unwrap();
    assert!(waiting.contains("data-state=\"queued\""), "{waiting}");
    assert!(waiting.contains("hx-trigger=\"every 2s\""), "{waiting}");
    assert!(!waiting.contains("id=\"scheme\""));
    let scheme_json = format!("{page}/scheme.json");
    assert_eq!(s.get(&scheme_json).await.status(), StatusCode::NOT_FOUND);

    app.runner.try_run_next_job(0).await.unwrap();
    // The polled block, now settled, asks the page to reload itself.
    let block = s.get(&format!("{page}/progress")).await;
    assert_eq!(block.headers()["hx-refresh"], "true");
    let done = s.get(&page).await.text().await.unwrap();
    assert!(done.contains("data-state=\"succeeded\""), "{done}");
    assert!(!done.contains("hx-trigger"), "a settled job is not polled");
    assert!(done.contains("id=\"scheme\"") && done.contains("id=\"predicted\""));
    assert!(done.contains("gyro_bias_x") && done.contains("ten-position-9+9"));
    let r = s.get(&scheme_json).await;
    assert_eq!(r.status(), StatusCode::OK);
    let disposition = r.headers()["content-disposition"].to_str().unwrap();
    assert!(disposition.starts_with("attachment"), "{disposition}");
    let scheme: Scheme = serde_json::from_str(&r.text().await.unwrap()).unwrap();
    scheme.validate().unwrap();
    assert!(scheme.counts().1 <= 7);
    app.stop().await;
}
