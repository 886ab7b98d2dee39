//! A certificate as the text it prints: every fact, the approval block and
//! the parameter table already worded and formatted, so that the page and
//! the PDF say exactly the same thing (each only lays it out); and
//! [`Certificate`], everything it is made from.

use super::units::Repeatability;
use crate::store::{CertificateRow, ResultVersion, RunRow, StoredVerdict};
use sinscal_core::accept::{LimitKind, ParameterCheck};
use sinscal_core::accept::{ProductLimits, VerdictStatus};
use sinscal_core::calib::CalibrationResult;
use sinscal_core::io::meta::RunMetadata;
use sinscal_core::model::PARAMETERS;
use sinscal_core::sim::scheme::SchemeRef;

/// Everything a certificate states, read once for the page, the JSON and
/// the PDF.
pub(crate) struct Certificate {
    pub run: RunRow,
    pub meta: Option<RunMetadata>,
    /// The result certified: the run's current one.
    pub result: CalibrationResult,
    pub result_version: ResultVersion,
    pub verdict: Option<StoredVerdict>,
    pub limits: Option<ProductLimits>,
    /// The unit's runs up to this one against the product's limits.
    pub repeatability: Repeatability,
    /// The certificate issued for this result; `None`: a draft.
    pub issued: Option<CertificateRow>,
    /// Certificates issued for the run's earlier (superseded) results.
    pub earlier: Vec<CertificateRow>,
}

impl Certificate {
    /// Whether the result may be approved now.
    pub fn approvable(&self) -> bool {
        self.issued.is_none()
            && self
                .verdict
                .as_ref()
                .is_some_and(|v| v.status() == VerdictStatus::Accepted)
    }

    pub fn sheet(&self) -> Sheet {
        Sheet::of(self)
    }
}

/// The words of a draft, wherever the number would be.
pub const DRAFT: &str = "DRAFT - not valid until approved";

/// A certificate's text.
#[derive(Clone, Debug)]
pub struct Sheet {
    /// `SC-000042`, or `None` for a draft.
    pub number: Option<String>,
    /// The issue date, `None` for a draft.
    pub issued: Option<String>,
    /// `(who, role, when)` of the approval; `None`: a draft.
    pub approval: Option<(String, String, String)>,
    /// Label and value of each fact about the unit, the run and the result.
    pub facts: Vec<(&'static str, String)>,
    /// The 24 parameters with the product's limits and the repeatability.
    pub rows: Vec<ParameterRow>,
    /// The runs the repeatability is over.
    pub repeatability_runs: i64,
    /// Certificates of the run's earlier results, still on file.
    pub superseded: Vec<String>,
}

/// One parameter's line.
#[derive(Clone, Debug)]
pub struct ParameterRow {
    pub name: &'static str,
    pub value: String,
    pub sigma: String,
    pub unit: String,
    pub max_abs: String,
    pub max_sigma: String,
    pub check: &'static str,
    /// The sample standard deviation over the unit's runs, and its bound.
    pub repeat_sd: String,
    pub repeat_max: String,
    pub repeat_check: &'static str,
}

/// The column heads of [`ParameterRow`], in order.
pub const HEADS: [&str; 10] = [
    "Parameter",
    "Value",
    "1σ",
    "Unit",
    "Limit |value|",
    "Limit σ",
    "Check",
    "Repeat. SD",
    "Limit SD",
    "Repeat.",
];

impl ParameterRow {
    pub fn cells(&self) -> [&str; 10] {
        [
            self.name,
            &self.value,
            &self.sigma,
            &self.unit,
            &self.max_abs,
            &self.max_sigma,
            self.check,
            &self.repeat_sd,
            &self.repeat_max,
            self.repeat_check,
        ]
    }
}

/// A value with `digits` significant digits, without an exponent for the
/// magnitudes calibration parameters have (as the pages write them).
pub fn sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return "-".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-4..=6).contains(&mag) {
        return format!("{:.*e}", digits.saturating_sub(1), v);
    }
    let decimals = (digits as i32 - 1 - mag).max(0) as usize;
    format!("{v:.decimals$}")
}

/// Unix ms as `2026-12-02 14:05 UTC`.
pub fn time(ms: i64) -> String {
    chrono::DateTime::from_timestamp_millis(ms)
        .map(|t| t.format("%Y-%m-%d %H:%M UTC").to_string())
        .unwrap_or_else(|| "-".into())
}

fn or_dash(s: Option<&str>) -> String {
    s.filter(|s| !s.is_empty()).unwrap_or("-").to_string()
}

fn scheme(meta: Option<&RunMetadata>) -> String {
    match meta.and_then(|m| m.scheme.as_ref()) {
        Some(SchemeRef::Name(n)) => n.clone(),
        Some(SchemeRef::Inline(s)) if !s.name.is_empty() => {
            format!("{} ({} steps, inline)", s.name, s.steps.len())
        }
        Some(SchemeRef::Inline(s)) => format!("inline, {} steps", s.steps.len()),
        None => "-".into(),
    }
}

