//! The verdict on a calibration result: accepted, rejected (the limits it
//! fails) or needs review (why its evidence is in doubt). Computed here,
//! from a run's evidence and its product type, and nowhere else; the store
//! keeps what this returns.
//!
//! The rules (CONTRACT §6a):
//! 1. `failed` is every bound of the product type the result exceeds:
//!    |value| and σ of this run, and the repeatability (sample standard
//!    deviation over the unit's calibrated runs up to and including this
//!    one) where at least two runs give one.
//! 2. Doubts about the evidence: the model check inadequate, parameters
//!    poorly observable, parameters the cross-check flags, a parameter the
//!    result lacks, a product named in the metadata with no product type.
//!    Any doubt makes the verdict `needs_review`, with the limits the
//!    doubted values fail listed beside the reasons: a misfit or an
//!    unobservable parameter can both fail and pass a limit by accident.
//! 3. Else a failed limit makes it `rejected`.
//! 4. Else repeatability bounds that fewer than two runs cannot judge make
//!    it `needs_review` (`too_few_runs`).
//! 5. Else `accepted`. A run without a product is judged on 2 only.

use serde::{Deserialize, Serialize};

use super::limits::{LimitKind, ProductLimits};
use crate::model::{N_PARAMS, PARAMETERS};

/// The three outcomes, as stored and filtered on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VerdictStatus {
    Accepted,
    Rejected,
    NeedsReview,
}

impl VerdictStatus {
    pub const ALL: [VerdictStatus; 3] = [
        VerdictStatus::Accepted,
        VerdictStatus::Rejected,
        VerdictStatus::NeedsReview,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            VerdictStatus::Accepted => "accepted",
            VerdictStatus::Rejected => "rejected",
            VerdictStatus::NeedsReview => "needs_review",
        }
    }
}

impl std::str::FromStr for VerdictStatus {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let all = VerdictStatus::ALL.map(VerdictStatus::as_str);
        VerdictStatus::ALL
            .into_iter()
            .find(|v| v.as_str() == s)
            .ok_or_else(|| {
                let (last, rest) = all.split_last().expect("three verdicts");
                format!("unknown verdict {s:?}: {} or {last}", rest.join(", "))
            })
    }
}

impl std::fmt::Display for VerdictStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One bound a result exceeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FailedLimit {
    pub parameter: String,
    pub limit: LimitKind,
    /// The bound, in the parameter's canonical unit.
    pub max: f64,
    /// What the result (or the unit's runs) gave.
    pub actual: f64,
    pub unit: String,
}

/// Why a result's evidence is in doubt (or incomplete).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum ReviewReason {
    /// The model check found a misfit the 24 parameters cannot explain.
    ModelInadequate,
    /// The run left these parameters poorly observable.
    PoorlyObservable { parameters: Vec<String> },
    /// The filter and the least-squares cross-check differ on these.
    CrossCheckFlagged { parameters: Vec<String> },
    /// The result lacks these parameters, which the product type limits.
    MissingParameters { parameters: Vec<String> },
    /// The run's metadata names a product that has no product type.
    UnknownProduct { product: String },
    /// The product type bounds repeatability, which needs `needed` runs;
    /// the unit has `runs` calibrated runs up to this one.
    TooFewRuns { runs: i64, needed: i64 },
    /// The run stopped short of the scheme its metadata declares: the
    /// calibration found `dwells` of its `declared` positions.
    ShortOfScheme { dwells: i64, declared: i64 },
}

impl ReviewReason {
    /// The reason in words, for a page or a certificate.
    pub fn describe(&self) -> String {
        let list = |p: &[String]| p.join(", ");
        match self {
            ReviewReason::ModelInadequate => {
                "the model check found a misfit the parameters do not explain".into()
            }
            ReviewReason::PoorlyObservable { parameters } => {
                format!("the run left these poorly observable: {}", list(parameters))
            }
            ReviewReason::CrossCheckFlagged { parameters } => format!(
                "the filter and the least-squares cross-check disagree on: {}",
                list(parameters)
            ),
            ReviewReason::MissingParameters { parameters } => format!(
                "the result lacks parameters the product type limits: {}",
                list(parameters)
            ),
            ReviewReason::UnknownProduct { product } => {
                format!("the run names product {product:?}, which has no product type")
            }
            ReviewReason::TooFewRuns { runs, needed } => {
                format!("repeatability needs {needed} calibrated runs; the unit has {runs}")
            }
            ReviewReason::ShortOfScheme { dwells, declared } => format!(
                "the run is shorter than its declared scheme: {dwells} of {declared} positions"
            ),
        }
    }
}

