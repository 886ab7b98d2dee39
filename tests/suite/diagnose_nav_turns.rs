//! A table that turns the unit about navigation-frame axes (SPEC §4,
//! `"frame": "nav"`), with the unit mounted 10° off nominal heading: its
//! turns are 10° from any body axis, so the scheme is reconstructed in n.
//! A clean run names nothing; a delay is named and fitted.

use crate::diagnosis_support;

use diagnosis_support::*;
use sinscal_core::diagnose::Verdict;
use sinscal_core::model::Effects;
use sinscal_core::sim::scheme::{Axis, Frame, Step};
use sinscal_core::sim::SimConfig;

fn off_heading(effects: Effects, seed: u64) -> SimConfig {
    SimConfig {
        initial_attitude_error_deg: [0.3, -0.2, 10.0],
        ..config(nav_turns(300.0), effects, seed)
    }
}

fn assert_reconstructed_in_n(rep: &sinscal_core::diagnose::DiagnoseReport, cfg: &SimConfig) {
    let truth: Vec<(Axis, f64)> = cfg
        .scheme
        .steps
        .iter()
        .filter_map(|s| match s {
            Step::Rotate { rotate } => Some((rotate.axis, rotate.angle_deg)),
            Step::Dwell { .. } | Step::Flip { .. } => None,
        })
        .collect();
    let found = &rep
        .scheme
        .as_ref()
        .expect("table turns about n axes are described as a scheme")
        .rotations;
    assert_eq!(found.len(), truth.len());
    for (f, (axis, angle)) in found.iter().zip(truth) {
        assert_eq!((f.axis, f.frame), (axis, Frame::Nav), "{f:?}");
        assert!((f.angle_deg - angle).abs() < 0.05, "{f:?}");
        assert!(f.off_axis_deg < 0.1, "{f:?}");
    }
}

#[test]
fn clean_run_on_nav_turns_names_nothing() {
    let cfg = off_heading(Effects::none(), 21);
    let rep = run(&cfg);
    assert_reconstructed_in_n(&rep, &cfg);
    assert_eq!(rep.verdict, Verdict::NoSignificantEffect);
    assert!(rep.gap_rms_before < 1.2 * rep.noise_floor_rms);
}

#[test]
fn delay_on_nav_turns_is_named() {
    let effects = Effects {
        accel_delay: Some(2.0),
        ..Effects::none()
    };
    let cfg = off_heading(effects, 22);
    let rep = run(&cfg);
    assert_reconstructed_in_n(&rep, &cfg);
    assert_found(&rep, &cfg, &["accel_delay"]);
}
