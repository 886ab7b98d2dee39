//! Scheme design: the shortest rotation scheme whose predicted 1-σ meets a
//! target for every parameter (`sinscal design`).
//!
//! - `information`: the fast objective, the σ the systematic filter would
//!   reach on a scheme from the information of its dwells and turns,
//!   computed from the motion without records (checked against
//!   `calib::plan` on the built-in schemes).
//! - `search`: the beam search over turn sequences and the dwells.
//! - `target`: per-parameter accuracy targets (Table 1, or a file).
//! - `detect`: effects of given sizes the scheme must make the
//!   discrepancy workflow name (`--detect`).
//!
//! A design meets `target / margin` in predicted σ, so that the target
//! itself holds in nearly every run (margin 3: a parameter beyond its
//! target is a 3σ event).

pub mod detect;
pub mod information;
pub mod search;
pub mod spec;
mod summary;
pub mod target;
pub mod watch;

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::calib::{CalibError, EstimateOptions, NoiseDensity, NoiseModel};
use crate::estimation::priors::Priors;
use crate::model::units::DEG_PER_RT_H;
use crate::model::{Grade, PARAMETERS};
use crate::nav::Site;
use crate::sim::scheme::{Frame, DEFAULT_DWELL_S};
use crate::sim::{HandTurns, Scheme};
pub use detect::DetectGoal;
use detect::{DetectOutcome, Detection};
use information::{Information, ObjectiveSettings};
use search::{Scored, Scorer, SearchSpace};
pub use spec::{DesignSpec, TargetSpec};
pub use target::{Target, TargetError};
pub use watch::Watch;

/// Most turns a request may allow: a search's cost grows with it.
const MAX_TURNS: usize = 96;

/// Most `detect` goals in one request: every SPEC §3 quantity once.
const MAX_DETECT_GOALS: usize = 6;

/// Which axes the table can turn the unit about.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Axes {
    /// The unit's own axes (a table carrying the unit).
    #[default]
    Body,
    /// East, North, Up (a table with fixed axes).
    Nav,
    Both,
}

/// Errors of a design.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error("design: {0}")]
    Invalid(String),
    #[error(
        "the design did not finish within its time limit of {0:.0} s: loosen the target \
         or the margin, or run `sinscal design`, which has no limit"
    )]
    TimeLimit(f64),
    /// The design's [`Watch`] was cancelled.
    #[error("the design was cancelled")]
    Cancelled,
    #[error(transparent)]
    Calib(#[from] CalibError),
    /// The check of a `--detect` goal by the discrepancy workflow failed.
    #[error(transparent)]
    Diagnose(#[from] crate::diagnose::DiagnoseError),
}

/// What the engineer asks for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignRequest {
    /// Accuracy per parameter, canonical units, `PARAMETERS` order.
    #[serde(skip)]
    pub target: Option<Target>,
    pub noise: NoiseDensity,
    pub axes: Axes,
    pub rate_dps: f64,
    pub accel_dps2: f64,
    pub min_dwell_s: f64,
    /// Longest dwell the search considers, s (an hour unless a target out
    /// of reach asks what it would take).
    pub max_dwell_s: f64,
    /// Most turns in the scheme.
    pub max_turns: usize,
    /// Longest acceptable run, s.
    pub max_duration_s: Option<f64>,
    /// Predicted σ must be at most target / margin.
    pub margin: f64,
    /// Score the turns as an operator makes them by hand (SPEC §4), with
    /// hand turns drawn from `seed`.
    pub by_hand: bool,
    pub seed: u64,
    pub site: Site,
    /// The unit's start attitude, rotation vector in n, degrees.
    pub initial_attitude_deg: [f64; 3],
    /// Most wall time the search may take, s; `None`: no limit.
    pub time_limit_s: Option<f64>,
    /// Effects of given sizes the discrepancy workflow must name on a run
    /// of the scheme.
    #[serde(default)]
    pub detect: Vec<DetectGoal>,
}

