//! A headless Chromium driven over W3C WebDriver (chromedriver), for tests
//! of the server's HTML pages: forms, cookies, scripts, screenshots and the
//! browser console, as a user's browser sees them.
//!
//! Needs Debian's `chromium` and `chromium-driver` (`.ci/run` installs
//! them); `CHROMIUM` and `CHROMEDRIVER` override their paths. Without them
//! `Browser::start` panics rather than skipping, so a browser test cannot
//! pass by not running.
//!
//! Every call panics with the WebDriver error, and for element look-ups the
//! selector and the page's URL: the tests are the only users and a panic
//! names the failing step.
//!
//! File uploads: `Element::send_keys` with an absolute path on an
//! `<input type=file>` selects that file (chromedriver reads it from the
//! local disk; several files are joined with '\n'); `Element::upload`
//! makes the path absolute and checks the file exists first.

use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use base64::Engine as _;
use reqwest::Method;
use serde_json::{json, Value};

/// The key under which W3C WebDriver names an element in JSON.
const ELEMENT_KEY: &str = "element-6066-11e4-a52e-4f735466cecf";

/// WebDriver's key codes, for `send_keys`.
pub const ENTER: &str = "\u{E007}";
pub const TAB: &str = "\u{E004}";

const INSTALL_HINT: &str = "install Debian's `chromium` and `chromium-driver` \
     (apt-get install -y --no-install-recommends chromium chromium-driver; .ci/run does this)";

/// A WebDriver error, kept apart from the panic so that polling can tell
/// "not there yet" from a real failure.
#[derive(Debug)]
struct WdError {
    error: String,
    message: String,
}

impl std::fmt::Display for WdError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // chromedriver's messages carry a stack trace after the first line
        let first = self.message.lines().next().unwrap_or("");
        write!(f, "{}: {}", self.error, first)
    }
}

/// The HTTP side of one WebDriver session, shared by the browser and its
/// elements.
#[derive(Clone)]
struct Driver {
    http: reqwest::Client,
    /// `http://127.0.0.1:PORT/session/ID`
    session: String,
}

impl Driver {
    async fn call(
        &self,
        method: Method,
        path: &str,
        body: Option<Value>,
    ) -> Result<Value, WdError> {
        let url = format!("{}{}", self.session, path);
        let mut req = self.http.request(method.clone(), &url);
        if let Some(body) = body {
            req = req.json(&body);
        }
        let resp = req.send().await.map_err(|e| WdError {
            error: "http".into(),
            message: format!("{method} {url}: {e}"),
        })?;
        let status = resp.status();
        let text = resp.text().await.unwrap_or_default();
        let v: Value = serde_json::from_str(&text).map_err(|_| WdError {
            error: format!("http {status}"),
            message: format!("{method} {path}: not JSON: {text}"),
        })?;
        let value = v.get("value").cloned().unwrap_or(Value::Null);
        // W3C errors come with a 4xx/5xx status; a 200's value is data
        // (a script may well return an object with an `error` field)
        if !status.is_success() {
            return Err(WdError {
                error: value["error"]
                    .as_str()
                    .unwrap_or("unknown error")
                    .to_string(),
                message: value["message"].as_str().unwrap_or(&text).to_string(),
            });
        }
        Ok(value)
    }

    async fn get(&self, path: &str) -> Value {
        self.call(Method::GET, path, None)
            .await
            .unwrap_or_else(|e| panic!("WebDriver GET {path}: {e}"))
    }

    async fn post(&self, path: &str, body: Value) -> Value {
        self.call(Method::POST, path, Some(body))
            .await
            .unwrap_or_else(|e| panic!("WebDriver POST {path}: {e}"))
    }

    async fn url(&self) -> String {
        // for error messages: never panic while building one
        match self.call(Method::GET, "/url", None).await {
            Ok(v) => v.as_str().unwrap_or("?").to_string(),
            Err(e) => format!("<url unknown: {e}>"),
        }
    }

    async fn execute(&self, script: &str, args: Vec<Value>) -> Result<Value, WdError> {
        self.call(
            Method::POST,
            "/execute/sync",
            Some(json!({ "script": script, "args": args })),
        )
        .await
    }

