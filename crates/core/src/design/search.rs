//! The search for the shortest scheme: a beam search over rotation
//! sequences, then the dwells.
//!
//! A scheme is a dwell, then turns each followed by a dwell. For a given
//! sequence of turns the predicted σ falls as the dwells grow, so the
//! shortest uniform dwell that meets the goal is found by bisection; the
//! sequence is grown one turn at a time, keeping the `beam` best partial
//! sequences, each ranked by how far all its parameters still are from
//! their goals (a smooth sum over parameters, so that a turn that helps
//! several parameters counts for more than one that helps the worst
//! alone). Every length's best sequence is timed, the shortest kept, and
//! its dwells are then shortened one by one while the goal still holds.
//!
//! A design meets the same schemes again: the second search bisects
//! sequences the first already timed, and after a `--detect` check the
//! searches rerun with only the goals' correction changed, which the
//! scheme's information does not depend on. Each scheme is scored once
//! per design (`Scored`).

use std::cell::RefCell;
use std::collections::HashMap;

use sha2::{Digest, Sha256};

use crate::calib::CalibError;
use crate::sim::scheme::{Axis, Frame, Rotate, Step};
use crate::sim::Scheme;

use super::detect::Detection;
use super::information::{scheme_information, Information, ObjectiveSettings};

/// One turn of a candidate sequence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Turn {
    pub axis: Axis,
    pub frame: Frame,
    pub angle_deg: f64,
}

/// What the search may use and must respect.
#[derive(Clone, Debug)]
pub struct SearchSpace {
    /// The turns a step may make.
    pub turns: Vec<Turn>,
    pub rate_dps: f64,
    pub accel_dps2: f64,
    pub min_dwell_s: f64,
    /// Longest dwell the bisection considers, s.
    pub max_dwell_s: f64,
    /// Most turns in a scheme.
    pub max_turns: usize,
    /// Partial sequences kept at each length.
    pub beam: usize,
}

impl SearchSpace {
    /// Every turn of 90°, 180° or 270°, either way, about the axes of the
    /// given frames.
    pub fn turns_about(frames: &[Frame]) -> Vec<Turn> {
        let mut turns = Vec::new();
        for &frame in frames {
            let axes = match frame {
                Frame::Body => [Axis::X, Axis::Y, Axis::Z],
                Frame::Nav => [Axis::E, Axis::N, Axis::U],
            };
            for axis in axes {
                for angle in [90.0, -90.0, 180.0, -180.0, 270.0, -270.0] {
                    turns.push(Turn {
                        axis,
                        frame,
                        angle_deg: angle,
                    });
                }
            }
        }
        turns
    }
}

/// The information of every scheme scored so far in one design, by a
/// digest of the scheme's steps (SPEC §4 JSON): a scheme met again is not
/// scored again. A digest rather than the steps keeps the memory small
/// on long searches (tens of thousands of schemes of up to 96 turns).
#[derive(Default)]
pub struct Scored(RefCell<HashMap<[u8; 32], Information>>);

impl Scored {
    fn key(scheme: &Scheme) -> [u8; 32] {
        let steps = serde_json::to_vec(&scheme.steps).expect("a scheme serialises");
        Sha256::digest(&steps).into()
    }
}

/// How a candidate is scored: the predicted σ of each parameter against
/// its goal (target over margin), in `PARAMETERS` order, then each
/// effect's threshold against its goal (size over `DETECT_MARGIN`).
pub struct Scorer<'a> {
    pub settings: &'a ObjectiveSettings,
    /// Goal per parameter, SI.
    pub goal_si: Vec<f64>,
    /// Effects to be named (`settings.effects` carries their states).
    pub detect: Option<&'a Detection>,
    /// Turns a scheme into what is really run (hand turns); identity for
    /// a turntable.
    pub realise: &'a dyn Fn(&Scheme) -> Result<Scheme, String>,
    /// Schemes asked for so far (a scheme met again counts again).
    pub evaluations: std::cell::Cell<usize>,
    /// The schemes already scored in this design.
    pub scored: &'a Scored,
    /// When the search must give up (a server bounds what one request
    /// may cost); `None` searches to the end.
    pub deadline: Option<std::time::Instant>,
    /// Told the count of schemes scored; its cancel stops the search as
    /// the deadline does.
    pub watch: &'a super::Watch<'a>,
}