impl Default for DesignRequest {
    fn default() -> Self {
        DesignRequest {
            target: None,
            noise: NoiseDensity::white(0.0003, 5.0),
            axes: Axes::Body,
            rate_dps: 10.0,
            accel_dps2: 20.0,
            min_dwell_s: 60.0,
            max_dwell_s: 3600.0,
            max_turns: 24,
            max_duration_s: None,
            margin: 3.0,
            by_hand: false,
            seed: 1,
            site: Site::REFERENCE,
            initial_attitude_deg: [0.0; 3],
            time_limit_s: None,
            detect: Vec::new(),
        }
    }
}

/// One parameter's prediction against its goal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PredictedParameter {
    pub sigma: f64,
    pub target: f64,
    /// σ × margin / target: at most 1 when the goal is met.
    pub ratio: f64,
    pub unit: String,
}

/// A reference scheme on the same target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    pub scheme: String,
    /// The shortest uniform dwell that meets the goal, and the run's
    /// duration with it; `None` when no dwell up to the longest the search
    /// considered does.
    pub dwell_s: Option<f64>,
    pub duration_s: Option<f64>,
    /// Its worst σ × margin / target at the default 600 s dwells.
    pub worst_ratio_at_600_s: f64,
}

/// The designer's answer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Design {
    /// The scheme, as SPEC §4 JSON reads it.
    pub scheme: Scheme,
    pub duration_s: f64,
    pub target: String,
    pub margin: f64,
    pub by_hand: bool,
    pub parameters: BTreeMap<String, PredictedParameter>,
    /// Each `--detect` goal: the size the scheme would name, predicted
    /// and checked by the discrepancy workflow.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub detect: Vec<DetectOutcome>,
    /// The parameters (and effects) within 5 % of their goal: what sets
    /// the length.
    pub binding: Vec<String>,
    pub comparisons: Vec<Comparison>,
    /// How many schemes the last search scored (a scheme met twice
    /// counts twice, though its score is reused).
    pub evaluations: usize,
}

/// The objective's settings for a request: the estimator's own priors,
/// start covariance, zero-velocity σ and pre-scan guard and minimum dwell.
pub fn objective_settings(req: &DesignRequest) -> ObjectiveSettings {
    let opts = EstimateOptions::default();
    ObjectiveSettings {
        site: req.site,
        noise: NoiseModel::from_density(&req.noise),
        zupt_sigma_mps: opts.zupt_sigma_mps,
        priors: Priors {
            scale: opts.prior_scale,
            grade: grade_of(req),
            start_heading_sigma: None,
        },
        initial_attitude_deg: req.initial_attitude_deg,
        dwell_window_s: 10.0,
        guard_s: opts.detect.guard_s,
        min_dwell_s: opts.detect.min_dwell_s,
        effects: detection(req).map(|d| d.states).unwrap_or_default(),
    }
}

/// The grade a request's unit is calibrated at: the estimator's, else
/// the one its gyro noise names.
fn grade_of(req: &DesignRequest) -> Grade {
    EstimateOptions::default()
        .grade
        .unwrap_or_else(|| Grade::of_gyro_noise(req.noise.gyro_arw_deg_rt_h * DEG_PER_RT_H))
}

/// The request's `detect` goals as the objective scores them.
fn detection(req: &DesignRequest) -> Option<Detection> {
    (!req.detect.is_empty())
        .then(|| Detection::new(&req.detect, detect::naming_bar(), grade_of(req)))
}

