//! The workbench's pages over HTTP, as a browser without JavaScript uses
//! them: sessions, CSRF, roles on every page and action, the upload form,
//! and what each page shows of a calibrated run. (The same pages in a real
//! Chromium are `in_chromium`.)

use std::time::Duration;

use crate::common::pages::{location, set_cookie};
use crate::common::{short_run, spawn_app, spawn_app_with, TestApp};
use reqwest::StatusCode;
use sinscal_core::io::data::DataFormat;

const CALIBRATION: Duration = Duration::from_secs(240);

/// Every page and action, with the roles that may use it. `{run}`,
/// `{unit}` and `{design}` are filled in.
const PAGES: &[(&str, &[&str])] = &[
    ("/units/{unit}", &["engineer", "admin"]),
    // (A station reads its own runs only; this one is the admin's.)
    ("/runs/{run}", &["engineer", "admin"]),
    ("/runs/{run}/progress", &["engineer", "admin"]),
    ("/runs/{run}/certificate", &["engineer", "admin"]),
    ("/runs/{run}/certificate.pdf", &["engineer", "admin"]),
    ("/runs/{run}/noise", &["engineer", "admin"]),
    ("/runs/{run}/files/result.json", &["engineer", "admin"]),
    ("/runs/{run}/files/result.csv", &["engineer", "admin"]),
    (
        "/runs/{run}/files/compensation.json",
        &["engineer", "admin"],
    ),
    ("/runs/{run}/files/compensation.csv", &["engineer", "admin"]),
    ("/upload", &["station", "admin"]),
    ("/design", &["engineer", "admin"]),
    ("/designs/{design}", &["engineer", "admin"]),
    ("/designs/{design}/progress", &["engineer", "admin"]),
    ("/admin", &["admin"]),
];

/// Actions (form posts) and who may take them; each is refused for the
/// others before it changes anything.
const ACTIONS: &[(&str, &[&str])] = &[
    ("/runs/{run}/diagnose", &["engineer", "admin"]),
    ("/runs/{run}/adopt", &["engineer", "admin"]),
    ("/runs/{run}/calibrate", &["engineer", "admin"]),
    ("/runs/{run}/certificate/approve", &["engineer", "admin"]),
    ("/runs/{run}/delete", &["admin"]),
    ("/design", &["engineer", "admin"]),
    ("/admin/tokens", &["admin"]),
    ("/admin/products", &["admin"]),
];

async fn calibrated_unit(app: &TestApp, serial: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 3, DataFormat::Csv, serial);
    app.upload_and_calibrate(serial, &run, CALIBRATION).await.0
}

fn fill(path: &str, run: &str, unit: &str, design: &str) -> String {
    path.replace("{run}", run)
        .replace("{unit}", unit)
        .replace("{design}", design)
}

/// A design job, queued through the API (its page is there from then on).
async fn queued_design(app: &TestApp) -> String {
    let r = app
        .http
        .post(app.url("/designs"))
        .bearer_auth(&app.admin)
        .json(&serde_json::json!({"tighten": 0.1, "arw_deg_rt_h": 0.001, "max_turns": 7}))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let job: serde_json::Value = r.json().await.unwrap();
    job["id"].as_str().unwrap().to_string()
}

#[tokio::test]
async fn pages_refuse_without_a_session_and_show_the_sign_in_form() {
    let app = spawn_app(1).await;
    let http = crate::common::pages::no_redirects();
    let origin = app.origin();
    let run = uuid::Uuid::new_v4().to_string();
    for (path, _) in PAGES {
        let r = http
            .get(format!("{origin}{}", fill(path, &run, "U1", &run)))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), StatusCode::SEE_OTHER, "{path}");
        assert_eq!(location(&r), Some("/signin"), "{path}");
    }
    for (path, _) in ACTIONS {
        let r = http
            .post(format!("{origin}{}", fill(path, &run, "U1", &run)))
            .form(&[("csrf", "00")])
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), StatusCode::SEE_OTHER, "{path}");
    }
    // The root is the sign-in form itself.
    let root = http.get(format!("{origin}/")).send().await.unwrap();
    assert_eq!(root.status(), StatusCode::OK);
    assert!(root.text().await.unwrap().contains("name=\"token\""));
    // A wrong token, and a form without its cookie, are refused.
    let bad = app.sign_in_form("sinscal_0000", false).await;
    assert_eq!(bad.status(), StatusCode::UNAUTHORIZED);
    let forged = http
        .post(format!("{origin}/signin"))
        .form(&[("token", app.admin.as_str()), ("form_token", "abc")])
        .send()
        .await
        .unwrap();
    assert_eq!(forged.status(), StatusCode::FORBIDDEN);
    assert!(set_cookie(&forged, "sinscal_session").is_none());
    app.stop().await;
}

