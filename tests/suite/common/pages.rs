//! The pages as a browser without JavaScript sees them: a signed-in
//! session's cookie and CSRF token, requests that do not follow redirects
//! (so a test sees the 303 itself), and forms posted as browsers post them.

use reqwest::header::{COOKIE, LOCATION, SET_COOKIE};
use reqwest::{Response, StatusCode};

use super::TestApp;

/// A client that reports redirects instead of following them.
pub fn no_redirects() -> reqwest::Client {
    reqwest::Client::builder()
        .redirect(reqwest::redirect::Policy::none())
        .build()
        .unwrap()
}

/// A `Set-Cookie` header's `name=value` and its attributes.
pub fn set_cookie<'a>(r: &'a Response, name: &str) -> Option<&'a str> {
    r.headers()
        .get_all(SET_COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .find(|v| v.starts_with(&format!("{name}=")))
}

/// The value of `name="csrf" value="…"` (or of `?csrf=`) in a page.
pub fn csrf_in(html: &str) -> Option<String> {
    let at = html
        .find("name=\"csrf\" value=\"")
        .map(|i| i + "name=\"csrf\" value=\"".len())
        .or_else(|| html.find("?csrf=").map(|i| i + "?csrf=".len()))?;
    Some(
        html[at..]
            .chars()
            .take_while(|c| c.is_ascii_hexdigit())
            .collect(),
    )
}

pub fn location(r: &Response) -> Option<&str> {
    r.headers().get(LOCATION).and_then(|v| v.to_str().ok())
}

/// A signed-in browser session.
pub struct PageSession {
    pub origin: String,
    pub cookie: String,
    pub csrf: String,
    pub http: reqwest::Client,
}

impl TestApp {
    /// `http://host:port`, where the pages are.
    pub fn origin(&self) -> String {
        self.base.trim_end_matches("/api/v1").to_string()
    }

    /// Posts the sign-in form with `token` as a browser does: the form's
    /// own cookie and token first, then the form; `tls` as behind a TLS
    /// proxy. The answer to the post.
    pub async fn sign_in_form(&self, token: &str, tls: bool) -> Response {
        let http = no_redirects();
        let origin = self.origin();
        let proto = if tls { "https" } else { "http" };
        let form = http
            .get(format!("{origin}/signin"))
            .header("x-forwarded-proto", proto)
            .send()
            .await
            .unwrap();
        assert_eq!(form.status(), StatusCode::OK);
        let form_cookie = set_cookie(&form, "sinscal_signin")
            .expect("the sign-in form sets its cookie")
            .split(';')
            .next()
            .unwrap()
            .to_string();
        let html = form.text().await.unwrap();
        let at = html.find("name=\"form_token\" value=\"").unwrap() + 25;
        let form_token: String = html[at..].chars().take_while(|c| *c != '"').collect();
        http.post(format!("{origin}/signin"))
            .header(COOKIE, form_cookie)
            .header("x-forwarded-proto", proto)
            .form(&[("token", token), ("form_token", form_token.as_str())])
            .send()
            .await
            .unwrap()
    }

    /// Signs in through the form with `token`: the session's cookie and
    /// CSRF token.
    pub async fn sign_in(&self, token: &str) -> PageSession {
        let http = no_redirects();
        let origin = self.origin();
        let r = self.sign_in_form(token, false).await;
        assert_eq!(
            r.status(),
            StatusCode::SEE_OTHER,
            "sign-in answers a redirect"
        );
        let cookie = set_cookie(&r, "sinscal_session")
            .expect("signing in sets the session cookie")
            .split(';')
            .next()
            .unwrap()
            .to_string();
        let mut s = PageSession {
            origin,
            cookie,
            csrf: String::new(),
            http,
        };
        // Every page with the navigation carries the sign-out form.
        let page = s.get("/upload").await;
        let page = if page.status() == StatusCode::OK {
            page
        } else {
            s.get("/").await
        };
        s.csrf = csrf_in(&page.text().await.unwrap()).expect("a page with the navigation");
        s
    }
}

impl PageSession {
    pub async fn get(&self, path: &str) -> Response {
        self.http
            .get(format!("{}{path}", self.origin))
            .header(COOKIE, &self.cookie)
            .send()
            .await
            .unwrap()
    }

    /// Posts a form with this session's CSRF token added.
    pub async fn post(&self, path: &str, fields: &[(&str, &str)]) -> Response {
        let mut all = fields.to_vec();
        all.push(("csrf", self.csrf.as_str()));
        self.post_exactly(path, &all).await
    }

    /// Posts exactly these fields (a forged form leaves out the token).
    pub async fn post_exactly(&self, path: &str, fields: &[(&str, &str)]) -> Response {
        self.http
            .post(format!("{}{path}", self.origin))
            .header(COOKIE, &self.cookie)
            .form(fields)
            .send()
            .await
            .unwrap()
    }

    /// The upload form's multipart post.
    pub async fn upload(&self, csrf: &str, metadata: &[u8], data: Vec<u8>) -> Response {
        let form = reqwest::multipart::Form::new()
            .part(
                "metadata",
                reqwest::multipart::Part::bytes(metadata.to_vec()).file_name("run.json"),
            )
            .part(
                "data",
                reqwest::multipart::Part::bytes(data).file_name("run.csv"),
            );
        self.http
            .post(format!("{}/upload?csrf={csrf}", self.origin))
            .header(COOKIE, &self.cookie)
            .multipart(form)
            .send()
            .await
            .unwrap()
    }
}