fn validate(req: &DesignRequest, target: &Target) -> Result<(), DesignError> {
    // Ranges wide enough for any real unit and table, narrow enough that
    // one scheme's score stays a few milliseconds (a turn at 1e-9 °/s²
    // would last for ages).
    let within = |name: &str, v: f64, lo: f64, hi: f64| {
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(DesignError::Invalid(format!(
                "{name} must be within {lo} to {hi}, got {v}"
            )))
        }
    };
    within(
        "the gyro ARW (deg/√h)",
        req.noise.gyro_arw_deg_rt_h,
        1e-6,
        1.0,
    )?;
    within(
        "the accelerometer VRW (µg/√Hz)",
        req.noise.accel_vrw_ug_rt_hz,
        0.01,
        1e4,
    )?;
    within("the turn rate (deg/s)", req.rate_dps, 0.5, 1000.0)?;
    within("the turn acceleration (deg/s²)", req.accel_dps2, 0.5, 1e4)?;
    within("the margin", req.margin, 0.5, 100.0)?;
    if let Some(t) = req.time_limit_s {
        within("the time limit (s)", t, 0.1, 86_400.0)?;
    }
    if let Some(t) = req.max_duration_s {
        within("the longest run (s)", t, 1.0, 1e6)?;
    }
    let min_dwell = EstimateOptions::default().detect.min_dwell_s;
    if !(req.min_dwell_s.is_finite() && (min_dwell..=3600.0).contains(&req.min_dwell_s)) {
        return Err(DesignError::Invalid(format!(
            "the shortest dwell must be {min_dwell} s (what the estimator takes for a dwell) \
             to 3600 s, got {}",
            req.min_dwell_s
        )));
    }
    within(
        "the longest dwell (s)",
        req.max_dwell_s,
        req.min_dwell_s,
        86_400.0,
    )?;
    if !(1..=MAX_TURNS).contains(&req.max_turns) {
        return Err(DesignError::Invalid(format!(
            "the most turns must be 1 to {MAX_TURNS}, got {}",
            req.max_turns
        )));
    }
    if req.detect.len() > MAX_DETECT_GOALS {
        return Err(DesignError::Invalid(format!(
            "at most {MAX_DETECT_GOALS} effects to detect, got {}",
            req.detect.len()
        )));
    }
    for (p, a) in PARAMETERS.iter().zip(&target.accuracy) {
        let goal = a * p.si_per_unit / req.margin;
        if !(goal.is_normal() && goal > 0.0) {
            return Err(DesignError::Invalid(format!(
                "the target for {} ({a} {}) is not a usable positive number",
                p.name, p.unit
            )));
        }
    }
    req.site.validate().map_err(DesignError::Invalid)?;
    Ok(())
}

/// Checks a request's ranges without designing (what [`design`] checks
/// first): a server refuses a bad request before it queues it.
pub fn check(req: &DesignRequest) -> Result<(), DesignError> {
    validate(req, req.target.as_ref().unwrap_or(&Target::table1()))
}

/// Designs the shortest scheme for `req`.
pub fn design(req: &DesignRequest) -> Result<Design, DesignError> {
    design_watched(req, &Watch::quiet())
}

/// [`design`], reporting its progress to `watch` and stopping when it is
/// cancelled; the same answer.
pub fn design_watched(req: &DesignRequest, watch: &Watch) -> Result<Design, DesignError> {
    check(req)?;
    match designed(req, watch) {
        Err(DesignError::Calib(CalibError::Cancelled)) if watch.cancelled() => {
            Err(DesignError::Cancelled)
        }
        Err(DesignError::Calib(CalibError::Cancelled)) => {
            Err(DesignError::TimeLimit(req.time_limit_s.unwrap_or(0.0)))
        }
        other => other,
    }
}

fn designed(req: &DesignRequest, watch: &Watch) -> Result<Design, DesignError> {
    let deadline = req
        .time_limit_s
        .map(|s| std::time::Instant::now() + std::time::Duration::from_secs_f64(s));
    let mut detection = detection(req);
    let scored = Scored::default();
    let mut round = 0;
    loop {
        let (mut design, info) = searched(req, detection.as_ref(), (deadline, watch), &scored)?;
        let Some(d) = &mut detection else {
            return Ok(design);
        };
        if deadline.is_some_and(|t| std::time::Instant::now() >= t) {
            return Err(CalibError::Cancelled.into());
        }
        watch.phase(
            0.95,
            "checking the detect goals with the discrepancy workflow",
        );
        let run = realise(req, &design.scheme).map_err(DesignError::Invalid)?;
        design.detect = detect::outcomes(d, &d.thresholds(&info), &run, req)?;
        round += 1;
        // The workflow is the judge: where it names less than the
        // objective promised, the objective's goal is tightened by the
        // difference and the search run again.
        if round > detect::CHECK_ROUNDS || !d.correct(&design.detect) {
            return Ok(design);
        }
    }
}