/// The verdict on one result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(into = "VerdictParts", try_from = "VerdictParts")]
pub enum Verdict {
    Accepted,
    Rejected {
        failed: Vec<FailedLimit>,
    },
    /// `failed` lists the limits the doubted values fail, if any.
    NeedsReview {
        reasons: Vec<ReviewReason>,
        failed: Vec<FailedLimit>,
    },
}

impl Verdict {
    pub fn status(&self) -> VerdictStatus {
        match self {
            Verdict::Accepted => VerdictStatus::Accepted,
            Verdict::Rejected { .. } => VerdictStatus::Rejected,
            Verdict::NeedsReview { .. } => VerdictStatus::NeedsReview,
        }
    }

    pub fn failed(&self) -> &[FailedLimit] {
        match self {
            Verdict::Accepted => &[],
            Verdict::Rejected { failed } | Verdict::NeedsReview { failed, .. } => failed,
        }
    }

    pub fn reasons(&self) -> &[ReviewReason] {
        match self {
            Verdict::NeedsReview { reasons, .. } => reasons,
            _ => &[],
        }
    }

    /// How one parameter with (`limited`) or without limits stands. Under
    /// an inadequate model check a value within its limits is not a pass:
    /// the misfit the 24 parameters leave may be in it.
    pub fn parameter_check(&self, parameter: &str, limited: bool) -> ParameterCheck {
        if self.failed().iter().any(|f| f.parameter == parameter) {
            ParameterCheck::Fail
        } else if !limited {
            ParameterCheck::NoLimit
        } else if self.reasons().contains(&ReviewReason::ModelInadequate) {
            ParameterCheck::Unverified
        } else {
            ParameterCheck::Pass
        }
    }
}

/// One parameter against its product's limits, as a verdict judged it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParameterCheck {
    Pass,
    Fail,
    /// Within its limits, but the model check found the result does not
    /// explain the run.
    Unverified,
    NoLimit,
}

impl ParameterCheck {
    pub fn as_str(self) -> &'static str {
        match self {
            ParameterCheck::Pass => "pass",
            ParameterCheck::Fail => "fail",
            ParameterCheck::Unverified => "unverified",
            ParameterCheck::NoLimit => "no limit",
        }
    }
}

/// A verdict on the wire: `{"status", "failed", "reasons"}`.
#[derive(Serialize, Deserialize)]
struct VerdictParts {
    status: VerdictStatus,
    #[serde(default)]
    failed: Vec<FailedLimit>,
    #[serde(default)]
    reasons: Vec<ReviewReason>,
}

impl From<Verdict> for VerdictParts {
    fn from(v: Verdict) -> Self {
        let status = v.status();
        let (failed, reasons) = match v {
            Verdict::Accepted => (Vec::new(), Vec::new()),
            Verdict::Rejected { failed } => (failed, Vec::new()),
            Verdict::NeedsReview { reasons, failed } => (failed, reasons),
        };
        VerdictParts {
            status,
            failed,
            reasons,
        }
    }
}

impl TryFrom<VerdictParts> for Verdict {
    type Error = String;
    fn try_from(p: VerdictParts) -> Result<Self, String> {
        match p.status {
            VerdictStatus::Accepted if p.failed.is_empty() && p.reasons.is_empty() => {
                Ok(Verdict::Accepted)
            }
            VerdictStatus::Rejected if !p.failed.is_empty() && p.reasons.is_empty() => {
                Ok(Verdict::Rejected { failed: p.failed })
            }
            VerdictStatus::NeedsReview if !p.reasons.is_empty() => Ok(Verdict::NeedsReview {
                reasons: p.reasons,
                failed: p.failed,
            }),
            s => Err(format!(
                "a {} verdict with {} failed limits and {} reasons",
                s.as_str(),
                p.failed.len(),
                p.reasons.len()
            )),
        }
    }
}

