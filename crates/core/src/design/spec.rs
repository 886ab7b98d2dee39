//! A design request as a client writes it (the body of `POST
//! /schemes/design` and `POST /designs`, and what a design job keeps):
//! every field optional, defaulting as the command line does, the target
//! by name or by accuracies. [`DesignSpec::request`] makes the
//! [`DesignRequest`] the search takes; the server's API and its job worker
//! both read the same form through it.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::{Axes, DesignError, DesignRequest, DetectGoal, Target};
use crate::calib::NoiseDensity;
use crate::nav::Site;

/// The target: `"table1"` or accuracies by parameter name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum TargetSpec {
    Named(String),
    Accuracies(BTreeMap<String, f64>),
}

/// The request as written; a field left out takes the command line's
/// default.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<TargetSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tighten: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub margin: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arw_deg_rt_h: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vrw_ug_rt_hz: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axes: Option<Axes>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_dps: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_dps2: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_dwell_s: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_dwell_s: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_turns: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_duration_s: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by_hand: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub latitude_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attitude_error_deg: Option<[f64; 3]>,
    /// `["accel_lever_arm=2cm", "accel_delay=0.5ms"]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detect: Option<Vec<String>>,
}

impl DesignSpec {
    /// The target the spec names, tightened as it asks.
    fn target(&self) -> Result<Target, DesignError> {
        let target = match &self.target {
            None => Target::table1(),
            Some(TargetSpec::Named(n)) if n == "table1" => Target::table1(),
            Some(TargetSpec::Named(n)) => {
                return Err(DesignError::Invalid(format!(
                    "target: {n:?} is not a named target (use \"table1\" or an object of \
                     accuracies by parameter name)"
                )))
            }
            Some(TargetSpec::Accuracies(map)) => Target::from_accuracies("request", map.clone())
                .map_err(|e| DesignError::Invalid(e.to_string()))?,
        };
        match self.tighten {
            None => Ok(target),
            Some(f) if f.is_finite() && f > 0.0 => Ok(target.tightened(f)),
            Some(f) => Err(DesignError::Invalid(format!(
                "tighten must be a positive number, got {f}"
            ))),
        }
    }

    /// The search's request, with `time_limit_s` (`None`: no limit). Only
    /// the target and the detect goals are checked here; the ranges are
    /// [`super::check`]'s.
    pub fn request(&self, time_limit_s: Option<f64>) -> Result<DesignRequest, DesignError> {
        let d = DesignRequest::default();
        let detect = self
            .detect
            .iter()
            .flatten()
            .map(|g| g.parse::<DetectGoal>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| DesignError::Invalid(format!("detect: {e}")))?;
        let latitude = self.latitude_deg.unwrap_or(Site::REFERENCE.latitude_deg);
        Ok(DesignRequest {
            target: Some(self.target()?),
            noise: NoiseDensity::white(
                self.arw_deg_rt_h.unwrap_or(d.noise.gyro_arw_deg_rt_h),
                self.vrw_ug_rt_hz.unwrap_or(d.noise.accel_vrw_ug_rt_hz),
            ),
            axes: self.axes.unwrap_or(d.axes),
            rate_dps: self.rate_dps.unwrap_or(d.rate_dps),
            accel_dps2: self.accel_dps2.unwrap_or(d.accel_dps2),
            min_dwell_s: self.min_dwell_s.unwrap_or(d.min_dwell_s),
            max_dwell_s: self.max_dwell_s.unwrap_or(d.max_dwell_s),
            max_turns: self.max_turns.unwrap_or(d.max_turns),
            max_duration_s: self.max_duration_s,
            margin: self.margin.unwrap_or(d.margin),
            by_hand: self.by_hand.unwrap_or(d.by_hand),
            seed: self.seed.unwrap_or(d.seed),
            site: Site {
                latitude_deg: latitude,
                ..Site::REFERENCE
            },
            initial_attitude_deg: self.attitude_error_deg.unwrap_or(d.initial_attitude_deg),
            time_limit_s,
            detect,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spec reads back as written (what a design job keeps is what was
    /// asked), and an empty one is the command line's defaults on Table 1.
    #[test]
    fn a_spec_round_trips_and_defaults_as_the_command_line() {
        let text = r#"{"target":"table1","margin":3.0,"max_turns":7}"#;
        let spec: DesignSpec = serde_json::from_str(text).unwrap();
        assert_eq!(serde_json::to_string(&spec).unwrap(), text);
        let req = DesignSpec::default().request(Some(5.0)).unwrap();
        let defaults = DesignRequest::default();
        assert_eq!(req.target, Some(Target::table1()));
        assert_eq!(
            (req.max_turns, req.margin),
            (defaults.max_turns, defaults.margin)
        );
        assert_eq!(req.time_limit_s, Some(5.0));
        let bad = r#"{"target":"table2"}"#;
        let e = serde_json::from_str::<DesignSpec>(bad)
            .unwrap()
            .request(None);
        assert!(e.unwrap_err().to_string().contains("table2"));
        assert!(serde_json::from_str::<DesignSpec>(r#"{"colour":"red"}"#).is_err());
    }
}
