//! Where the gap lives: the stretches between nodes as pieces of dwells
//! and rotation steps, the gap summed per segment, and the words that say
//! whether it sits in motion or at rest, on which axis, and whether it
//! grows over the run.

use super::gap::{GapFit, Nodes};
use super::report::{Localisation, SegmentGap};
use crate::calib::{RunSegment, SegmentKind};

/// Rotations' share of the excess χ² above which the gap is said to live
/// in rotations, and below which in dwells: a clear majority either way,
/// so that a gap split 60/40 is reported as both.
const MOSTLY_ROTATIONS: f64 = 0.7;
const MOSTLY_DWELLS: f64 = 0.3;

/// The gap "grows with time" when the second half's mean normalised
/// excess is more than this multiple of the first half's: a doubling is
/// well beyond the scatter of a few dwells' excesses.
const GROWTH_FACTOR: f64 = 2.0;

/// The first half's excess is taken as at least this before the
/// comparison, so a first half at the noise (excess near 0) does not
/// make any second half "growing".
const GROWTH_FLOOR: f64 = 0.5;

/// What each stretch between nodes is: a piece of dwell d or the rotation
/// step out of dwell d (d the ordinal among dwells, 0-based).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum StretchKind {
    Dwell(usize),
    Rotation(usize),
}

pub(crate) fn stretch_kinds(nodes: &Nodes, segments: &[RunSegment]) -> Vec<StretchKind> {
    let ordinal: Vec<usize> = segments
        .iter()
        .scan(0usize, |n, s| {
            let o = *n;
            if s.kind == SegmentKind::Dwell {
                *n += 1;
            }
            Some(o)
        })
        .collect();
    (0..nodes.t.len() - 1)
        .map(|k| {
            let (a, b) = (nodes.segment[k], nodes.segment[k + 1]);
            if a == b {
                StretchKind::Dwell(ordinal[a])
            } else {
                StretchKind::Rotation(ordinal[a])
            }
        })
        .collect()
}

pub(crate) fn segment_gaps(
    fit: &GapFit,
    nodes: &Nodes,
    kinds: &[StretchKind],
    t0: f64,
) -> Vec<SegmentGap> {
    let mut out: Vec<SegmentGap> = Vec::new();
    for (k, kind) in kinds.iter().enumerate() {
        let (name, index) = match kind {
            StretchKind::Dwell(d) => ("dwell", d + 1),
            StretchKind::Rotation(d) => ("rotation", d + 1),
        };
        let r = fit.residual[k];
        let c = &fit.residual_cov[k];
        let new = !matches!(out.last(), Some(s) if s.kind == name && s.index == index);
        if new {
            out.push(SegmentGap {
                kind: name.into(),
                index,
                t_start: nodes.t[k] - t0,
                t_end: nodes.t[k + 1] - t0,
                gap_mps: [0.0; 3],
                sigma_mps: [0.0; 3],
                chi2: 0.0,
                dof: 0.0,
            });
        }
        let s = out.last_mut().expect("pushed above");
        s.t_end = nodes.t[k + 1] - t0;
        for i in 0..3 {
            s.gap_mps[i] += r[3 + i];
            s.sigma_mps[i] += c[(3 + i, 3 + i)];
        }
        // The stretch's share of the run's χ², in the run's own weight.
        // Not each component over its own residual variance: the fitted
        // node attitudes leave the attitude rows with a variance that is
        // a difference of nearly equal numbers, zero or below it, and a
        // rounding-sized residual over it gave χ² of 1e270.
        s.chi2 += fit.stretch_chi2[k];
        s.dof += fit.stretch_dof[k];
    }
    for s in &mut out {
        for v in &mut s.sigma_mps {
            *v = v.max(0.0).sqrt();
        }
    }
    out
}