/// The scheme as it is run: turned by hand when the request says so.
fn realise(req: &DesignRequest, s: &Scheme) -> Result<Scheme, String> {
    if req.by_hand {
        Scheme::by_hand(s, req.seed, &HandTurns::default())
    } else {
        Ok(s.clone())
    }
}

/// The search with the objective's goals; the design and its information.
fn searched(
    req: &DesignRequest,
    detection: Option<&Detection>,
    (deadline, watch): (Option<std::time::Instant>, &Watch),
    scored: &Scored,
) -> Result<(Design, Information), DesignError> {
    let target = req.target.clone().unwrap_or_else(Target::table1);
    let settings = objective_settings(req);
    let realise = |s: &Scheme| realise(req, s);
    let scorer = Scorer {
        settings: &settings,
        goal_si: target
            .accuracy
            .iter()
            .zip(PARAMETERS.iter())
            .map(|(a, p)| a * p.si_per_unit / req.margin)
            .collect(),
        detect: detection,
        realise: &realise,
        evaluations: std::cell::Cell::new(0),
        scored,
        deadline,
        watch,
    };
    let frames: &[Frame] = match req.axes {
        Axes::Body => &[Frame::Body],
        Axes::Nav => &[Frame::Nav],
        Axes::Both => &[Frame::Body, Frame::Nav],
    };
    let space = SearchSpace {
        turns: SearchSpace::turns_about(frames),
        rate_dps: req.rate_dps,
        accel_dps2: req.accel_dps2,
        min_dwell_s: req.min_dwell_s,
        max_dwell_s: req.max_dwell_s,
        max_turns: req.max_turns,
        beam: 4,
    };
    // Rank sequences at a dwell near the answer's: a first search at 300 s
    // finds the length, a second at the dwell it needed ranks again.
    watch.phase(0.0, "searching turn sequences at 300 s dwells");
    let first = search::search_sequences(&space, &scorer, 300.0)?;
    let Some(first) = first else {
        return Err(DesignError::Invalid(format!(
            "no sequence of up to {} turns with dwells up to {} s reaches the target at \
             margin {} (more --max-turns, or a longer --max-dwell, tells what it would \
             take); {}",
            space.max_turns,
            space.max_dwell_s,
            req.margin,
            out_of_reach(&scorer, space.max_dwell_s)?
        )));
    };
    let probe = first.dwells[0];
    watch.phase(0.45, "searching turn sequences again at the dwell found");
    let second = search::search_sequences(&space, &scorer, probe)?;
    let pick = match second {
        Some(s) if s.information.duration_s < first.information.duration_s => s,
        _ => first,
    };
    watch.phase(0.8, "trimming the dwells");
    let trimmed = search::trim_dwells(pick, &space, &scorer)?;
    // Whole seconds, rounded up: a dwell is set on a table's controller.
    let dwells: Vec<f64> = trimmed.dwells.iter().map(|d| d.ceil()).collect();
    let name = format!(
        "designed-{}-{}",
        trimmed.turns.len() + 1,
        if req.by_hand { "by-hand" } else { "table" }
    );
    let scheme = search::build(&name, &trimmed.turns, &dwells, &space);
    let info = scorer.information(&scheme)?;
    if let Some(max) = req.max_duration_s {
        if info.duration_s > max {
            return Err(DesignError::Invalid(format!(
                "the shortest scheme found lasts {:.0} s, more than --max-duration {max} s",
                info.duration_s
            )));
        }
    }
    watch.phase(0.9, "comparing with the built-in schemes");
    let comparisons = ["ten-position", "ten-position-9+9"]
        .iter()
        .map(|name| compare(name, &scorer, space.max_dwell_s))
        .collect::<Result<Vec<_>, _>>()?;
    let design = report(scheme, &info, &target, req, &scorer, comparisons);
    Ok((design, info))
}