#[tokio::test]
async fn the_session_cookie_is_http_only_strict_and_secure_behind_tls() {
    let app = spawn_app(1).await;
    for tls in [false, true] {
        let r = app.sign_in_form(&app.admin, tls).await;
        let session = set_cookie(&r, "sinscal_session").unwrap();
        assert!(session.contains("HttpOnly"), "{session}");
        assert!(session.contains("SameSite=Strict"), "{session}");
        assert!(session.contains("Path=/"), "{session}");
        assert_eq!(session.contains("Secure"), tls, "{session}");
    }
    // Signing out ends the session on the server, not only in the browser.
    let s = app.sign_in(&app.admin).await;
    assert_eq!(s.get("/admin").await.status(), StatusCode::OK);
    assert_eq!(
        s.post("/signout", &[]).await.status(),
        StatusCode::SEE_OTHER
    );
    assert_eq!(s.get("/admin").await.status(), StatusCode::SEE_OTHER);
    // Revoking a token ends the sessions opened with it.
    let engineer = app.create_token("engineer").await;
    let e = app.sign_in(&engineer).await;
    assert_eq!(e.get("/units/U1").await.status(), StatusCode::NOT_FOUND);
    let admin = app.sign_in(&app.admin).await;
    let tokens: serde_json::Value = app.get_json("/tokens").await;
    let id = tokens
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["role"] == "engineer")
        .unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let r = admin.post(&format!("/admin/tokens/{id}/revoke"), &[]).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    // (`/` would answer the sign-in form itself.)
    assert_eq!(e.get("/units/U1").await.status(), StatusCode::SEE_OTHER);
    app.stop().await;
}