/// Runs a repeatability bound needs (a standard deviation needs two).
pub const REPEATABILITY_RUNS: i64 = 2;

/// What a result offers to be judged on, in canonical parameter order.
#[derive(Clone, Debug)]
pub struct Evidence<'a> {
    /// Values and σ in canonical units; NaN where the result lacks one.
    pub values: &'a [f64; N_PARAMS],
    pub sigmas: &'a [f64; N_PARAMS],
    /// The model check's verdict; `None` for a result without one.
    pub model_adequate: Option<bool>,
    pub poorly_observable: &'a [String],
    pub cross_check_flagged: &'a [String],
    /// Per parameter, the sample standard deviation over the unit's
    /// calibrated runs up to and including this one (`None` below two).
    pub repeatability: &'a [Option<f64>; N_PARAMS],
    /// How many calibrated runs that covers.
    pub runs: i64,
    /// The positions the calibration found and those the run's declared
    /// scheme has, when it declares one.
    pub scheme_dwells: Option<(i64, i64)>,
}

/// The product a run is judged against.
#[derive(Clone, Copy, Debug)]
pub enum Product<'a> {
    /// The metadata names none: no limits apply.
    None,
    /// The metadata names a product with no product type.
    Unknown(&'a str),
    Known(&'a ProductLimits),
}

/// The verdict on a result (the module's rules 1–5).
pub fn judge(ev: &Evidence<'_>, product: Product<'_>) -> Verdict {
    let mut reasons = Vec::new();
    if ev.model_adequate == Some(false) {
        reasons.push(ReviewReason::ModelInadequate);
    }
    if !ev.poorly_observable.is_empty() {
        reasons.push(ReviewReason::PoorlyObservable {
            parameters: ev.poorly_observable.to_vec(),
        });
    }
    if !ev.cross_check_flagged.is_empty() {
        reasons.push(ReviewReason::CrossCheckFlagged {
            parameters: ev.cross_check_flagged.to_vec(),
        });
    }
    if let Some((dwells, declared)) = ev.scheme_dwells.filter(|(f, d)| f < d) {
        reasons.push(ReviewReason::ShortOfScheme { dwells, declared });
    }
    let mut failed = Vec::new();
    let mut missing = Vec::new();
    let mut repeatability_unjudged = false;
    match product {
        Product::None => {}
        Product::Unknown(name) => reasons.push(ReviewReason::UnknownProduct {
            product: name.to_string(),
        }),
        Product::Known(limits) => {
            for (i, info) in PARAMETERS.iter().enumerate() {
                let bounds = limits.of(i);
                if bounds.is_empty() {
                    continue;
                }
                let (value, sigma) = (ev.values[i], ev.sigmas[i]);
                if !(value.is_finite() && sigma.is_finite()) {
                    missing.push(info.name.to_string());
                    continue;
                }
                let actual = |kind| match kind {
                    LimitKind::MaxAbsValue => Some(value.abs()),
                    LimitKind::MaxSigma => Some(sigma),
                    LimitKind::MaxRepeatability => ev.repeatability[i],
                };
                for kind in LimitKind::ALL {
                    let Some(max) = bounds.get(kind) else {
                        continue;
                    };
                    match actual(kind) {
                        Some(a) if a > max => failed.push(FailedLimit {
                            parameter: info.name.to_string(),
                            limit: kind,
                            max,
                            actual: a,
                            unit: info.unit.to_string(),
                        }),
                        Some(_) => {}
                        None => repeatability_unjudged = true,
                    }
                }
            }
        }
    }
    if !missing.is_empty() {
        reasons.push(ReviewReason::MissingParameters {
            parameters: missing,
        });
    }
    if !reasons.is_empty() {
        Verdict::NeedsReview { reasons, failed }
    } else if !failed.is_empty() {
        Verdict::Rejected { failed }
    } else if repeatability_unjudged {
        Verdict::NeedsReview {
            reasons: vec![ReviewReason::TooFewRuns {
                runs: ev.runs,
                needed: REPEATABILITY_RUNS,
            }],
            failed,
        }
    } else {
        Verdict::Accepted
    }
}

#[cfg(test)]
mod tests;