/// What stands in the way of an impossible target: the parameters the
/// 19-position reference scheme still leaves above their goal with dwells
/// of `dwell_s`, worst first.
fn out_of_reach(scorer: &Scorer, dwell_s: f64) -> Result<String, DesignError> {
    let reference = Scheme::builtin("ten-position-9+9", dwell_s).expect("a built-in scheme");
    let info = scorer.information(&reference)?;
    let goals = scorer.detect.iter().flat_map(|d| &d.goals);
    let mut over: Vec<(f64, String)> = scorer
        .ratios(&info)
        .into_iter()
        .zip(
            PARAMETERS
                .iter()
                .map(|p| p.name.to_string())
                .chain(goals.map(|g| format!("detect {g}"))),
        )
        .filter(|(r, _)| *r > 1.0)
        .collect();
    over.sort_by(|a, b| b.0.total_cmp(&a.0));
    let listed: Vec<String> = over
        .iter()
        .take(6)
        .map(|(r, name)| format!("{name} {r:.1}×"))
        .collect();
    Ok(format!(
        "ten-position-9+9 with {dwell_s:.0} s dwells ({:.1} h) still leaves its σ above the \
         goal for {}",
        info.duration_s / 3600.0,
        if listed.is_empty() {
            "no parameter (the sequences searched are shorter)".to_string()
        } else {
            listed.join(", ")
        }
    ))
}

/// A built-in scheme on the same goal: the uniform dwell it needs, up to
/// `max_dwell_s`.
fn compare(name: &str, scorer: &Scorer, max_dwell_s: f64) -> Result<Comparison, DesignError> {
    let builtin = |d: f64| Scheme::builtin(name, d).expect("a built-in scheme");
    let worst_600 = scorer.worst(&scorer.information(&builtin(DEFAULT_DWELL_S))?);
    let min_dwell = EstimateOptions::default().detect.min_dwell_s;
    let needed = search::shortest_dwell(scorer, min_dwell, max_dwell_s, builtin)?;
    // Whole seconds, as a table's controller takes them.
    let (dwell_s, duration_s) = match needed {
        Some((d, _)) => {
            let d = d.ceil();
            (Some(d), Some(scorer.information(&builtin(d))?.duration_s))
        }
        None => (None, None),
    };
    Ok(Comparison {
        scheme: name.to_string(),
        dwell_s,
        duration_s,
        worst_ratio_at_600_s: worst_600,
    })
}

fn report(
    scheme: Scheme,
    info: &Information,
    target: &Target,
    req: &DesignRequest,
    scorer: &Scorer,
    comparisons: Vec<Comparison>,
) -> Design {
    let ratios = scorer.ratios(info);
    let parameters: BTreeMap<String, PredictedParameter> = PARAMETERS
        .iter()
        .enumerate()
        .map(|(i, p)| {
            (
                p.name.to_string(),
                PredictedParameter {
                    sigma: info.sigma_canonical(i),
                    target: target.accuracy[i],
                    ratio: ratios[i],
                    unit: p.unit.to_string(),
                },
            )
        })
        .collect();
    let worst = ratios.iter().copied().fold(0.0, f64::max);
    let goals = scorer.detect.iter().flat_map(|d| &d.goals);
    let binding = PARAMETERS
        .iter()
        .map(|p| p.name.to_string())
        .chain(goals.map(|g| g.to_string()))
        .zip(&ratios)
        .filter(|(_, r)| **r >= 0.95 * worst)
        .map(|(name, _)| name)
        .collect();
    Design {
        scheme,
        duration_s: info.duration_s,
        target: target.name.clone(),
        margin: req.margin,
        by_hand: req.by_hand,
        parameters,
        detect: Vec::new(),
        binding,
        comparisons,
        evaluations: scorer.evaluations.get(),
    }
}