#[tokio::test]
async fn roles_hold_on_every_page_and_action_and_forms_need_their_csrf_token() {
    let app = spawn_app(1).await;
    let serial = "RLG-P1";
    let run = calibrated_unit(&app, serial).await;
    let design = queued_design(&app).await;
    let mut sessions = Vec::new();
    for role in ["station", "engineer", "admin"] {
        let token = if role == "admin" {
            app.admin.clone()
        } else {
            app.create_token(role).await
        };
        sessions.push((role, app.sign_in(&token).await));
    }
    // The run is accepted (no product, a clean check): its page links the
    // compensation file and asks no reason.
    let page = sessions[2]
        .1
        .get(&format!("/runs/{run}"))
        .await
        .text()
        .await
        .unwrap();
    assert!(page.contains("compensation.json\" download"), "{page}");
    assert!(!page.contains("compensation-override"));
    for (path, allowed) in PAGES {
        let path = fill(path, &run, serial, &design);
        for (role, s) in &sessions {
            let status = s.get(&path).await.status();
            if allowed.contains(role) {
                assert_eq!(status, StatusCode::OK, "{role} {path}");
            } else {
                // A station reads only its own runs: another's run is 404.
                assert!(
                    status == StatusCode::FORBIDDEN || status == StatusCode::NOT_FOUND,
                    "{role} {path}: {status}"
                );
            }
        }
    }
    // A design's scheme file is the engineers' too (the queued design has
    // none yet, so the allowed roles are told so, not refused).
    for (role, s) in &sessions {
        let status = s
            .get(&format!("/designs/{design}/scheme.json"))
            .await
            .status();
        match *role {
            "station" => assert_eq!(status, StatusCode::FORBIDDEN),
            _ => assert!(
                status != StatusCode::FORBIDDEN && status != StatusCode::UNAUTHORIZED,
                "{role}: {status}"
            ),
        }
    }
    // The units page: engineers and admins; a station goes to its upload
    // form.
    for (role, s) in &sessions {
        let r = s.get("/").await;
        match *role {
            "station" => assert_eq!(location(&r), Some("/upload")),
            _ => assert_eq!(r.status(), StatusCode::OK, "{role}"),
        }
    }
    let fields = [
        ("role", "engineer"),
        ("label", "from a test"),
        ("name", "P-1"),
        ("limits", "{}"),
    ];
    for (path, allowed) in ACTIONS {
        let path = fill(path, &run, serial, &design);
        for (role, s) in &sessions {
            // Without the token, or with another session's, nobody may.
            let forged = s.post_exactly(&path, &fields).await;
            assert_eq!(
                forged.status(),
                StatusCode::FORBIDDEN,
                "{role} {path} without csrf"
            );
            let mut wrong = fields.to_vec();
            wrong.push(("csrf", "0123456789abcdef"));
            assert_eq!(
                s.post_exactly(&path, &wrong).await.status(),
                StatusCode::FORBIDDEN
            );
            // From another site, even with the token.
            let mut with = fields.to_vec();
            with.push(("csrf", s.csrf.as_str()));
            let cross = s
                .http
                .post(format!("{}{path}", s.origin))
                .header(reqwest::header::COOKIE, &s.cookie)
                .header(reqwest::header::ORIGIN, "http://evil.example")
                .form(&with)
                .send()
                .await
                .unwrap();
            assert_eq!(
                cross.status(),
                StatusCode::FORBIDDEN,
                "{role} {path} cross-site"
            );
            if !allowed.contains(role) {
                let r = s.post(&path, &fields).await;
                assert!(
                    r.status() == StatusCode::FORBIDDEN || r.status() == StatusCode::NOT_FOUND,
                    "{role} {path}: {}",
                    r.status()
                );
            }
        }
    }
    // Nothing above changed anything: the run is still there with its
    // single calibration job, no diagnosis, no new token or product type.
    let r = app.get(&app.admin, &format!("/runs/{run}/diagnosis")).await;
    assert_eq!(r.status(), StatusCode::NOT_FOUND);
    assert_eq!(
        app.get_json("/product-types")
            .await
            .as_array()
            .unwrap()
            .len(),
        0
    );
    assert_eq!(app.get_json("/tokens").await.as_array().unwrap().len(), 3);
    // The allowed actions, with their token, do act.
    let admin = &sessions[2].1;
    let r = admin.post(&format!("/runs/{run}/diagnose"), &[]).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let r = admin
        .post(
            "/admin/products",
            &[
                ("name", "P-1"),
                ("description", ""),
                ("limits", "{\"gyro_bias_x\": {\"max_abs_value\": 1}}"),
            ],
        )
        .await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    assert_eq!(
        app.get_json("/product-types")
            .await
            .as_array()
            .unwrap()
            .len(),
        1
    );
    app.stop().await;
}

#[tokio::test]
async fn the_upload_form_stores_a_run_and_refuses_bad_files_with_the_reason() {
    let app = spawn_app(1).await;
    let station = app.create_token("station").await;
    let s = app.sign_in(&station).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 5, DataFormat::Csv, "RLG-UP");
    let data = std::fs::read(&run.data).unwrap();
    // Without the form's token the body is not read.
    let r = s.upload("", &run.metadata, data.clone()).await;
    assert_eq!(r.status(), StatusCode::FORBIDDEN);
    // Broken data: refused, naming the line.
    let mut broken = data.clone();
    let cut = broken.len() / 2;
    broken.truncate(cut);
    broken.extend_from_slice(b"\n1.0,not-a-number\n");
    let r = s.upload(&s.csrf, &run.metadata, broken).await;
    assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY);
    assert!(r.headers()[reqwest::header::CONTENT_TYPE]
        .to_str()
        .unwrap()
        .starts_with("text/html"));
    assert!(r.text().await.unwrap().contains("line"));
    // The run itself: stored, and the browser is sent to its page.
    let r = s.upload(&s.csrf, &run.metadata, data).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let page = location(&r).unwrap().to_string();
    assert!(page.starts_with("/runs/"), "{page}");
    let id = page.trim_start_matches("/runs/");
    assert_eq!(app.get_run(id).await["unit_serial"], "RLG-UP");
    // The station sees its run's page and its upload in its list.
    assert_eq!(s.get(&page).await.status(), StatusCode::OK);
    assert!(s
        .get("/upload")
        .await
        .text()
        .await
        .unwrap()
        .contains(&id[..8]));
    app.stop().await;
}