    /// Elements matching `css` under `under` (an element id) or the page.
    async fn find_all(&self, under: Option<&str>, css: &str) -> Result<Vec<Element>, WdError> {
        let path = match under {
            Some(id) => format!("/element/{id}/elements"),
            None => "/elements".to_string(),
        };
        let body = json!({ "using": "css selector", "value": css });
        let found = self.call(Method::POST, &path, Some(body)).await?;
        Ok(found
            .as_array()
            .map(|a| a.as_slice())
            .unwrap_or(&[])
            .iter()
            .filter_map(|e| e[ELEMENT_KEY].as_str())
            .map(|id| Element {
                driver: self.clone(),
                id: id.to_string(),
                css: css.to_string(),
            })
            .collect())
    }
}

/// One headless Chromium behind its own chromedriver. Dropping it (or
/// `quit`) ends both; no process outlives it.
pub struct Browser {
    driver: Driver,
    /// chromedriver, leader of a process group that Chromium joins
    process: Option<Child>,
    /// Chromium's profile and chromedriver's log
    dir: tempfile::TempDir,
}

/// A cookie as the browser holds it.
#[derive(Debug, Clone, PartialEq)]
pub struct Cookie {
    pub name: String,
    pub value: String,
    pub path: String,
    pub http_only: bool,
    pub secure: bool,
    /// "Strict", "Lax" or "None" as the browser reports it
    pub same_site: Option<String>,
}

impl Browser {
    /// Starts chromedriver on a free port and opens a headless session.
    /// Panics, naming the packages to install, if either binary is missing.
    pub async fn start() -> Browser {
        let chromedriver = locate("CHROMEDRIVER", "/usr/bin/chromedriver", "chromedriver")
            .unwrap_or_else(|e| panic!("{e}"));
        let chromium =
            locate("CHROMIUM", "/usr/bin/chromium", "chromium").unwrap_or_else(|e| panic!("{e}"));
        let dir = tempfile::tempdir().expect("temp dir for the browser profile");
        let http = reqwest::Client::builder()
            // a proxy from the environment must not see localhost traffic
            .no_proxy()
            // above the page-load and script timeouts set below, so those
            // report first, with chromedriver's message
            .timeout(Duration::from_secs(90))
            .build()
            .expect("http client");

        // The port is free when asked but may be taken before chromedriver
        // binds it: try a few.
        let mut last_err = String::new();
        for _ in 0..3 {
            let port = free_port();
            let log = dir.path().join("chromedriver.log");
            let mut child = Command::new(&chromedriver)
                .arg(format!("--port={port}"))
                .arg(format!("--log-path={}", log.display()))
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                // Chromium's crash handlers leave the process group (they
                // exit with the browser); this keeps their database, named
                // on their command line, in the folder instead of $HOME.
                // (--disable-crashpad-for-testing would stop them, but with
                // it chromedriver 148 leaves navigations on the new-tab page.)
                .env("XDG_CONFIG_HOME", dir.path().join("config"))
                .env("XDG_CACHE_HOME", dir.path().join("cache"))
                // its own group, so that ending it can end Chromium's
                // processes too (they inherit the group)
                .process_group(0)
                .spawn()
                .unwrap_or_else(|e| {
                    panic!("cannot run {}: {e}; {INSTALL_HINT}", chromedriver.display())
                });
            let base = format!("http://127.0.0.1:{port}");
            match wait_ready(&http, &base, &mut child).await {
                Ok(()) => {
                    let mut browser = Browser {
                        driver: Driver {
                            http,
                            session: String::new(),
                        },
                        process: Some(child),
                        dir,
                    };
                    browser.new_session(&base, &chromium).await;
                    return browser;
                }
                Err(e) => {
                    last_err = format!("{e}; log: {}", tail(&log));
                    kill_group(&mut child);
                }
            }
        }
        panic!("chromedriver did not start: {last_err}");
    }

