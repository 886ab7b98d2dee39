//! A unit's page: its calibration history, per parameter the trend over
//! runs with the product's tolerance, the repeatability table (the seed
//! paper's Table 2 for any number of runs), and any two runs compared.

use std::collections::BTreeMap;

use axum::extract::rejection::QueryRejection;
use axum::extract::{Path, Query, State};
use axum::response::Html;
use maud::{html, Markup};
use serde::Deserialize;

use super::access::PageCaller;
use super::error::PageError;
use super::format;
use super::layout;
use super::unit_noise;
use super::unit_tables::{repeatability_table, trend_charts, UnitRun};
use super::unit_thermal::thermal_section;
use crate::api::auth::roles;
use crate::api::error::ApiError;
use crate::api::thermal::{unit_thermal_model, ThermalQuery};
use crate::api::AppState;
use sinscal_core::calib::ParameterEstimate;
use sinscal_core::io::UnitSerial;
use sinscal_core::model::PARAMETERS;

/// Most runs a unit page reads (its history is paged beyond in the API).
const MAX_RUNS: i64 = 1000;

#[derive(Debug, Default, Deserialize)]
pub struct UnitQuery {
    /// Two runs to compare.
    #[serde(default)]
    a: String,
    #[serde(default)]
    b: String,
    /// `all`: every run a column of the repeatability table.
    #[serde(default)]
    columns: String,
}

pub async fn page(
    State(st): State<AppState>,
    session: PageCaller<roles::Engineer>,
    Path(serial): Path<String>,
    query: Result<Query<UnitQuery>, QueryRejection>,
) -> Result<Html<String>, PageError> {
    let serial: UnitSerial = serial.parse().map_err(PageError::bad_request)?;
    let Query(q) = query.map_err(|e| PageError::bad_request(e.body_text()))?;
    let unit = st
        .store
        .get_unit(&serial)
        .await?
        .ok_or_else(|| PageError::not_found(format!("no unit {serial}")))?;
    let (total, rows) = st
        .store
        .history(&serial, (i64::MIN, i64::MAX), None, MAX_RUNS, 0)
        .await?;
    let spread = st
        .store
        .repeatability(&serial, i64::MIN, None)
        .await?
        .parameters;
    let limits = crate::api::units::unit_limits(&st, unit.product.as_deref()).await?;
    let mut runs = Vec::with_capacity(rows.len());
    for r in &rows {
        let parameters: BTreeMap<String, ParameterEstimate> =
            serde_json::from_str(&r.parameters)
                .map_err(|e| PageError::from(crate::store::StoreError::from(e)))?;
        runs.push(UnitRun {
            run_id: r.run_id,
            run_time: r.run_time,
            parameters,
            model: r.model()?,
            verdict: r.verdict()?.map(|v| v.status()),
            model_adequate: r.model_adequate,
        });
    }
    // The thermal model when the unit's runs span two temperatures; its
    // absence is the common case, not an error.
    let thermal = match unit_thermal_model(&st, &serial, &ThermalQuery::default()).await {
        Ok(fitted) => Some(fitted),
        Err(ApiError::Conflict(_)) => None,
        Err(e) => return Err(e.into()),
    };
    let held = match st.store.held_noise_model(&serial).await? {
        Some(row) => Some((row.parsed()?, row.set_at)),
        None => None,
    };
    let all_columns = q.columns == "all";
    let verdict = unit.verdict()?.map(|v| v.status());
    let (word, class) = format::verdict(verdict);
    let body = html! {
        h1 { "Unit " (serial) }
        dl.facts {
            dt { "Product" } dd { (unit.product.as_deref().unwrap_or("none named")) }
            dt { "Runs" } dd { (unit.runs) " uploaded, " (unit.calibrated) " calibrated" }
            dt { "Verdict" } dd { span class={ "badge " (class) } { (word) } " (latest calibrated run)" }
            @if total > MAX_RUNS { dt { "Shown" } dd { "the first " (MAX_RUNS) " of " (total) " calibrated runs" } }
        }
        h2 { "Calibration history" }
        (history(serial.as_str(), &runs, &q))
        @if !q.a.is_empty() && !q.b.is_empty() {
            (compare(&runs, &q.a, &q.b)?)
        }
        h2 { "Repeatability" }
        (repeatability_table(serial.as_str(), &runs, &spread, limits.as_ref(), all_columns))
        h2 { "Trends" }
        p.muted { "Each run's estimate ± 1σ against the run's date, the runs' mean (line) and ± 1 standard deviation (grey band), and the product type's limits (repeatability in orange, |value| in red). The y axis is scaled to the runs; a limit beyond it is named \"off scale\" in the legend." }
        (trend_charts(&runs, &spread, limits.as_ref()))
        @if let Some((model, soaks)) = &thermal {
            h2 { "Thermal model" }
            (thermal_section(model, soaks))
        }
        (unit_noise::section(&session, &serial, held.as_ref()))
    };
    Ok(Html(
        layout::page(&format!("Unit {serial}"), Some(&session), body).into_string(),
    ))
}