/// A run the acceptance did not accept (its product has no product type)
/// offers no compensation link: its page asks for a reason, the download
/// without one is refused, and with one the file records it.
#[tokio::test]
async fn the_compensation_of_a_run_not_accepted_is_downloaded_only_with_a_reason() {
    let app = spawn_app(1).await;
    let dir = tempfile::tempdir().unwrap();
    let mut run = short_run(dir.path(), 4, DataFormat::Csv, "U-OVR");
    let mut meta: serde_json::Value = serde_json::from_slice(&run.metadata).unwrap();
    meta["product"] = serde_json::json!("NO-SUCH-TYPE");
    run.metadata = serde_json::to_vec(&meta).unwrap();
    let (id, job) = app.upload_and_calibrate("U-OVR", &run, CALIBRATION).await;
    assert_eq!(job["state"], "succeeded", "{job}");
    let s = app.sign_in(&app.admin).await;
    let page = s.get(&format!("/runs/{id}")).await.text().await.unwrap();
    assert!(page.contains("id=\"compensation-override\""), "{page}");
    assert!(!page.contains("compensation.json\" download"), "{page}");
    let file = format!("/runs/{id}/files/compensation.json");
    assert_eq!(s.get(&file).await.status(), StatusCode::CONFLICT);
    let r = s.get(&format!("{file}?override=bench+trial")).await;
    assert_eq!(r.status(), StatusCode::OK);
    let json: serde_json::Value = r.json().await.unwrap();
    assert_eq!(json["provenance"]["verdict"], "needs_review");
    assert_eq!(
        json["provenance"]["verdict_override"]["reason"],
        "bench trial"
    );
    app.stop().await;
}

/// `run`'s metadata for `serial`, naming `product` when given.
fn metadata_of(run: &crate::common::SimRun, serial: &str, product: Option<&str>) -> Vec<u8> {
    let mut meta: serde_json::Value = serde_json::from_slice(&run.metadata).unwrap();
    meta["unit_serial"] = serde_json::json!(serial);
    if let Some(p) = product {
        meta["product"] = serde_json::json!(p);
    }
    serde_json::to_vec(&meta).unwrap()
}

/// The text of the element with `id` in `page` (the first line of it).
fn text_of<'a>(page: &'a str, id: &str) -> &'a str {
    let at = page
        .find(&format!("id=\"{id}\""))
        .unwrap_or_else(|| panic!("no #{id} in {page}"));
    let rest = &page[at..];
    &rest[..rest.find("</section>").unwrap_or(rest.len())]
}

/// A refused upload ends on a page naming the part at fault and the
/// problem's detail, with the form to send it again; an upload that is
/// taken waits for its verdict on its run's page and in the station's
/// list.
#[tokio::test]
async fn a_refused_upload_names_the_part_at_fault_and_offers_the_form_again() {
    // No workers: an accepted upload stays queued.
    let app = spawn_app(0).await;
    let station = app.create_token("station").await;
    let s = app.sign_in(&station).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 6, DataFormat::Csv, "RLG-RF");
    let data = std::fs::read(&run.data).unwrap();
    let mut broken = data.clone();
    broken.truncate(data.len() / 2);
    broken.extend_from_slice(b"\n1.0,not-a-number\n");
    let mut short = data.clone();
    short.truncate(data.len() / 100);
    short.truncate(short.iter().rposition(|&b| b == b'\n').unwrap() + 1);
    let no_unit = br#"{"sample_rate_hz": 100, "format": "csv"}"#.to_vec();
    let cases: [(&str, Vec<u8>, Vec<u8>, &str); 3] = [
        ("data", run.metadata.clone(), broken, "line"),
        (
            "data",
            run.metadata.clone(),
            short,
            "a calibration needs at least 40 s",
        ),
        ("metadata", no_unit, data.clone(), "unit_serial"),
    ];
    for (part, metadata, body, says) in cases {
        let r = s.upload(&s.csrf, &metadata, body).await;
        assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY, "{part}");
        assert!(r.headers()[reqwest::header::CONTENT_TYPE]
            .to_str()
            .unwrap()
            .starts_with("text/html"));
        let page = r.text().await.unwrap();
        let refusal = text_of(&page, "refusal");
        assert!(
            refusal.contains(&format!("data-part=\"{part}\"")),
            "{refusal}"
        );
        let what = if part == "data" {
            "The data file was refused"
        } else {
            "The metadata (run.json) was refused"
        };
        assert!(refusal.contains(what), "{refusal}");
        assert!(
            text_of(&page, "refusal-detail").contains(says),
            "{says}: {page}"
        );
        // The form again, with the session's token, and the way back.
        assert!(
            page.contains(&format!("action=\"/upload?csrf={}\"", s.csrf)),
            "{page}"
        );
        assert!(page.contains("href=\"/upload\""), "{page}");
    }
    // Nothing of them was stored.
    assert_eq!(app.units().await["total"], 0);

    // Taken: its page and the station's list say what the verdict waits
    // for.
    let r = s.upload(&s.csrf, &run.metadata, data).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let page = s.get(location(&r).unwrap()).await.text().await.unwrap();
    assert!(
        text_of(&page, "verdict").contains("calibration queued"),
        "{page}"
    );
    let list = s.get("/upload").await.text().await.unwrap();
    assert!(
        text_of(&list, "uploads").contains("calibration queued"),
        "{list}"
    );
    app.stop().await;
}

