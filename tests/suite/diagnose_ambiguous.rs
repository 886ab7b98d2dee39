//! Two candidates the scheme cannot tell apart, and the turn that parts
//! them. On X+90, Y+180, X+180 at one rate, accelerometers displaced
//! along their own axes make velocity steps at the turns that an
//! accelerometer delay makes as well: the lever arm's step grows with the
//! rate squared and the delay's with the rate, and every turn here has
//! the same rate. The workflow must say "ambiguous", name neither, and
//! suggest a turn; adding that turn to the scheme must let the same
//! unit's lever arm be named and fitted.
//!
//! And the converse: where the signatures differ, no ambiguity is made
//! up. On one-way quarter turns about x a gyro scale asymmetry is the
//! scale factor itself (each |Δθ_x| is Δθ_x), so it explains nothing and
//! an accelerometer drift is named outright.

use crate::diagnosis_support;

use diagnosis_support::*;
use sinscal_core::diagnose::candidates::values_in;
use sinscal_core::diagnose::Verdict;
use sinscal_core::model::effects::{BiasDrift, LeverArms};
use sinscal_core::model::Effects;
use sinscal_core::sim::scheme::{Axis, Rotate, Step};
use sinscal_core::sim::Scheme;

fn table_turns(name: &str, turns: &[(Axis, f64)], dwell_s: f64) -> Scheme {
    let mut steps = vec![Step::Dwell { dwell_s }];
    for &(axis, angle_deg) in turns {
        steps.push(Step::Rotate {
            rotate: Rotate {
                axis,
                angle_deg,
                rate_dps: 10.0,
                accel_dps2: 20.0,
                frame: None,
            },
        });
        steps.push(Step::Dwell { dwell_s });
    }
    Scheme {
        name: name.into(),
        steps,
    }
}

fn own_axis_lever_arm() -> Effects {
    Effects {
        accel_lever_arm: Some(LeverArms {
            x: [50.0, 0.0, 0.0],
            y: [0.0, 50.0, 0.0],
            z: [0.0, 0.0, 50.0],
        }),
        ..Effects::none()
    }
}

#[test]
fn one_rate_cannot_part_a_lever_arm_from_a_delay_and_the_suggested_turn_does() {
    for seed in 1..=4 {
        ambiguous_then_parted(seed);
    }
}

fn ambiguous_then_parted(seed: u64) {
    let turns = [(Axis::X, 90.0), (Axis::Y, 180.0), (Axis::X, 180.0)];
    let cfg = config(
        table_turns("x-y-x", &turns, 300.0),
        own_axis_lever_arm(),
        seed,
    );
    let rep = run(&cfg);
    assert!(rep.named.is_empty(), "seed {seed}: {}", rep.verdict);
    assert!(
        matches!(rep.verdict, Verdict::Ambiguous { .. }),
        "seed {seed}: {}",
        rep.verdict
    );
    let step = rep.steps.last().unwrap();
    let mut pair: Vec<String> = step.indistinguishable.clone();
    pair.push(
        step.candidates
            .iter()
            .max_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic))
            .unwrap()
            .effect
            .clone(),
    );
    pair.sort();
    pair.dedup();
    assert_eq!(pair, ["accel_delay", "accel_lever_arm"], "seed {seed}");
    let turn = step
        .separating_turns
        .first()
        .expect("a separating turn is suggested");
    eprintln!("suggested: {}", turn.describe());
    assert!(turn.sigma_apart > 3.0);

    // The same unit, the scheme with the suggested turn added.
    let mut scheme = cfg.scheme.clone();
    scheme.steps.push(Step::Rotate {
        rotate: turn.rotate,
    });
    scheme.steps.push(Step::Dwell {
        dwell_s: turn.dwell_s,
    });
    let cfg2 = config(scheme, own_axis_lever_arm(), seed + 100);
    let rep2 = run(&cfg2);
    assert_eq!(
        rep2.named,
        ["accel_lever_arm"],
        "seed {seed}: {}",
        rep2.verdict
    );
    let truth = values_in(&cfg2.effects, &rep2.named_candidates[0]).unwrap();
    let lib = sinscal_core::diagnose::candidates::library();
    let cand = lib
        .iter()
        .find(|c| c.name == rep2.named_candidates[0])
        .unwrap();
    for (p, t) in cand.params.iter().zip(truth) {
        let e = &rep2.calibration.effects[&p.name];
        let z = (e.value - t) / e.sigma;
        eprintln!(
            "{}: {:.3} ± {:.3}, truth {t} ({z:+.2}σ)",
            p.name, e.value, e.sigma
        );
        assert!(z.abs() < 3.0, "{} off by {z:.2}σ", p.name);
    }
    assert!(rep2.gap_rms_after <= 1.2 * rep2.noise_floor_rms);
}

#[test]
fn asymmetry_on_one_way_turns_is_the_scale_factor_and_drift_is_named() {
    let drift = Effects {
        bias_drift: Some(BiasDrift {
            gyro: [0.0; 3],
            accel: [12.0, 12.0, 12.0],
        }),
        ..Effects::none()
    };
    for seed in 1..=4 {
        let cfg = config(
            table_turns("x-quarter-turns", &[(Axis::X, 90.0); 4], 300.0),
            drift,
            seed,
        );
        let rep = run(&cfg);
        assert_eq!(rep.named, ["bias_drift"], "seed {seed}: {}", rep.verdict);
        let asymmetry = rep.steps[0]
            .candidates
            .iter()
            .find(|c| c.effect == "gyro_scale_asymmetry")
            .unwrap();
        assert!(asymmetry.delta_chi2 < 1.0, "seed {seed}: {asymmetry:?}");
    }
}
