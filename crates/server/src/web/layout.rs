//! The frame every page shares: head (styles, htmx), the navigation the
//! session's role may use, and the sign-out form.

use maud::{html, Markup, DOCTYPE};

use super::session::Session;
use crate::api::auth::roles;

/// A whole page.
pub fn page(title: &str, session: Option<&Session>, body: Markup) -> Markup {
    html! {
        (DOCTYPE)
        html lang="en" {
            head {
                meta charset="utf-8";
                meta name="viewport" content="width=device-width, initial-scale=1";
                // htmx would otherwise add an inline style, which the
                // Content-Security-Policy refuses.
                meta name="htmx-config" content=r#"{"includeIndicatorStyles":false}"#;
                title { (title) " · sinscal" }
                link rel="stylesheet" href="/static/style.css";
                // No icon: a browser would otherwise ask for /favicon.ico.
                link rel="icon" href="data:,";
                script src="/static/htmx.min.js" defer {}
            }
            body {
                @if let Some(s) = session { (nav(s)) }
                main { (body) }
            }
        }
    }
}

fn nav(s: &Session) -> Markup {
    let role = s.role();
    html! {
        nav.top {
            a.brand href="/" { "sinscal" }
            @if roles::ENGINEER.contains(&role) { a href="/" { "Units" } }
            @if roles::UPLOAD.contains(&role) { a href="/upload" { "Upload" } }
            @if roles::ENGINEER.contains(&role) { a href="/design" { "Design" } }
            @if roles::ADMIN.contains(&role) { a href="/admin" { "Admin" } }
            span.who { "signed in as " (role.as_str()) }
            form.inline method="post" action="/signout" {
                input type="hidden" name="csrf" value=(s.csrf());
                button.link type="submit" { "Sign out" }
            }
        }
    }
}

/// A button that posts a CSRF-protected form to `action`.
pub fn action_button(s: &Session, action: &str, label: &str, class: &str) -> Markup {
    html! {
        form.inline method="post" action=(action) {
            input type="hidden" name="csrf" value=(s.csrf());
            button class=(class) type="submit" { (label) }
        }
    }
}