/// The history table, which is also the form choosing two runs to compare
/// (a GET form: comparing changes nothing).
fn history(serial: &str, runs: &[UnitRun], q: &UnitQuery) -> Markup {
    html! {
        form method="get" action={ "/units/" (serial) } {
            table #history {
                thead { tr {
                    th { "Run date" } th { "Run" } th { "Model" } th { "Verdict" } th { "Model check" }
                    th { "A" } th { "B" }
                } }
                tbody {
                    @for r in runs.iter().rev() {
                        @let (word, class) = format::verdict(r.verdict);
                        tr {
                            td { (format::time(r.run_time)) }
                            td { a href={ "/runs/" (r.run_id) } { code { (format::short_id(r.run_id)) } } }
                            td { (format::model(r.model.as_ref())) }
                            td { span class={ "badge " (class) } { (word) } }
                            td { @match r.model_adequate {
                                Some(true) => "adequate",
                                Some(false) => span.fail { "inadequate" },
                                None => "—",
                            } }
                            td { input type="radio" name="a" value=(r.run_id) checked[q.a == r.run_id.to_string()] aria-label="compare as A"; }
                            td { input type="radio" name="b" value=(r.run_id) checked[q.b == r.run_id.to_string()] aria-label="compare as B"; }
                        }
                    }
                }
            }
            @if runs.len() >= 2 { button #compare-runs type="submit" { "Compare A and B" } }
        }
    }
}

/// Two runs side by side: per parameter the difference B − A, and how many
/// combined σ it is (a change beyond 3 is more than the estimators' noise).
/// `a` and `b` are the query's text, matched against the ids' spelling: any
/// other text (malformed or not) names no run of the unit.
fn compare(runs: &[UnitRun], a: &str, b: &str) -> Result<Markup, PageError> {
    let find = |id: &str| {
        runs.iter()
            .find(|r| r.run_id.to_string() == id)
            .ok_or_else(|| {
                PageError::not_found(format!("run {id} is not a calibrated run of this unit"))
            })
    };
    let (ra, rb) = (find(a)?, find(b)?);
    Ok(html! {
        h2 #compare { "Run " code { (format::short_id(a)) } " against run " code { (format::short_id(b)) } }
        table.compare {
            thead { tr {
                th { "Parameter" } th { "Unit" } th.num { "A" } th.num { "B" } th.num { "B − A" } th.num { "in σ" }
            } }
            tbody {
                @for p in PARAMETERS.iter() {
                    @if let (Some(x), Some(y)) = (ra.parameters.get(p.name), rb.parameters.get(p.name)) {
                        @let d = y.value - x.value;
                        @let z = d / x.sigma.hypot(y.sigma);
                        tr class=[(z.abs() > 3.0).then_some("flag")] {
                            td { (p.name) } td { (p.unit) }
                            td.num { (format::sig(x.value, 5)) " ± " (format::sig(x.sigma, 2)) }
                            td.num { (format::sig(y.value, 5)) " ± " (format::sig(y.sigma, 2)) }
                            td.num { (format::sig(d, 3)) }
                            td.num { (format::sig(z, 2)) }
                        }
                    }
                }
            }
        }
    })
}
