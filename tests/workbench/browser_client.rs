//! The browser client of `tests/suite/common/browser.rs`, checked against a small
//! page server started here: a form with a file upload, the console,
//! an HttpOnly cookie, screenshots, and that no browser process outlives
//! the client. One browser for all of it: Chromium's start is the cost.

use std::time::Duration;

use crate::common::browser::{self, Browser};
use axum::extract::Multipart;
use axum::http::header;
use axum::response::{Html, IntoResponse};
use axum::routing::{get, post};
use axum::Router;

const WAIT: Duration = Duration::from_secs(10);

// An empty icon: without it Chromium asks for /favicon.ico, and what a
// page logs would depend on how that 404 is reported.
const HEAD: &str = r#"<meta charset="utf-8"><link rel="icon" href="data:,">"#;

fn page(title: &str, body: &str) -> Html<String> {
    Html(format!(
        "<!doctype html><html><head>{HEAD}<title>{title}</title></head><body>{body}</body></html>"
    ))
}

async fn form() -> Html<String> {
    page(
        "Form",
        r#"<form method="post" action="/submit" enctype="multipart/form-data">
             <input type="text" name="name" id="name">
             <select name="colour" id="colour">
               <option value="red">Red</option><option value="green">Green</option>
             </select>
             <input type="file" name="upload" id="upload">
             <button type="submit" id="go">Send</button>
           </form>
           <script>
             // content that arrives after the load event, for wait_for
             setTimeout(() => {
               const p = document.createElement("p");
               p.id = "late"; p.textContent = "scripts ran";
               document.body.append(p);
             }, 300);
           </script>"#,
    )
}