/// A station reads the verdict of each of its runs, in words, on the
/// run's page (where the upload form sends it) and in its list of
/// uploads; the unit's page says which model each run used.
#[tokio::test]
async fn stations_see_the_verdict_of_their_runs_in_words() {
    let app = spawn_app_with(1, |c| c.diagnose_inadequate = false).await;
    // A σ bound no run can meet.
    let r = app
        .http
        .post(app.url("/product-types"))
        .bearer_auth(&app.admin)
        .json(
            &serde_json::json!({"name": "TIGHT", "limits": {"gyro_scale_y": {"max_sigma": 1e-9}}}),
        )
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::CREATED);
    let station = app.create_token("station").await;
    let s = app.sign_in(&station).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 7, DataFormat::Csv, "ST-A");
    let data = std::fs::read(&run.data).unwrap();
    let cases = [
        ("ST-A", None, "accepted"),
        ("ST-R", Some("TIGHT"), "rejected"),
        ("ST-N", Some("NO-SUCH-TYPE"), "needs review"),
    ];
    let mut pages = Vec::new();
    for (serial, product, _) in cases {
        let r = s
            .upload(&s.csrf, &metadata_of(&run, serial, product), data.clone())
            .await;
        assert_eq!(r.status(), StatusCode::SEE_OTHER, "{serial}");
        pages.push(location(&r).unwrap().to_string());
    }
    for ((serial, _, word), page) in cases.iter().zip(&pages) {
        let id = page.trim_start_matches("/runs/");
        let job = app.get_run(id).await["job_id"]
            .as_str()
            .unwrap()
            .to_string();
        let done = app.wait_job(&job, CALIBRATION).await;
        assert_eq!(done["state"], "succeeded", "{serial}: {done}");
        let html = s.get(page).await.text().await.unwrap();
        let verdict = text_of(&html, "verdict");
        assert!(
            verdict.contains("Verdict: <span class=\"badge") && verdict.contains(word),
            "{serial}: {verdict}"
        );
    }
    let list = s.get("/upload").await.text().await.unwrap();
    let uploads = text_of(&list, "uploads");
    for ((serial, _, word), page) in cases.iter().zip(&pages) {
        let row = &uploads[uploads
            .find(&page[6..14])
            .unwrap_or_else(|| panic!("{serial}"))..];
        let row = &row[..row.find("</tr>").unwrap()];
        assert!(row.contains(word), "{serial}: {row}");
    }
    // The rejected run's page names the limit it failed.
    let rejected = s.get(&pages[1]).await.text().await.unwrap();
    assert!(text_of(&rejected, "verdict").contains("gyro_scale_y"));

    // The unit's page (an engineer's) says which model the run used, in
    // its history and above the repeatability table's run columns.
    let admin = app.sign_in(&app.admin).await;
    let unit = admin.get("/units/ST-A").await.text().await.unwrap();
    let history = &unit[unit.find("id=\"history\"").unwrap()..];
    assert!(history[..history.find("</table>").unwrap()].contains("base-24"));
    let models = &unit[unit.find("id=\"run-models\"").unwrap()..];
    assert!(
        models[..models.find("</tr>").unwrap()].contains("base-24"),
        "{unit}"
    );
    app.stop().await;
}