    async fn new_session(&mut self, base: &str, chromium: &Path) {
        let profile = self.dir.path().join("profile");
        let args = [
            "--headless=new".to_string(),
            "--no-sandbox".into(),
            "--disable-gpu".into(),
            "--disable-quic".into(),
            "--no-first-run".into(),
            "--disable-background-networking".into(),
            "--disable-component-update".into(),
            "--disable-sync".into(),
            "--disable-dev-shm-usage".into(),
            "--window-size=1280,1600".into(),
            format!("--user-data-dir={}", profile.display()),
        ];
        let caps = json!({ "capabilities": { "alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": { "binary": chromium, "args": args },
            "goog:loggingPrefs": { "browser": "ALL" },
            // a hung page fails the test in seconds, not chromedriver's 300 s
            "timeouts": { "pageLoad": 30_000, "script": 30_000, "implicit": 0 },
        }}});
        let resp = self
            .driver
            .http
            .post(format!("{base}/session"))
            .json(&caps)
            .send()
            .await
            .unwrap_or_else(|e| panic!("WebDriver new session: {e}"));
        let v: Value = resp.json().await.expect("new session: JSON");
        let Some(id) = v["value"]["sessionId"].as_str() else {
            panic!(
                "chromedriver could not start {}: {}: {}; {INSTALL_HINT}\nchromedriver's log ends:\n{}",
                chromium.display(),
                v["value"]["error"].as_str().unwrap_or("?"),
                v["value"]["message"].as_str().unwrap_or(""),
                tail(&self.dir.path().join("chromedriver.log")),
            );
        };
        self.driver.session = format!("{base}/session/{id}");
    }

    /// Ends the session (Chromium closes its profile cleanly), then
    /// chromedriver.
    pub async fn quit(mut self) {
        let _ = self.driver.call(Method::DELETE, "", None).await;
        if let Some(mut child) = self.process.take() {
            kill_group(&mut child);
        }
    }

    /// The folder with Chromium's profile and chromedriver's log; every
    /// process of this browser names it on its command line.
    pub fn work_dir(&self) -> &Path {
        self.dir.path()
    }

    /// Opens `url` and waits for its load event.
    pub async fn goto(&self, url: &str) {
        self.driver.post("/url", json!({ "url": url })).await;
    }

    pub async fn current_url(&self) -> String {
        self.driver
            .get("/url")
            .await
            .as_str()
            .unwrap_or("")
            .to_string()
    }

    pub async fn title(&self) -> String {
        self.driver
            .get("/title")
            .await
            .as_str()
            .unwrap_or("")
            .to_string()
    }

    /// The DOM as it is now, serialised (not the bytes the server sent).
    pub async fn page_source(&self) -> String {
        self.driver
            .get("/source")
            .await
            .as_str()
            .unwrap_or("")
            .to_string()
    }

    /// The first element matching `css`; panics if there is none.
    pub async fn find(&self, css: &str) -> Element {
        match self.driver.find_all(None, css).await {
            Ok(mut v) if !v.is_empty() => v.swap_remove(0),
            Ok(_) => panic!("no element matches `{css}` on {}", self.driver.url().await),
            Err(e) => panic!("find `{css}` on {}: {e}", self.driver.url().await),
        }
    }

    /// Every element matching `css`, in document order (none is not an
    /// error: this is how a test checks absence).
    pub async fn find_all(&self, css: &str) -> Vec<Element> {
        match self.driver.find_all(None, css).await {
            Ok(v) => v,
            Err(e) => panic!("find all `{css}` on {}: {e}", self.driver.url().await),
        }
    }

    /// Polls until an element matches `css` (for content a script adds).
    pub async fn wait_for(&self, css: &str, timeout: Duration) -> Element {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(e) = self.find_all(css).await.into_iter().next() {
                return e;
            }
            if Instant::now() >= deadline {
                panic!(
                    "no element matched `{css}` within {timeout:?} on {}",
                    self.driver.url().await
                );
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// Polls until an element matching `css` has `needle` in its text, and
    /// returns it. Elements replaced while being read (an htmx swap) are
    /// read again on the next round.
    pub async fn wait_for_text(&self, css: &str, needle: &str, timeout: Duration) -> Element {
        let deadline = Instant::now() + timeout;
        let mut seen = Vec::new();
        loop {
            seen.clear();
            for e in self.find_all(css).await {
                match e.try_text().await {
                    Ok(t) if t.contains(needle) => return e,
                    Ok(t) => seen.push(t),
                    // Swapped out (htmx) or the page moved on between the
                    // find and the read: chromedriver says either, by
                    // timing. The next round finds the new element.
                    Err(err) if gone(&err) => {}
                    Err(err) => panic!("text of `{css}`: {err}"),
                }
            }
            if Instant::now() >= deadline {
                panic!(
                    "no `{css}` contained {needle:?} within {timeout:?} on {}; texts: {seen:?}",
                    self.driver.url().await
                );
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// Runs `script` as a function body in the page (`arguments[i]` are
    /// `args`; pass an element as `el.to_arg()`), returning what it returns.
    pub async fn execute(&self, script: &str, args: Vec<Value>) -> Value {
        self.driver
            .execute(script, args)
            .await
            .unwrap_or_else(|e| panic!("script failed: {e}\n{script}"))
    }

    pub async fn cookies(&self) -> Vec<Cookie> {
        let all = self.driver.get("/cookie").await;
        all.as_array()
            .map(|a| a.as_slice())
            .unwrap_or(&[])
            .iter()
            .map(|c| Cookie {
                name: c["name"].as_str().unwrap_or("").to_string(),
                value: c["value"].as_str().unwrap_or("").to_string(),
                path: c["path"].as_str().unwrap_or("").to_string(),
                http_only: c["httpOnly"].as_bool().unwrap_or(false),
                secure: c["secure"].as_bool().unwrap_or(false),
                same_site: c["sameSite"].as_str().map(str::to_string),
            })
            .collect()
    }

    /// The cookie named `name`, if the browser holds one for this page.
    pub async fn cookie(&self, name: &str) -> Option<Cookie> {
        self.cookies().await.into_iter().find(|c| c.name == name)
    }

    /// Deletes the cookies visible to the current page's domain.
    pub async fn delete_all_cookies(&self) {
        self.driver
            .call(Method::DELETE, "/cookie", None)
            .await
            .unwrap_or_else(|e| panic!("delete cookies: {e}"));
    }

    /// The console's SEVERE entries since the last call (or the session's
    /// start): `console.error`, uncaught exceptions and failed loads of
    /// resources (a 404 image or script), each as "url line:col message".
    /// chromedriver's log endpoint hands each entry out once.
    ///
    /// Entries reach chromedriver after the command that caused them may
    /// have returned (a `goto` can return before its page's
    /// `console.error` is in the log), so this logs a marker in the page
    /// and reads until the marker arrives: whatever the page logged before
    /// it has arrived too.
    pub async fn console_errors(&self) -> Vec<String> {
        static MARKS: AtomicU64 = AtomicU64::new(0);
        let mark = format!(
            "console-errors-mark-{}-{}",
            std::process::id(),
            MARKS.fetch_add(1, Ordering::Relaxed)
        );
        // a page that cannot run scripts (an error page) gets a plain read
        let marked = self
            .driver
            .execute("console.info(arguments[0])", vec![json!(mark)])
            .await
            .is_ok();
        let deadline = Instant::now() + Duration::from_secs(5);
        let mut errors = Vec::new();
        loop {
            let entries = self
                .driver
                .post("/se/log", json!({ "type": "browser" }))
                .await;
            let mut arrived = !marked;
            for e in entries.as_array().map(|a| a.as_slice()).unwrap_or(&[]) {
                let message = e["message"].as_str().unwrap_or("");
                if message.contains(&mark) {
                    arrived = true;
                } else if e["level"] == "SEVERE" {
                    errors.push(message.to_string());
                }
            }
            if arrived {
                return errors;
            }
            if Instant::now() >= deadline {
                panic!("the console's log lags over 5 s (marker not seen); so far: {errors:?}");
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    /// Sets the window's outer size. The viewport is shorter by the
    /// toolbars headless Chromium still reserves (139 px on 148: the
    /// default 1280x1600 window has a 1280x1461 viewport).
    pub async fn set_window_size(&self, width: u32, height: u32) {
        self.driver
            .post("/window/rect", json!({ "width": width, "height": height }))
            .await;
    }

    /// A PNG of the viewport, written to `path` (its folder is created).
    pub async fn screenshot(&self, path: impl AsRef<Path>) {
        let b64 = self.driver.get("/screenshot").await;
        write_png(path.as_ref(), b64.as_str().unwrap_or(""));
    }

    /// A PNG of the whole page, past the viewport. WebDriver has no such
    /// command for Chromium; chromedriver forwards DevTools commands, and
    /// `Page.captureScreenshot` can capture beyond the viewport.
    pub async fn full_page_screenshot(&self, path: impl AsRef<Path>) {
        let (w, h) = self.content_size().await;
        let shot = self
            .cdp(
                "Page.captureScreenshot",
                json!({
                    "format": "png",
                    "captureBeyondViewport": true,
                    "clip": { "x": 0, "y": 0, "width": w, "height": h, "scale": 1 },
                }),
            )
            .await;
        write_png(path.as_ref(), shot["data"].as_str().unwrap_or(""));
    }

    /// The page's content size in CSS pixels, once it has one: on a loaded
    /// machine a page just navigated to can report 0 × 0 for a moment
    /// (layout not yet run), and Chromium refuses a capture of 0 width.
    async fn content_size(&self) -> (f64, f64) {
        for _ in 0..100 {
            let metrics = self.cdp("Page.getLayoutMetrics", json!({})).await;
            let size = &metrics["cssContentSize"];
            let (w, h) = (
                size["width"].as_f64().unwrap_or(0.0).ceil(),
                size["height"].as_f64().unwrap_or(0.0).ceil(),
            );
            if w > 0.0 && h > 0.0 {
                return (w, h);
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        panic!("the page has no layout after 5 s (content size 0)");
    }

    /// A Chrome DevTools Protocol command, through chromedriver.
    pub async fn cdp(&self, cmd: &str, params: Value) -> Value {
        self.driver
            .post("/goog/cdp/execute", json!({ "cmd": cmd, "params": params }))
            .await
    }
}

/// Whether a WebDriver error says the element is no longer in the page.
fn gone(err: &WdError) -> bool {
    matches!(
        err.error.as_str(),
        "stale element reference" | "no such element"
    )
}

impl Drop for Browser {
    /// Drop cannot wait for the session's end over HTTP, so it kills
    /// chromedriver's group outright; the profile folder goes after.
    fn drop(&mut self) {
        if let Some(mut child) = self.process.take() {
            kill_group(&mut child);
        }
    }
}

/// `target/screenshots/<name>` under the crate, its folder created.
pub fn screenshot_path(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/screenshots");
    std::fs::create_dir_all(&dir).expect("create target/screenshots");
    dir.join(name)
}

/// An element of the page, found by `css`.
#[derive(Clone)]
pub struct Element {
    driver: Driver,
    id: String,
    /// the selector it was found by, for messages
    css: String,
}

impl std::fmt::Debug for Element {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Element({})", self.css)
    }
}

impl Element {
    /// The element as a script argument for `Browser::execute`.
    pub fn to_arg(&self) -> Value {
        json!({ ELEMENT_KEY: self.id })
    }

    async fn post(&self, what: &str, body: Value) -> Value {
        let path = format!("/element/{}/{what}", self.id);
        match self.driver.call(Method::POST, &path, Some(body)).await {
            Ok(v) => v,
            Err(e) => panic!(
                "{what} on `{}` at {}: {e}",
                self.css,
                self.driver.url().await
            ),
        }
    }

    async fn get(&self, what: &str) -> Value {
        match self.try_get(what).await {
            Ok(v) => v,
            Err(e) => panic!(
                "{what} of `{}` at {}: {e}",
                self.css,
                self.driver.url().await
            ),
        }
    }

    async fn try_get(&self, what: &str) -> Result<Value, WdError> {
        let path = format!("/element/{}/{what}", self.id);
        self.driver.call(Method::GET, &path, None).await
    }

    /// Scrolls the element into view and clicks its centre; fails if
    /// another element covers it. A click that submits a form returns once
    /// the next page has loaded.
    pub async fn click(&self) {
        self.post("click", json!({})).await;
    }

    /// Types `text` (see `ENTER`, `TAB` for keys). On `<input type=file>`
    /// `text` is an absolute path of a file to select.
    pub async fn send_keys(&self, text: &str) {
        self.post("value", json!({ "text": text })).await;
    }

    /// Selects the file at `path` in an `<input type=file>`.
    pub async fn upload(&self, path: impl AsRef<Path>) {
        let path = path.as_ref();
        let abs = std::fs::canonicalize(path)
            .unwrap_or_else(|e| panic!("file to upload {}: {e}", path.display()));
        self.send_keys(abs.to_str().expect("UTF-8 path")).await;
    }

    pub async fn clear(&self) {
        self.post("clear", json!({})).await;
    }

    /// The rendered text, as a user sees it (hidden parts left out).
    pub async fn text(&self) -> String {
        self.get("text").await.as_str().unwrap_or("").to_string()
    }

    async fn try_text(&self) -> Result<String, WdError> {
        Ok(self
            .try_get("text")
            .await?
            .as_str()
            .unwrap_or("")
            .to_string())
    }

    /// The HTML attribute `name` as written in the markup, if present.
    pub async fn attr(&self, name: &str) -> Option<String> {
        self.get(&format!("attribute/{name}"))
            .await
            .as_str()
            .map(str::to_string)
    }

    /// The DOM property `name` (`value`, `checked`, ...) as it is now.
    pub async fn property(&self, name: &str) -> Value {
        self.get(&format!("property/{name}")).await
    }

    /// Chooses the `<option>` with `value` in this `<select>` and fires
    /// `input` and `change` as a user's choice would (htmx listens for
    /// them). Panics listing the options when none has that value.
    pub async fn select_by_value(&self, value: &str) {
        let script = "const [sel, v] = arguments;
            const opt = Array.from(sel.options || []).find(o => o.value === v);
            if (!opt) return Array.from(sel.options || []).map(o => o.value);
            opt.selected = true;
            sel.dispatchEvent(new Event('input', { bubbles: true }));
            sel.dispatchEvent(new Event('change', { bubbles: true }));
            return null;";
        let r = self
            .driver
            .execute(script, vec![self.to_arg(), json!(value)])
            .await
            .unwrap_or_else(|e| panic!("select {value:?} in `{}`: {e}", self.css));
        if !r.is_null() {
            panic!("`{}` has no option {value:?}; options: {r}", self.css);
        }
    }

    /// Every element under this one matching `css`, in document order.
    pub async fn find_all(&self, css: &str) -> Vec<Element> {
        match self.driver.find_all(Some(&self.id), css).await {
            Ok(v) => v,
            Err(e) => panic!("find all `{css}` inside `{}`: {e}", self.css),
        }
    }

    /// The first element under this one matching `css`.
    pub async fn find(&self, css: &str) -> Element {
        match self.driver.find_all(Some(&self.id), css).await {
            Ok(mut v) if !v.is_empty() => v.swap_remove(0),
            Ok(_) => panic!(
                "no element matches `{css}` inside `{}` on {}",
                self.css,
                self.driver.url().await
            ),
            Err(e) => panic!("find `{css}` inside `{}`: {e}", self.css),
        }
    }
}

/// The binary from `env_var`, else `default` if it exists, else `name` on
/// PATH.
pub fn locate(env_var: &str, default: &str, name: &str) -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os(env_var) {
        let p = PathBuf::from(p);
        return if p.is_file() {
            Ok(p)
        } else {
            Err(format!(
                "{env_var}={} is not a file; {INSTALL_HINT}",
                p.display()
            ))
        };
    }
    let default = PathBuf::from(default);
    if default.is_file() {
        return Ok(default);
    }
    std::env::var_os("PATH")
        .iter()
        .flat_map(std::env::split_paths)
        .map(|d| d.join(name))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            format!(
                "{name} not found ({env_var} unset, no {}, none on PATH); {INSTALL_HINT}",
                default.display()
            )
        })
}

/// A localhost port nobody listens on now.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

/// Polls chromedriver's `/status` until it is ready for a session.
async fn wait_ready(http: &reqwest::Client, base: &str, child: &mut Child) -> Result<(), String> {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        if let Ok(Some(status)) = child.try_wait() {
            return Err(format!("chromedriver exited at start ({status})"));
        }
        if let Ok(r) = http.get(format!("{base}/status")).send().await {
            if let Ok(v) = r.json::<Value>().await {
                if v["value"]["ready"] == true {
                    return Ok(());
                }
            }
        }
        if Instant::now() >= deadline {
            return Err("chromedriver not ready within 20 s".into());
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Kills chromedriver's process group (chromedriver and every Chromium
/// process it started) and reaps chromedriver.
fn kill_group(child: &mut Child) {
    let pgid = child.id() as libc::pid_t;
    // SAFETY: signals a process group this module created and owns.
    unsafe {
        libc::kill(-pgid, libc::SIGKILL);
    }
    let _ = child.wait();
}

fn write_png(path: &Path, b64: &str) {
    let png = base64::engine::general_purpose::STANDARD
        .decode(b64)
        .unwrap_or_else(|e| panic!("screenshot is not base64: {e}"));
    assert!(
        png.starts_with(b"\x89PNG\r\n\x1a\n"),
        "screenshot is not a PNG"
    );
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).expect("screenshot folder");
    }
    std::fs::write(path, png).unwrap_or_else(|e| panic!("write {}: {e}", path.display()));
}

/// The last lines of a log file, for a start-up failure's message.
fn tail(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(10)..].join("\n")
}
