//! The workbench (the pages at the server's root), one test binary: the
//! pages over HTTP as a browser without JavaScript uses them (`pages`,
//! `design_pages`), the same pages in a real headless Chromium
//! (`in_chromium`, `design_in_chromium`), the discrepancy loop closed from
//! the pages (`loop_in_chromium`), the steps those walks share (`steps`),
//! and the WebDriver client they drive Chromium with, against a page
//! server of its own (`browser_client`).

#[path = "../suite/common/mod.rs"]
mod common;
#[path = "../suite/thermal_support/mod.rs"]
mod thermal_support;

mod browser_client;
mod design_in_chromium;
mod design_pages;
mod in_chromium;
mod loop_in_chromium;
mod pages;
mod steps;