/// The admin page's product form sets the line's model; a model the
/// server cannot read is refused naming the field.
#[tokio::test]
async fn the_admin_form_sets_a_product_types_model() {
    let app = spawn_app(0).await;
    let s = app.sign_in(&app.admin).await;
    let form = s.get("/admin").await.text().await.unwrap();
    assert!(form.contains("name=\"model\""), "{form}");
    let save = |model: &'static str| {
        let s = &s;
        async move {
            s.post(
                "/admin/products",
                &[
                    ("name", "LINE-M"),
                    ("description", ""),
                    ("limits", "{}"),
                    ("model", model),
                ],
            )
            .await
        }
    };
    let r = save("base+gyro_scale_asymmetry+tilt").await;
    assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY);
    let page = r.text().await.unwrap();
    assert!(page.contains("model: "), "{page}");
    assert!(page.contains("tilt"), "{page}");
    assert_eq!(
        app.get(&app.admin, "/product-types/LINE-M").await.status(),
        StatusCode::NOT_FOUND
    );
    let r = save(" base+gyro_scale_asymmetry ").await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let read = app.get_json("/product-types/LINE-M").await;
    assert_eq!(read["model"], "base-24+gyro_scale_asymmetry");
    let admin = s.get("/admin").await.text().await.unwrap();
    let products = &admin[admin.find("id=\"products\"").unwrap()..];
    assert!(products.contains("base-24+gyro_scale_asymmetry"), "{admin}");
    // "Change" opens the form on the product's current values, model too.
    assert!(
        products.contains("href=\"/admin?edit=LINE-M#product\""),
        "{admin}"
    );
    let edit = s.get("/admin?edit=LINE-M").await.text().await.unwrap();
    let form = &edit[edit.find("id=\"product\"").unwrap()..];
    assert!(form.contains("value=\"LINE-M\""), "{form}");
    assert!(
        form.contains("value=\"base-24+gyro_scale_asymmetry\""),
        "{form}"
    );
    // Saved again with the model left empty: the server's.
    let r = save("").await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let read = app.get_json("/product-types/LINE-M").await;
    assert_eq!(read["model"], serde_json::Value::Null);
    assert_eq!(read["revision"], 2);
    app.stop().await;
}

/// A form upload whose declared body is over the server's limit is refused
/// before a byte of it is read (so the test speaks HTTP by hand), still as
/// a page naming the data file and the limit, with the way back.
#[tokio::test]
async fn an_upload_over_the_body_limit_is_refused_as_a_page() {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let app = spawn_app_with(0, |c| c.max_body_bytes = 1 << 20).await;
    let station = app.create_token("station").await;
    let s = app.sign_in(&station).await;
    let addr = s.origin.trim_start_matches("http://").to_string();
    let head = format!(
        "POST /upload?csrf={} HTTP/1.1\r\nHost: {addr}\r\nCookie: {}\r\n\
         Content-Type: multipart/form-data; boundary=xyz\r\nContent-Length: {}\r\n\r\n",
        s.csrf,
        s.cookie,
        4u64 << 20
    );
    let mut tcp = tokio::net::TcpStream::connect(&addr).await.unwrap();
    tcp.write_all(head.as_bytes()).await.unwrap();
    let mut reply = Vec::new();
    let _ = tokio::time::timeout(Duration::from_secs(5), tcp.read_to_end(&mut reply)).await;
    let reply = String::from_utf8_lossy(&reply);
    assert!(reply.starts_with("HTTP/1.1 413"), "{reply}");
    assert!(reply.contains("content-type: text/html"), "{reply}");
    assert!(reply.contains("data-part=\"data\""), "{reply}");
    assert!(
        text_of(&reply, "refusal-detail").contains("exceeds the limit of 1048576 bytes"),
        "{reply}"
    );
    assert!(reply.contains("href=\"/upload\""), "{reply}");
    app.stop().await;
}
