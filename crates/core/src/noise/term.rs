//! One noise term as NOISE.json gives it: a value with its σ when the curve
//! resolves it, a value held from elsewhere (Q from a detected quantum), or
//! an upper bound and the τ the data covered — never 0 and never a value
//! the data cannot support.

use serde::{Deserialize, Serialize};

use super::departures::sig;
use super::fit::Estimate;

/// What the curve says of a term.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TermStatus {
    /// `value` and `sigma` (1-σ) read from the curve.
    Resolved,
    /// `upper_bound` only (one-sided 95 %): the curve does not show it.
    NotResolved,
    /// `value` held from elsewhere (Q = q/√12 from the quantum found in
    /// the data), not fitted.
    Fixed,
}

/// A term in its report unit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Term {
    pub status: TermStatus,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub upper_bound: Option<f64>,
    /// Resolved or fixed: the τ band the term is read from (where it makes
    /// half the model or more). Not resolved: the τ the curve covered.
    pub tau_s: [f64; 2],
    /// The term's band overlaps a departure from the model: the figure is
    /// not the sensor's noise alone.
    pub spoiled_by_departure: bool,
    /// The same in words, with the unit.
    pub text: String,
}

/// Which end of the curve limits a term that is not resolved: quantization
/// and white noise show at short τ, flicker and random walk at long τ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reach {
    Short,
    Long,
}

impl Term {
    /// The term from the fit's estimate, SI, in the unit `per_unit` SI
    /// each (`unit` its name). `band` is where it is read (or where its
    /// bound binds), `covered` the curve's τ range.
    pub fn from_estimate(
        estimate: &Estimate,
        (per_unit, unit): (f64, &str),
        band: [f64; 2],
        covered: [f64; 2],
        reach: Reach,
        spoiled: bool,
    ) -> Self {
        let spoiled_note = if spoiled {
            "; read beside a departure from the model: disturbances add, so the sensor's own is at most this"
        } else {
            ""
        };
        match *estimate {
            Estimate::Resolved { value, sigma } => {
                let (v, s) = (value / per_unit, sigma / per_unit);
                Term {
                    status: TermStatus::Resolved,
                    value: Some(v),
                    sigma: Some(s),
                    upper_bound: None,
                    tau_s: band,
                    spoiled_by_departure: spoiled,
                    text: format!(
                        "{} ± {} {unit} (tau {}–{} s){spoiled_note}",
                        sig(v),
                        sig(s),
                        sig(band[0]),
                        sig(band[1])
                    ),
                }
            }
            Estimate::Fixed { value } => {
                let v = value / per_unit;
                Term {
                    status: TermStatus::Fixed,
                    value: Some(v),
                    sigma: None,
                    upper_bound: None,
                    tau_s: band,
                    spoiled_by_departure: spoiled,
                    text: format!(
                        "{} {unit}: q/sqrt(12) of the quantum found in the data, held in the fit",
                        sig(v)
                    ),
                }
            }
            Estimate::Bound { upper } => {
                let b = upper / per_unit;
                let range = match reach {
                    Reach::Short => format!("tau >= {} s", sig(covered[0])),
                    Reach::Long => format!("tau <= {} s", sig(covered[1])),
                };
                Term {
                    status: TermStatus::NotResolved,
                    value: None,
                    sigma: None,
                    upper_bound: Some(b),
                    tau_s: covered,
                    spoiled_by_departure: spoiled,
                    text: format!(
                        "not resolved: below {} {unit} (95 %) at {range}{spoiled_note}",
                        sig(b)
                    ),
                }
            }
        }
    }

    /// The value the model draws with (resolved or fixed), else 0.
    pub fn model_value(&self) -> f64 {
        match self.status {
            TermStatus::Resolved | TermStatus::Fixed => self.value.unwrap_or(0.0),
            TermStatus::NotResolved => 0.0,
        }
    }

    /// A table cell: "v±s", "<b", "=v".
    pub fn cell(&self) -> String {
        match self.status {
            TermStatus::Resolved => format!(
                "{}±{}",
                sig(self.value.unwrap_or(0.0)),
                sig(self.sigma.unwrap_or(0.0))
            ),
            TermStatus::NotResolved => format!("<{}", sig(self.upper_bound.unwrap_or(0.0))),
            TermStatus::Fixed => format!("={}", sig(self.value.unwrap_or(0.0))),
        }
    }
}