pub(crate) fn localise(
    fit: &GapFit,
    nodes: &Nodes,
    kinds: &[StretchKind],
    segs: &[SegmentGap],
    t0: f64,
    t_total: f64,
    z_sig: f64,
) -> Localisation {
    let mut loc = Localisation::default();
    let (mut first, mut n_first, mut second, mut n_second) = (0.0, 0usize, 0.0, 0usize);
    let mut axis_num = [0.0; 3];
    let mut axis_den = [0.0; 3];
    for (k, kind) in kinds.iter().enumerate() {
        let r = fit.residual[k];
        let c = &fit.residual_cov[k];
        let (chi2, exp) = (fit.stretch_chi2[k], fit.stretch_dof[k]);
        for i in 0..3 {
            axis_num[i] += r[3 + i] * r[3 + i];
            axis_den[i] += c[(3 + i, 3 + i)].max(0.0);
        }
        match kind {
            StretchKind::Rotation(_) => loc.excess_rotations += chi2 - exp,
            StretchKind::Dwell(_) => {
                loc.excess_dwells += chi2 - exp;
                let tm = 0.5 * (nodes.t[k] + nodes.t[k + 1]) - t0;
                if tm < 0.5 * t_total {
                    first += (chi2 - exp) / exp.max(1.0);
                    n_first += 1;
                } else {
                    second += (chi2 - exp) / exp.max(1.0);
                    n_second += 1;
                }
            }
        }
    }
    for i in 0..3 {
        loc.axis_ratio[i] = axis_num[i] / axis_den[i].max(f64::MIN_POSITIVE);
    }
    loc.excess_first_half = first / n_first.max(1) as f64;
    loc.excess_second_half = second / n_second.max(1) as f64;
    for s in segs {
        let dof = s.dof.max(1.0);
        if (s.chi2 - dof) / (2.0 * dof).sqrt() > z_sig {
            loc.segments.push(format!(
                "{} {} ({:.0}-{:.0} s): gap [{:.2e}, {:.2e}, {:.2e}] m/s vs sigma [{:.1e}, {:.1e}, {:.1e}]",
                s.kind,
                s.index,
                s.t_start,
                s.t_end,
                s.gap_mps[0],
                s.gap_mps[1],
                s.gap_mps[2],
                s.sigma_mps[0],
                s.sigma_mps[1],
                s.sigma_mps[2]
            ));
        }
    }
    let total = loc.excess_rotations.max(0.0) + loc.excess_dwells.max(0.0);
    let mut parts = Vec::new();
    if total <= 0.0 || loc.segments.is_empty() {
        parts.push("no segment stands out of the noise".to_string());
    } else {
        let rot = loc.excess_rotations.max(0.0) / total;
        parts.push(if rot > MOSTLY_ROTATIONS {
            format!("during rotations ({:.0}% of the excess)", 100.0 * rot)
        } else if rot < MOSTLY_DWELLS {
            format!("during dwells ({:.0}% of the excess)", 100.0 * (1.0 - rot))
        } else {
            format!(
                "in rotations and dwells alike ({:.0}% in rotations)",
                100.0 * rot
            )
        });
        let names = ["east", "north", "up"];
        let worst = (0..3)
            .max_by(|&a, &b| loc.axis_ratio[a].total_cmp(&loc.axis_ratio[b]))
            .unwrap_or(0);
        parts.push(format!(
            "axes E/N/U at {:.1}/{:.1}/{:.1}x the noise variance (mostly {})",
            loc.axis_ratio[0], loc.axis_ratio[1], loc.axis_ratio[2], names[worst]
        ));
        let (a, b) = (loc.excess_first_half, loc.excess_second_half);
        parts.push(if b > GROWTH_FACTOR * a.max(GROWTH_FLOOR) {
            "growing with time".to_string()
        } else {
            "not growing with time".to_string()
        });
        parts.push(format!("{} segments stand out", loc.segments.len()));
    }
    loc.summary = parts.join("; ");
    loc
}