impl Sheet {
    pub fn of(c: &Certificate) -> Sheet {
        let meta = c.meta.as_ref();
        let r = &c.result;
        let verdict = c.verdict.as_ref();
        let site = meta.map_or_else(
            || "-".into(),
            |m| {
                format!(
                    "latitude {}°, longitude {}°, height {} m",
                    m.latitude_deg, m.longitude_deg, m.height_m
                )
            },
        );
        let temperature = match (&r.temperature, meta.and_then(|m| m.temperature_c)) {
            (Some(t), _) if t.max_c - t.min_c > 0.05 => format!(
                "{} °C mean ({} to {} °C)",
                sig(t.mean_c, 3),
                sig(t.min_c, 3),
                sig(t.max_c, 3)
            ),
            (Some(t), _) => format!("{} °C", sig(t.mean_c, 3)),
            (None, Some(t)) => format!("{} °C", sig(t, 3)),
            (None, None) => "not stated".into(),
        };
        let product = match verdict.and_then(|v| v.product.as_deref()) {
            Some(p) => match verdict.and_then(|v| v.revision) {
                Some(rev) => format!("{p} (limits revision {rev})"),
                None => format!("{p} (no such product type: no limits)"),
            },
            None => or_dash(meta.and_then(|m| m.product.as_deref())),
        };
        let model_check = match &r.model_check {
            Some(m) if m.adequate => "adequate".to_string(),
            Some(_) => "inadequate".to_string(),
            None => "not made (result predates it)".to_string(),
        };
        let overall = verdict.map_or("not judged", |v| v.status().as_str());
        let facts = vec![
            ("Unit serial", c.run.unit_serial.to_string()),
            ("Product type", product),
            ("Run", c.run.id.to_string()),
            (
                "Result",
                format!(
                    "no. {} (job {})",
                    c.result_version.seq, c.result_version.job_id
                ),
            ),
            ("Recorded at", time(c.run.run_time)),
            ("Calibrated at", time(c.result_version.completed_at)),
            ("Station", or_dash(meta.and_then(|m| m.station.as_deref()))),
            (
                "Operator",
                or_dash(meta.and_then(|m| m.operator.as_deref())),
            ),
            ("Scheme", scheme(meta)),
            ("Site", site),
            ("Temperature", temperature),
            ("Model", r.model.to_string()),
            (
                "Estimator",
                format!(
                    "{}, {} passes over {} h",
                    r.estimator.as_str(),
                    r.passes,
                    sig(r.duration_s / 3600.0, 3)
                ),
            ),
            ("Data sha256", c.run.file.sha256.clone()),
            ("Software", format!("sinscal {}", env!("CARGO_PKG_VERSION"))),
            ("Model check", model_check),
            ("Verdict", overall.to_string()),
        ];
        Sheet {
            number: c.issued.as_ref().map(|i| i.number.clone()),
            issued: c.issued.as_ref().map(|i| time(i.issued_at)),
            approval: c.issued.as_ref().map(|i| {
                (
                    i.approved_by.clone(),
                    i.approver_role.as_str().to_string(),
                    time(i.approved_at),
                )
            }),
            facts,
            rows: parameter_rows(c),
            repeatability_runs: c.repeatability.runs,
            superseded: c
                .earlier
                .iter()
                .map(|e| {
                    format!(
                        "{} (result no. {}, issued {})",
                        e.number,
                        e.result_seq,
                        time(e.issued_at)
                    )
                })
                .collect(),
        }
    }
}

fn parameter_rows(c: &Certificate) -> Vec<ParameterRow> {
    let limits = c.limits.as_ref();
    let bound = |i: usize, kind| {
        limits
            .and_then(|l| l.of(i).get(kind))
            .map_or_else(|| "-".into(), |v| sig(v, 3))
    };
    PARAMETERS
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let e = c.result.parameters.get(p.name);
            let limited = limits.is_some_and(|l| !l.of(i).is_empty());
            let check = c.verdict.as_ref().map_or(ParameterCheck::NoLimit, |v| {
                v.verdict.parameter_check(p.name, limited)
            });
            let spread = c.repeatability.parameters.iter().find(|s| s.name == p.name);
            let sd = spread.and_then(|s| s.std_dev);
            let repeat_max = limits.and_then(|l| l.of(i).get(LimitKind::MaxRepeatability));
            let repeat_check = match (sd, repeat_max) {
                (_, None) => "-",
                (None, Some(_)) => "too few runs",
                (Some(s), Some(max)) if s > max => "fail",
                (Some(_), Some(_)) => "pass",
            };
            ParameterRow {
                name: p.name,
                value: e.map_or_else(|| "-".into(), |e| sig(e.value, 6)),
                sigma: e.map_or_else(|| "-".into(), |e| sig(e.sigma, 3)),
                unit: e.map_or(p.unit, |e| e.unit.as_str()).to_string(),
                max_abs: bound(i, LimitKind::MaxAbsValue),
                max_sigma: bound(i, LimitKind::MaxSigma),
                check: check.as_str(),
                repeat_sd: sd.map_or_else(|| "-".into(), |s| sig(s, 3)),
                repeat_max: repeat_max.map_or_else(|| "-".into(), |v| sig(v, 3)),
                repeat_check,
            }
        })
        .collect()
}