impl Scorer<'_> {
    pub fn information(&self, scheme: &Scheme) -> Result<Information, CalibError> {
        if self
            .deadline
            .is_some_and(|d| std::time::Instant::now() >= d)
            || self.watch.cancelled()
        {
            return Err(CalibError::Cancelled);
        }
        self.evaluations.set(self.evaluations.get() + 1);
        self.watch.scored(self.evaluations.get());
        let key = Scored::key(scheme);
        if let Some(info) = self.scored.0.borrow().get(&key) {
            return Ok(info.clone());
        }
        let run = (self.realise)(scheme).map_err(CalibError::Unusable)?;
        let info = scheme_information(&run, self.settings)?;
        self.scored.0.borrow_mut().insert(key, info.clone());
        Ok(info)
    }

    /// σ over goal, per parameter, then threshold over goal per effect.
    pub fn ratios(&self, info: &Information) -> Vec<f64> {
        let mut ratios: Vec<f64> = info
            .sigma_si
            .iter()
            .zip(&self.goal_si)
            .map(|(s, g)| s / g)
            .collect();
        if let Some(d) = self.detect {
            ratios.extend(d.ratios(info));
        }
        ratios
    }

    /// The largest σ over goal: the scheme meets the goal when ≤ 1.
    pub fn worst(&self, info: &Information) -> f64 {
        self.ratios(info).into_iter().fold(0.0, f64::max)
    }

    /// The beam's ranking: Σ softplus(ln ratio) — about ln ratio for a
    /// parameter far from its goal, fading to nothing for one well inside.
    fn rank(&self, info: &Information) -> f64 {
        self.ratios(info)
            .into_iter()
            .map(|r| (1.0 + r.max(1e-12)).ln())
            .sum()
    }
}

/// The scheme of `turns` with the given dwells (one more than turns).
pub fn build(name: &str, turns: &[Turn], dwells: &[f64], space: &SearchSpace) -> Scheme {
    let mut steps = vec![Step::Dwell { dwell_s: dwells[0] }];
    for (t, d) in turns.iter().zip(&dwells[1..]) {
        steps.push(Step::Rotate {
            rotate: Rotate {
                axis: t.axis,
                angle_deg: t.angle_deg,
                rate_dps: space.rate_dps,
                accel_dps2: space.accel_dps2,
                frame: Some(t.frame),
            },
        });
        steps.push(Step::Dwell { dwell_s: *d });
    }
    Scheme {
        name: name.to_string(),
        steps,
    }
}

/// The shortest dwell in [`lo`, `hi`] (to 1 %) at which the scheme
/// `scheme_at(dwell)` meets the goal, with its information there; `None`
/// if even `hi` does not. σ falls as dwells grow, so bisection (on a log
/// scale) finds it.
pub fn shortest_dwell(
    scorer: &Scorer,
    lo: f64,
    hi: f64,
    scheme_at: impl Fn(f64) -> Scheme,
) -> Result<Option<(f64, Information)>, CalibError> {
    let at = |d: f64| scorer.information(&scheme_at(d));
    let (mut lo, mut hi) = (lo, hi);
    let top = at(hi)?;
    if scorer.worst(&top) > 1.0 {
        return Ok(None);
    }
    let bottom = at(lo)?;
    if scorer.worst(&bottom) <= 1.0 {
        return Ok(Some((lo, bottom)));
    }
    let mut best = (hi, top);
    while hi / lo > 1.01 {
        let mid = (lo * hi).sqrt();
        let info = at(mid)?;
        if scorer.worst(&info) <= 1.0 {
            hi = mid;
            best = (mid, info);
        } else {
            lo = mid;
        }
    }
    Ok(Some(best))
}