/// Echoes the form's fields; for a file, its name and byte count.
async fn submit(mut form: Multipart) -> Html<String> {
    let mut rows = String::new();
    while let Some(field) = form.next_field().await.expect("multipart") {
        let name = field.name().unwrap_or("").to_string();
        let file = field.file_name().map(str::to_string);
        let bytes = field.bytes().await.expect("field bytes");
        let shown = match file {
            Some(f) => format!("{f}: {} bytes", bytes.len()),
            None => String::from_utf8_lossy(&bytes).into_owned(),
        };
        rows.push_str(&format!(r#"<li id="echo-{name}">{shown}</li>"#));
    }
    page("Received", &format!("<ul>{rows}</ul>"))
}

async fn set_cookie() -> impl IntoResponse {
    (
        [(
            header::SET_COOKIE,
            "sid=s3cret; Path=/; HttpOnly; SameSite=Strict",
        )],
        page("Cookie", "<p>set</p>"),
    )
}

async fn serve() -> String {
    let app = Router::new()
        .route("/form", get(form))
        .route("/submit", post(submit))
        .route("/cookie", get(set_cookie))
        .route(
            "/boom",
            // a console error and a failed resource load
            get(|| async {
                page(
                    "Boom",
                    r#"<img src="/missing.png"><script>console.error("boom")</script>"#,
                )
            }),
        )
        .route("/clean", get(|| async { page("Clean", "<p>fine</p>") }))
        .route(
            "/tall",
            get(|| async { page("Tall", r#"<div style="height:3000px">top</div><p>end</p>"#) }),
        );
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    tokio::spawn(async move { axum::serve(listener, app).await.unwrap() });
    format!("http://{addr}")
}

/// Width and height from a PNG's IHDR chunk.
fn png_size(png: &[u8]) -> (u32, u32) {
    let be = |i: usize| u32::from_be_bytes(png[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

/// Processes whose command line names `needle` (the browser's folder:
/// chromedriver's log, Chromium's profile, its crash handlers' database).
fn processes_naming(needle: &str) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        if let Ok(cmd) = std::fs::read(entry.path().join("cmdline")) {
            let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
            if cmd.contains(needle) {
                found.push(format!("{}: {cmd}", entry.file_name().to_string_lossy()));
            }
        }
    }
    found
}

#[tokio::test]
async fn drives_forms_console_cookies_and_screenshots() {
    let base = serve().await;
    let b = Browser::start().await;
    let work_dir = b.work_dir().display().to_string();
    assert!(
        processes_naming(&work_dir).len() >= 2,
        "chromedriver and Chromium run"
    );

    // form: text, select, file; submit; read the server's echo
    b.goto(&format!("{base}/form")).await;
    assert_eq!(b.title().await, "Form");
    assert!(b.current_url().await.ends_with("/form"));
    assert_eq!(b.wait_for("#late", WAIT).await.text().await, "scripts ran");
    let name = b.find("#name").await;
    name.send_keys("typed, then cleared").await;
    name.clear().await;
    name.send_keys("Ada Lovelace").await;
    assert_eq!(name.property("value").await, "Ada Lovelace");
    assert_eq!(name.attr("name").await.as_deref(), Some("name"));
    assert_eq!(name.attr("placeholder").await, None);
    b.find("#colour").await.select_by_value("green").await;
    let upload = tempfile::Builder::new().suffix(".dat").tempfile().unwrap();
    std::fs::write(upload.path(), vec![7u8; 12_345]).unwrap();
    b.find("#upload").await.upload(upload.path()).await;
    b.screenshot(browser::screenshot_path("browser_client_form.png"))
        .await;
    b.find("#go").await.click().await;
    let file_name = upload.path().file_name().unwrap().to_str().unwrap();
    b.wait_for_text("#echo-upload", "12345 bytes", WAIT).await;
    assert_eq!(b.find("#echo-name").await.text().await, "Ada Lovelace");
    assert_eq!(b.find("#echo-colour").await.text().await, "green");
    assert_eq!(
        b.find("#echo-upload").await.text().await,
        format!("{file_name}: 12345 bytes")
    );
    assert!(b.find_all("form").await.is_empty());
    assert!(b.page_source().await.contains("echo-name"));

    // console: an error and a failed load are reported once; a clean page
    // reports nothing
    b.goto(&format!("{base}/boom")).await;
    let errors = b.console_errors().await;
    assert!(
        errors.iter().any(|e| e.contains("\"boom\"")),
        "console.error reported: {errors:?}"
    );
    assert!(
        errors.iter().any(|e| e.contains("missing.png")),
        "failed load reported: {errors:?}"
    );
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert!(b.console_errors().await.is_empty(), "each entry once");
    b.goto(&format!("{base}/clean")).await;
    assert_eq!(b.console_errors().await, Vec::<String>::new());

    // cookie: HttpOnly (scripts cannot read it) and Strict
    b.goto(&format!("{base}/cookie")).await;
    let sid = b.cookie("sid").await.expect("sid cookie set");
    assert_eq!(sid.value, "s3cret");
    assert!(sid.http_only);
    assert!(!sid.secure);
    assert_eq!(sid.same_site.as_deref(), Some("Strict"));
    assert_eq!(b.execute("return document.cookie", vec![]).await, "");
    b.delete_all_cookies().await;
    assert!(b.cookies().await.is_empty());

    // script arguments, elements included
    let p = b.find("p").await;
    let tag = b
        .execute(
            "return arguments[0].tagName + arguments[1]",
            vec![p.to_arg(), 42.into()],
        )
        .await;
    assert_eq!(tag, "P42");

    // screenshots: the viewport, then the whole 3000 px page
    let shot = browser::screenshot_path("browser_client_form.png");
    let png = std::fs::read(&shot).unwrap();
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"));
    let (w, h) = png_size(&png);
    assert!(w >= 1000 && (1000..=1600).contains(&h), "viewport {w}x{h}");
    b.goto(&format!("{base}/tall")).await;
    let full = browser::screenshot_path("browser_client_tall.png");
    b.full_page_screenshot(&full).await;
    let (fw, fh) = png_size(&std::fs::read(&full).unwrap());
    // the content's width: the viewport's less a scrollbar, if one shows
    assert!(
        fh > 3000 && fw <= w && fw + 20 >= w,
        "full page {fw}x{fh}, viewport {w}x{h}"
    );

    // dropping the client ends chromedriver and every Chromium process
    drop(b);
    let deadline = std::time::Instant::now() + WAIT;
    loop {
        let left = processes_naming(&work_dir);
        if left.is_empty() {
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "left running: {left:?}"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

#[test]
fn missing_browser_names_the_packages() {
    let err = browser::locate(
        "SINSCAL_TEST_NO_SUCH_VARIABLE",
        "/nonexistent/chromedriver",
        "sinscal-no-such-binary",
    )
    .unwrap_err();
    assert!(err.contains("chromium-driver"), "{err}");
}