/// The shortest uniform dwell at which `turns` meets the goal.
pub fn shortest_uniform_dwell(
    turns: &[Turn],
    space: &SearchSpace,
    scorer: &Scorer,
) -> Result<Option<(f64, Information)>, CalibError> {
    shortest_dwell(scorer, space.min_dwell_s, space.max_dwell_s, |d| {
        build("probe", turns, &vec![d; turns.len() + 1], space)
    })
}

/// The best sequence found for one number of turns.
#[derive(Clone, Debug)]
pub struct Candidate {
    pub turns: Vec<Turn>,
    pub dwells: Vec<f64>,
    pub information: Information,
}

/// Beam search over turn sequences at a probe dwell; each length's best
/// few are timed by bisection, the shortest overall returned. Stops
/// growing once four lengths in a row have not improved on the best.
pub fn search_sequences(
    space: &SearchSpace,
    scorer: &Scorer,
    probe_dwell_s: f64,
) -> Result<Option<Candidate>, CalibError> {
    let mut beam: Vec<Vec<Turn>> = vec![Vec::new()];
    let mut best: Option<Candidate> = None;
    let mut since_best = 0;
    for _ in 0..space.max_turns {
        let mut grown: Vec<(f64, Vec<Turn>)> = Vec::new();
        for seq in &beam {
            for turn in &space.turns {
                // Undoing the previous turn adds nothing a dwell would not.
                if seq.last().is_some_and(|l| {
                    l.axis == turn.axis && l.frame == turn.frame && l.angle_deg == -turn.angle_deg
                }) {
                    continue;
                }
                let mut next = seq.clone();
                next.push(*turn);
                let dwells = vec![probe_dwell_s; next.len() + 1];
                let info = scorer.information(&build("probe", &next, &dwells, space))?;
                grown.push((scorer.rank(&info), next));
            }
        }
        grown.sort_by(|a, b| a.0.total_cmp(&b.0));
        grown.truncate(space.beam);
        beam = grown.into_iter().map(|(_, s)| s).collect();
        let mut improved = false;
        for seq in &beam {
            if let Some((d, information)) = shortest_uniform_dwell(seq, space, scorer)? {
                let shorter = !best
                    .as_ref()
                    .is_some_and(|b| information.duration_s >= b.information.duration_s);
                if shorter {
                    best = Some(Candidate {
                        turns: seq.clone(),
                        dwells: vec![d; seq.len() + 1],
                        information,
                    });
                    improved = true;
                }
            }
        }
        since_best = if improved { 0 } else { since_best + 1 };
        if best.is_some() && since_best >= 4 {
            break;
        }
    }
    Ok(best)
}

/// Shortens the dwells one at a time (by a tenth, while the goal holds,
/// never below the minimum) until no dwell can be shortened.
pub fn trim_dwells(
    mut c: Candidate,
    space: &SearchSpace,
    scorer: &Scorer,
) -> Result<Candidate, CalibError> {
    let mut changed = true;
    let mut rounds = 0;
    while changed && rounds < 20 {
        changed = false;
        rounds += 1;
        for i in 0..c.dwells.len() {
            let shorter = (c.dwells[i] * 0.9).max(space.min_dwell_s);
            if shorter >= c.dwells[i] {
                continue;
            }
            let mut dwells = c.dwells.clone();
            dwells[i] = shorter;
            let info = scorer.information(&build("probe", &c.turns, &dwells, space))?;
            if scorer.worst(&info) <= 1.0 {
                c.dwells = dwells;
                c.information = info;
                changed = true;
            }
        }
    }
    Ok(c)
}
